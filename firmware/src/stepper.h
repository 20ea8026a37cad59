/*
  stepper.h - step generation of the labkit firmware.

  Main loop: st_prep_buffer() takes planned blocks and prepares their ticks
  into a ring buffer: timer period, step rate and laser duty (the ramp
  arithmetic of labkit.motion.timer), and the tick's step and direction bits
  from the 3-axis Bresenham of a line or the octant walk of an arc (arc.c,
  plus the helix axis by the line rule); then it starts the step timer.
  Interrupt: st_tick() (see hal.h for when it is called) pulses the steps of
  the tick that ended, counts them into the position, and loads the next
  prepared tick: its directions, duty and period. No arithmetic there beyond
  that, no floating point, no loops over blocks; while a probe cycle runs it
  also reads the probe input (st_probe_arm).

  Feed hold decelerates at the block's slope down to its floor rate, keeps
  the rest of the job and resumes with a ramp; reset drops everything at
  once. Positions are counted in steps by the interrupt.
*/
#ifndef LK_STEPPER_H
#define LK_STEPPER_H

#include <stdint.h>

#define ST_IDLE    0
#define ST_RUN     1
#define ST_HOLDING 2   /* decelerating for a feed hold */
#define ST_HELD    3
#define ST_DWELL   4

/* What the stepper knows of the block it is running (reports, tests). */
typedef struct {
  uint32_t seq;                  /* blocks started since st_init, from 1 */
  uint8_t kind;                  /* PLAN_BLOCK_* */
  uint8_t rapid, laser, dir_bits;
  uint32_t line;
  int32_t super_block;
  int32_t start_steps[3], end_steps[3];
  uint32_t ticks;
  uint32_t f_entry, f_peak, f_exit, f_min, up, down, f_feed;
  double power_mw;
  double length_mm, entry_mm_s, peak_mm_s, exit_mm_s;
  uint64_t dwell_cycles;
} st_block_info_t;

void st_init(void);
void st_prep_buffer(void);
void st_tick(void);

void st_feed_hold(void);
void st_resume(void);
void st_reset(void);
uint8_t st_take_abort(void);       /* 1 once after st_reset (ends the parser's waits) */

/* G38.x probing, read in the step interrupt as GRBL reads it: st_probe_arm() (main, before
   the probe move starts) has st_tick() read hal_probe_read() after each tick's steps; the
   first read equal to pin_level keeps the position and disarms. st_probe_tripped() gives
   that position (steps) once; st_probe_disarm() forgets both. */
void st_probe_arm(uint8_t pin_level);
void st_probe_disarm(void);
uint8_t st_probe_tripped(int32_t steps[3]);

uint8_t st_state(void);
uint8_t st_is_idle(void);
void st_get_position(int32_t steps[3]);
void st_get_position_mm(float mm[3]);
/* (main, idle only) The machine position becomes steps: homing sets it at the switches. */
void st_set_position(const int32_t steps[3]);
uint32_t st_current_rate_hz(void);
uint32_t st_current_line(void);

/* The block of the tick now running, NULL when idle. */
const st_block_info_t *st_running_block(void);
/* Laser power (mW) of the tick now running: for simulators and tests. */
double st_current_power_mw(void);

#endif /* LK_STEPPER_H */
