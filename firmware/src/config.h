/*
  config.h - compile-time sizes and features of the labkit firmware core.

  Buffer sizes trade RAM for look-ahead and for how far the main loop may
  fall behind the step interrupt. Machine values (steps/mm, rates, laser)
  are in defaults.h and can be changed at run time (plan_machine()).
*/
#ifndef LK_CONFIG_H
#define LK_CONFIG_H

/* Planner ring buffer: motion and dwell blocks waiting to run, the one
   running included. The look-ahead depth (G5 P, buffer_blocks) can be at
   most PLAN_BUFFER_SIZE - 2: planning block k needs blocks k .. k + depth. */
#ifndef PLAN_BUFFER_SIZE
#define PLAN_BUFFER_SIZE 36
#endif
#define PLAN_MAX_DEPTH (PLAN_BUFFER_SIZE - 2)

/* Prepared ticks (period, rate, laser duty) waiting for the step interrupt.
   Power of two. */
#ifndef ST_TICK_BUFFER_SIZE
#define ST_TICK_BUFFER_SIZE 256
#endif

/* How far ahead of the motors the main loop prepares ticks, in ms of motion:
   a feed hold starts decelerating at most this late. The main loop must call
   st_prep_buffer() more often than this. */
#ifndef ST_PREP_LEAD_MS
#define ST_PREP_LEAD_MS 8u
#endif

/* Blocks known to the stepper (the running one and the ones being prepared). */
#ifndef ST_BLOCK_BUFFER_SIZE
#define ST_BLOCK_BUFFER_SIZE 4
#endif

/* Laser duty full scale: hal_laser_set(LK_LASER_PWM_TOP) = laser_max_power_mw. */
#ifndef LK_LASER_PWM_TOP
#define LK_LASER_PWM_TOP 1000u
#endif

/* Fixed-point sub-steps per step of the arc walk (labkit.motion.bresenham.ARC_SCALE). */
#define LK_ARC_SCALE 256

/* Radii (in steps) below this are walked as a straight line (MIN_ARC_RADIUS_STEPS). */
#define LK_ARC_MIN_RADIUS_STEPS 2.0

/* Largest (radius + 4) * scale of an exact arc walk in int64 (_MAX_FIXED_RADIUS). */
#define LK_ARC_MAX_FIXED_RADIUS 3000000000.0

/* Longest arc walk the parser accepts, by the walk's bound on its ticks
   (1.05 x radius x sweep in steps, labkit.motion.bresenham.arc_lattice_points): the
   walk is counted once in the main loop before the line is answered. 4
   million allow a full circle of 280 mm radius at 2133 steps/mm (3.6 million
   points, about 60 ms on a PC). Longer arcs are error 33. */
#ifndef LK_ARC_MAX_TICKS
#define LK_ARC_MAX_TICKS 4000000
#endif

/* G-code: largest N line number (GRBL), largest magnitude of a number (2^53). */
#define GC_MAX_LINE_NUMBER 9999999.0
#define GC_MAX_ABS_VALUE 9007199254740992.0

#endif /* LK_CONFIG_H */
