/*
  laser.h - laser power of the labkit firmware ([CBR40] section IV, GRBL laser mode).

  Power per tick (computed in the main loop, stepper.c st_prep_buffer):
    M3  the programmed power (capped at the laser maximum),
    M4  power x f_k / f_feed, capped at the laser maximum: the power/speed
        ratio of [CBR40] with the speed as the driver's step rate,
    off 0.
  The step interrupt only copies the prepared duty to the output
  (laser_output). Output modes: LASER_MODE_CONTINUOUS (the gate held open,
  the duty sets the diode current) or LASER_MODE_PULSED (the gate switched
  by a PWM square wave, the seed's pulsed mode). laser_off() switches the
  beam off at once; it is called on every stop, hold, alarm and reset.
*/
#ifndef LK_LASER_H
#define LK_LASER_H

#include <stdint.h>

#define LASER_MODE_CONTINUOUS 0
#define LASER_MODE_PULSED     1

void laser_init(void);                         /* off, continuous */
void laser_off(void);                          /* beam off now (any context) */
void laser_set_mode(uint8_t mode, uint32_t pwm_hz, uint16_t on_permille);
uint8_t laser_get_mode(void);

/* Power (mW) of one tick at driver rate f_k: labkit.motion.timer.tick_power_mw. */
double laser_tick_power_mw(uint8_t laser, double power_mw, uint32_t f_feed, uint32_t f_k,
                           double max_power_mw);
/* mW -> duty 0 .. LK_LASER_PWM_TOP, rounded to nearest; a burning tick gets at least 1. */
uint16_t laser_duty_from_mw(double power_mw, double max_power_mw);

/* Laser-power override (GRBL 1.1's spindle override bytes 0x99..0x9D),
   10 .. 200 %: scales the power of every tick prepared from now on, capped
   at the laser maximum. 100 % (the default, and after a reset) changes
   nothing, so the firmware stays tick-for-tick equal to labkit.motion. */
void laser_set_override(uint8_t percent);
uint8_t laser_get_override(void);
double laser_override_mw(double power_mw, double max_power_mw);

/* Step interrupt: set the output to a prepared duty (no floating point). */
void laser_output(uint16_t duty);
uint16_t laser_current_duty(void);

#endif /* LK_LASER_H */
