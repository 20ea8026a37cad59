/*
  shell_util.c - the shell's hal for tests (serial output captured into a
  buffer, storage in RAM (host/storage_ram.c), a fake millisecond clock, hal_poll empty).
*/
#include "shell_util.h"

#include <string.h>

#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "storage_ram.h"
#if defined(__has_include)
#if __has_include("hal_record.h")
#include "hal_record.h"
#define HAVE_REC 1
#endif
#endif

static char out[1 << 16];
static uint32_t out_len;
static uint32_t now_ms;

void hal_serial_tx_kick(void) {
  int c;
  while ((c = serial_tx_pop()) >= 0) {
    if (out_len + 1 < sizeof out)
      out[out_len++] = (char)c;
  }
  out[out_len] = 0;
}
void hal_serial_tx_wait(void) { hal_serial_tx_kick(); }
const char *shell_out(void) { return out; }
void shell_out_clear(void) { out_len = 0; out[0] = 0; }

uint8_t *shell_storage(uint32_t *len) { return storage_area(len); }
void shell_storage_clear(void) { storage_erase(); }

uint32_t hal_millis(void) { return now_ms; }
void shell_advance_ms(uint32_t ms) { now_ms += ms; }
void (*shell_poll_hook)(void);

/* The step timer of the recording hal ticks here (nothing without it). */
void hal_poll(void) {
  if (shell_poll_hook)
    shell_poll_hook();
#ifdef HAVE_REC
  for (int i = 0; i < 128 && rec.running; i++) {
    st_tick();
    if ((i & 3) == 3 && rec.running)   /* the main loop keeps up: no starving */
      st_prep_buffer();
  }
#endif
}

void shell_send(const char *bytes) {
  for (const char *p = bytes; *p; p++) {
    serial_rx_isr((uint8_t)*p);
    if (serial_rx_count() > 100)
      for (int i = 0; i < 4; i++) protocol_poll();
  }
  for (int i = 0; i < 20; i++)
    protocol_poll();
  /* the host goes quiet: look-ahead flushes, the moves run out */
  now_ms += 100;
  for (int i = 0; i < 200000 && !(st_is_idle() && serial_rx_count() == 0); i++)
    protocol_poll();
  for (int i = 0; i < 20; i++)
    protocol_poll();
}
