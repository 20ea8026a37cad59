/*
  fuzz_util.c - the shell's hal for the fuzzers and the beam property:
  output discarded, storage in RAM (host/storage_ram.c), a clock that moves 1 ms per poll. With
  hal_null.c the step timer never ticks, so when the planner is nearly full
  or motion stays queued for long the machine is reset (st_reset +
  plan_reset) and no input can make the loop wait for motion that never
  finishes; beam_property.c ticks the timer
  instead (fuzz_set_poll). fuzz_power_on() starts every input from an
  erased storage and a fresh firmware.
*/
#include "fuzz_util.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "laser.h"
#include "menu.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "status_codes.h"
#include "stepper.h"
#include "storage_ram.h"

static uint32_t now_ms;

void hal_serial_tx_kick(void) {
  while (serial_tx_pop() >= 0) {
  }
}
void hal_serial_tx_wait(void) { hal_serial_tx_kick(); }

uint32_t hal_millis(void) { return now_ms; }

/* hal_null's timer never ticks, so what is queued never runs out: a nearly full planner is
   emptied, and so is motion that stays queued for STUCK_POLLS polls in a row (a G38 line waits
   in gc_execute_line until the moves before it have ended, as GRBL's probe cycle does; an
   input's own main-loop passes are far fewer). Either ends the parser's wait as a reset does. */
#define STUCK_POLLS 1000u
static uint32_t queued_polls;
static void reset_when_stuck(void) {
  queued_polls = plan_is_empty() && st_is_idle() ? 0 : queued_polls + 1;
  if (plan_free_slots() < 4 || queued_polls > STUCK_POLLS) {
    st_reset();
    plan_reset();
    queued_polls = 0;
  }
}
static void (*poll_work)(void) = reset_when_stuck;

void fuzz_set_poll(void (*fn)(void)) { poll_work = fn ? fn : reset_when_stuck; }

void hal_poll(void) {
  now_ms++;
  poll_work();
}

void fuzz_fail(const char *what) {
  fprintf(stderr, "fuzz harness: %s\n", what);
  abort();
}

void fuzz_power_on(void) {
  storage_erase();
  now_ms = 0;
  queued_polls = 0;
  protocol_startup();
  if (protocol_state() != PROTO_IDLE || !st_is_idle() || !plan_is_empty() ||
      laser_current_duty() != 0 || menu_laser_is_on() || serial_rx_count() != 0)
    fuzz_fail("power-on did not leave the machine idle, empty and dark");
  static const char *const coarse[] = {"100=100", "101=100", "102=100"};
  for (unsigned i = 0; i < 3; i++) {
    char cmd[16];
    strcpy(cmd, coarse[i]);
    uint8_t st = settings_store_setting(cmd);
    if (st != STATUS_OK) {
      char msg[96];
      snprintf(msg, sizeof msg, "setup command $%s refused with status %u", coarse[i], (unsigned)st);
      fuzz_fail(msg);
    }
  }
  if (plan_machine()->steps_per_mm[0] != 100.0 || settings.machine.steps_per_mm[2] != 100.0)
    fuzz_fail("setup: 100 steps/mm not in effect after $100-$102");
  while (serial_tx_pop() >= 0) {   /* the banner and the settings message */
  }
}
