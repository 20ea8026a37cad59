/*
  laser.c - laser power: M3 constant, M4 following the step rate, continuous
  or pulsed output, and the one way to switch the beam off.
*/
#include "laser.h"

#include "config.h"
#include "hal.h"

static volatile uint16_t laser_duty_now;
static uint8_t laser_mode;
static uint8_t laser_override = 100;

void laser_init(void)
{
  laser_mode = LASER_MODE_CONTINUOUS;
  laser_override = 100;
  hal_laser_gate(0, 1000);
  laser_off();
}

void laser_off(void)
{
  laser_duty_now = 0;
  hal_laser_set(0);
}

void laser_set_mode(uint8_t mode, uint32_t pwm_hz, uint16_t on_permille)
{
  laser_off();
  if (mode == LASER_MODE_PULSED && pwm_hz > 0) {
    laser_mode = LASER_MODE_PULSED;
    hal_laser_gate(pwm_hz, on_permille > 1000 ? 1000 : on_permille);
  } else {
    laser_mode = LASER_MODE_CONTINUOUS;
    hal_laser_gate(0, 1000);
  }
}

uint8_t laser_get_mode(void) { return laser_mode; }

double laser_tick_power_mw(uint8_t laser, double power_mw, uint32_t f_feed, uint32_t f_k,
                           double max_power_mw)
{
  if (laser == 4 && f_feed > 0) {
    double p = power_mw * (double)f_k / (double)f_feed;
    return p < max_power_mw ? p : max_power_mw;
  }
  if (laser == 3) return power_mw < max_power_mw ? power_mw : max_power_mw;
  return 0.0;
}

void laser_set_override(uint8_t percent)
{
  laser_override = percent < 10 ? 10 : percent > 200 ? 200 : percent;
}

uint8_t laser_get_override(void) { return laser_override; }

double laser_override_mw(double power_mw, double max_power_mw)
{
  if (laser_override == 100) return power_mw;
  double p = power_mw * (double)laser_override / 100.0;
  return p < max_power_mw ? p : max_power_mw;
}

uint16_t laser_duty_from_mw(double power_mw, double max_power_mw)
{
  if (!(power_mw > 0.0) || !(max_power_mw > 0.0)) return 0;
  double d = power_mw / max_power_mw * (double)LK_LASER_PWM_TOP + 0.5;
  if (d >= (double)LK_LASER_PWM_TOP) return (uint16_t)LK_LASER_PWM_TOP;
  uint16_t duty = (uint16_t)d;
  return duty == 0 ? 1 : duty;   /* a burning tick never rounds to dark */
}

void laser_output(uint16_t duty)
{
  if (duty != laser_duty_now) {
    laser_duty_now = duty;
    hal_laser_set(duty);
  }
}

uint16_t laser_current_duty(void) { return laser_duty_now; }
