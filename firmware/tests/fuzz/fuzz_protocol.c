/*
  fuzz_protocol.c - libFuzzer target: bytes through the RX interrupt into
  the whole shell (real-time bytes, $ commands, settings, jogs, check
  mode, alarms, the menu's $LCD) and the core behind it, the main loop
  polled in between. Every input starts from power-on with erased storage
  (fuzz_power_on), so what one input stores cannot refuse the next one's
  setup. Panel events have their own channel (fuzz_beam drives it): bytes
  0xB0..0xB8 here are serial bytes like any other.
*/
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  fuzz_power_on();
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
