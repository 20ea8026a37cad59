/*
  machine.h - the machine as the core sees it: the fields of
  labkit.motion.MachineSpec (see labkit/motion/spec.py for their meaning).

  The live copy is plan_machine() (planner.h); machine.c fills one from
  defaults.h and checks one. Units are in the names: mm, mm/min, mm/s^2, Hz, mW.
*/
#ifndef LK_MACHINE_H
#define LK_MACHINE_H

#include <stdint.h>

typedef struct {
  char name[24];
  double steps_per_mm[3];
  double max_rate_mm_min[3];
  double accel_mm_s2[3];
  double travel_mm[3];
  int32_t accel_hz_per_step;     /* linear law: Hz per step, >= 1 */
  int32_t decel_hz_per_step;
  int32_t start_rate_hz;         /* floor of every step rate, Hz */
  double junction_deviation_mm;  /* GRBL $11 */
  double arc_tolerance_mm;       /* GRBL $12 (kept; arcs are walked, not cut) */
  int32_t buffer_blocks;         /* look-ahead depth, 1 .. PLAN_MAX_DEPTH */
  double laser_max_power_mw;
  uint32_t timer_clock_hz;
  uint32_t prescaler;            /* 0 .. 65535 */
  uint32_t timer_bits;           /* 16 or 32 */
  double step_pulse_us;
} lk_machine_t;

/* Fill *m with the values of defaults.h. */
void machine_load_defaults(lk_machine_t *m);

/* 0 when *m is usable (the checks of Machine.__post_init__), else
   STATUS_MAX_VALUE_EXCEEDED (a value out of range). */
uint8_t machine_check(const lk_machine_t *m);

/* Fastest step rate of axis i, Hz: floor(max_rate / 60 * steps_per_mm + 1e-9). */
int32_t machine_max_step_rate_hz(const lk_machine_t *m, int axis);

#endif /* LK_MACHINE_H */
