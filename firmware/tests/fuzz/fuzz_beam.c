/*
  fuzz_beam.c - libFuzzer target: the beam-state property (beam_property.h)
  for any input. The bytes go to the serial RX interrupt as a host sends
  them (0xFE b: b on the panel channel); the step timer ticks as in the
  simulator; after every tick, every change of the laser duty and every
  main-loop pass the beam must be on only where the accepted program
  commands it. A violation aborts with what was wrong. Every input starts
  from power-on with erased storage.
*/
#include <stddef.h>
#include <stdint.h>

#include "beam_property.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  beam_power_on();
  beam_run(data, size);
  return 0;
}
