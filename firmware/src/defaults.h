/*
  defaults.h - machine defaults: the CBR-40 laser of [CBR40] (seed 004),
  the values of labkit/motion/machines/cbr40-laser.toml.

  Colinbus CBR-40 frame, 3 mm lead screws at 1/32 microstep (6400 steps per
  turn: 2133.33 steps/mm, 0.46875 um per step), 300 x 400 x 100 mm of travel,
  1546.0875 mm/min (54 972 steps/s) per axis, a 2500 mW diode laser and a
  48 MHz step timer with 5 us step pulses. Slopes, accelerations, start rate
  and prescaler are not in the seed; these are labkit's chosen values.
*/
#ifndef LK_DEFAULTS_H
#define LK_DEFAULTS_H

#define DEFAULT_MACHINE_NAME        "cbr40-laser"
#define DEFAULT_STEPS_PER_REV       6400.0
#define DEFAULT_LEAD_MM             3.0
#define DEFAULT_STEPS_PER_MM        (DEFAULT_STEPS_PER_REV / DEFAULT_LEAD_MM)
#define DEFAULT_MAX_RATE_MM_MIN     1546.0875
#define DEFAULT_ACCEL_MM_S2         500.0
#define DEFAULT_X_TRAVEL_MM         300.0
#define DEFAULT_Y_TRAVEL_MM         400.0
#define DEFAULT_Z_TRAVEL_MM         100.0
#define DEFAULT_ACCEL_HZ_PER_STEP   40
#define DEFAULT_DECEL_HZ_PER_STEP   40
#define DEFAULT_START_RATE_HZ       1000
#define DEFAULT_JUNCTION_DEVIATION_MM 0.01
#define DEFAULT_ARC_TOLERANCE_MM    0.002
#define DEFAULT_BUFFER_BLOCKS       16
#define DEFAULT_LASER_MAX_POWER_MW  2500.0
#define DEFAULT_TIMER_CLOCK_HZ      48000000u
#define DEFAULT_PRESCALER           0u
#define DEFAULT_TIMER_BITS          16u
#define DEFAULT_STEP_PULSE_US       5.0

/* GRBL $30 default: the S of full power in the grbl dialect. */
#define DEFAULT_GRBL_S_MAX          1000.0
/* labkit-fw dialect: S is an 8-bit duty. */
#define DEFAULT_LABKIT_S_MAX        255.0

#endif /* LK_DEFAULTS_H */
