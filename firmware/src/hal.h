/*
  hal.h - the hardware layer the labkit firmware core calls.

  The core (gcode, planner, stepper, laser) never touches a register. It calls
  the functions below; the host simulator (firmware/host/), the board
  (firmware/board/) and the test recorder (firmware/tests/hal_record.c) each
  implement them once.

  Timing contract of the step timer
  ---------------------------------
  The step timer counts at timer_clock_hz / (prescaler + 1) (lk_machine_t).
  A "tick" is one timer period. The core starts the timer with
  hal_timer_start() after it has called hal_timer_set_period() for the first
  tick. From then on the hal calls st_tick() (stepper.h) once at the END of
  every tick, from the timer interrupt. Inside st_tick() the core
    - fires the step pulses of the tick that has just ended
      (hal_step_pulse), then
    - prepares the next tick: hal_set_dir() (only when it changes),
      hal_laser_set(), hal_timer_set_period(),
    - or calls hal_timer_stop() when no tick is ready.
  hal_timer_set_period(P) called inside st_tick() (or before
  hal_timer_start()) gives the length of the tick that starts now:
  (P + 1) * (prescaler + 1) timer clock cycles. On an STM32 this is the
  buffered ARR register; P never exceeds 2^timer_bits - 1.

  Everything called from st_tick() must be short and free of floating point.

  Functions called only from the main loop are marked (main).
*/
#ifndef LK_HAL_H
#define LK_HAL_H

#include <stdint.h>

/* Axis bit masks used by step and direction bytes: bit i is axis i (X, Y, Z). */
#define HAL_AXIS_X 0x01u
#define HAL_AXIS_Y 0x02u
#define HAL_AXIS_Z 0x04u

/* Direction pins: bit i set = axis i moves towards negative coordinates.
   Called before the step pulse of the first tick in the new direction. */
void hal_set_dir(uint8_t dir_bits);

/* Step pulses: raise the step pin of every axis whose bit is set. The hal
   lowers them again after the machine's step_pulse_us (a one-pulse timer
   channel on the board, nothing on the host). step_bits may be 0 (a tick
   without a step: dwell or an arc tick that moves no axis). */
void hal_step_pulse(uint8_t step_bits);

/* Step timer. */
void hal_timer_set_period(uint32_t period_reg); /* length of the tick starting now  */
void hal_timer_start(void);                     /* (main) begin ticking; st_tick() follows */
void hal_timer_stop(void);                      /* no st_tick() calls until the next start */

/* Laser output. duty = 0 ... LK_LASER_PWM_TOP (config.h); 0 must switch the
   beam fully off (the gate, not only the PWM). Called from st_tick() and from
   laser_off() in the main loop (stop, hold, alarm, reset). */
void hal_laser_set(uint16_t duty);

/* Laser gate ([CBR40]: the driver runs the diode continuously or pulsed by a
   PWM square wave on a switch transistor). pwm_hz = 0: gate held open, the
   power follows hal_laser_set() alone (continuous mode); pwm_hz > 0: the gate
   is switched at pwm_hz with on_permille/1000 of each period on (pulsed
   mode). (main) */
void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille);

/* Air assist (M7 / M8 on, M9 off). bit 0 = mist (M7), bit 1 = flood (M8). (main) */
void hal_air_set(uint8_t bits);

/* Inputs, read as the switch's state with GRBL's wiring (a normally open
   switch to ground, pull-up on: a low pin is a pressed switch); the core
   applies $5 / $6. limits.c gives defaults for a hal without them: nothing
   pressed. */
uint8_t hal_limits_read(void);   /* (main) bit i: limit switch of axis i pressed. A hal with
                                    limit pins also calls protocol_limit_pin_change() (shell,
                                    protocol.h) from the pins' change interrupt, on both edges,
                                    never from inside st_tick(): GRBL's hard limits */
uint8_t hal_probe_read(void);    /* 1: the probe touches. Also called from st_tick() while a
                                    probe cycle runs (GRBL reads it in its step interrupt):
                                    one pin read, nothing more */

/* Keep the step interrupt out while the main loop changes data it shares with
   it (st_reset, feed hold). Must nest at least one level. */
void hal_irq_disable(void);
void hal_irq_enable(void);

#endif /* LK_HAL_H */
