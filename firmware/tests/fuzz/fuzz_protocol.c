/*
  fuzz_protocol.c - libFuzzer target: bytes through the RX interrupt into
  the whole shell (real-time bytes, panel bytes, $ commands, settings,
  jogs, check mode, alarms, the menu) and the core behind it, the main loop
  polled in between. The machine starts from power-on for every input.
*/
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"

/* 100 steps/mm instead of 2133: the core walks every arc once in the parser
   (core_api.md, "Limits"), and a fuzzed 4 m circle would cost seconds;
   coarse steps keep every input fast without changing any code path. */
static void coarse_machine(void) {
  static char s0[] = "100=100", s1[] = "101=100", s2[] = "102=100";
  if (settings_store_setting(s0) || settings_store_setting(s1) || settings_store_setting(s2))
    abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  protocol_startup();
  coarse_machine();
  for (size_t i = 0; i < size; i++) {
    serial_rx_isr(data[i]);
    if ((i & 7u) == 7u || serial_rx_count() > 100)
      protocol_poll();
  }
  for (int k = 0; k < 50; k++)
    protocol_poll();
  if (serial_rx_count() > SERIAL_RX_SIZE)
    abort();
  return 0;
}
