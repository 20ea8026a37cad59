/*
  hal_record.h - a hal.h that records instead of driving pins (tests only).

  Every tick started by the core (hal_timer_set_period inside st_tick or at
  start) becomes a rec_tick_t: the stepper's running block, the period, the
  step rate and laser power of the tick (asked from the stepper), the laser
  duty on the output, the clock cycles from the start to the tick's end, and
  - when hal_step_pulse comes at its end - the signed step of each axis.
  hal_record_run() plays the timer: it calls st_tick() until the core stops it.
*/
#ifndef HAL_RECORD_H
#define HAL_RECORD_H

#include <stdint.h>
#include "stepper.h"

typedef struct {
  uint32_t seq;          /* st_block_info_t.seq of the block */
  uint32_t period, rate;
  double power_mw;
  uint16_t duty;
  int8_t step[3];
  uint8_t pulsed;
  uint64_t cycles_end;
} rec_tick_t;

typedef struct {
  rec_tick_t *ticks;
  uint32_t n_ticks;
  st_block_info_t *blocks;   /* one per seq, in order */
  uint32_t n_blocks;
  uint64_t cycles;
  uint8_t running, dir;
  uint16_t duty;
  uint8_t air;
  uint32_t gate_hz;
  uint32_t starts, stops, double_pulses, stray_pulses;
  uint8_t after_stop;        /* the next period starts a new tick */
  uint32_t max_hal_period;   /* largest value written to the period register */
  uint32_t hal_periods;      /* periods written (a long tick takes several) */
} rec_t;

extern rec_t rec;

void hal_record_reset(void);
void hal_record_run(void);        /* st_tick() while the timer runs */
void hal_record_pump(void);       /* st_prep_buffer + run until nothing moves */
void hal_record_ticks(uint32_t n);  /* at most n ticks while the timer runs, st_prep_buffer
                                       after each (a job stopped part way) */

/* The core started on this hal, after plan_init() and any planner settings: stepper, laser,
   the parser in `dialect` (GC_DIALECT_*), its waits for a planner slot running the timer. */
void hal_record_start_core(uint8_t dialect);
/* One line through the parser, from a writable copy (gc_execute_line edits its line). */
uint8_t hal_record_line(const char *text);

#endif
