/*
  hal_null.c - a hal that does nothing, for tests and fuzzing before (or
  without) the core's recorder (tests/hal_record.c). The step timer never
  ticks: moves stay queued.
*/
#include <stdint.h>

#include "hal.h"

void hal_set_dir(uint8_t dir_bits) { (void)dir_bits; }
void hal_step_pulse(uint8_t step_bits) { (void)step_bits; }
void hal_timer_set_period(uint32_t period_reg) { (void)period_reg; }
void hal_timer_start(void) {}
void hal_timer_stop(void) {}
void hal_laser_set(uint16_t duty) { (void)duty; }
void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille) { (void)pwm_hz; (void)on_permille; }
void hal_air_set(uint8_t bits) { (void)bits; }
void hal_irq_disable(void) {}
void hal_irq_enable(void) {}
