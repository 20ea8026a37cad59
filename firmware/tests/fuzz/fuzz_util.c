/*
  fuzz_util.c - the shell's hal for the fuzzers: output discarded, storage
  in RAM, a clock that moves 1 ms per poll; the step timer of hal_null.c
  never ticks. When the planner is nearly full the machine is reset
  (st_reset + plan_reset), so that no input can make the loop wait for
  motion the fuzzer never finishes.
*/
#include <stdint.h>
#include <string.h>

#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"

static uint8_t storage[4096];
static uint32_t storage_len;
static uint32_t now_ms;

void hal_serial_tx_kick(void) {
  while (serial_tx_pop() >= 0) {
  }
}
void hal_serial_tx_wait(void) { hal_serial_tx_kick(); }

uint8_t hal_storage_read(void *buf, uint32_t len) {
  if (len > storage_len)
    return 0;
  memcpy(buf, storage, len);
  return 1;
}
uint8_t hal_storage_write(const void *buf, uint32_t len) {
  if (len > sizeof storage)
    return 0;
  memcpy(storage, buf, len);
  storage_len = len;
  return 1;
}

uint32_t hal_millis(void) { return now_ms; }

void hal_poll(void) {
  now_ms++;
  if (plan_free_slots() < 4) {
    st_reset();
    plan_reset();
  }
}
