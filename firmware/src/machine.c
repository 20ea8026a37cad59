/*
  machine.c - the machine's fields: defaults, the checks of
  labkit.motion.MachineSpec, the fastest step rate of an axis (see machine.h).
*/
#include "machine.h"

#include <math.h>
#include <string.h>

#include "config.h"
#include "defaults.h"
#include "status_codes.h"

void machine_load_defaults(lk_machine_t *m)
{
  memset(m, 0, sizeof *m);
  strncpy(m->name, DEFAULT_MACHINE_NAME, sizeof m->name - 1);
  for (int a = 0; a < 3; a++) {
    m->steps_per_mm[a] = DEFAULT_STEPS_PER_MM;
    m->max_rate_mm_min[a] = DEFAULT_MAX_RATE_MM_MIN;
    m->accel_mm_s2[a] = DEFAULT_ACCEL_MM_S2;
  }
  m->travel_mm[0] = DEFAULT_X_TRAVEL_MM;
  m->travel_mm[1] = DEFAULT_Y_TRAVEL_MM;
  m->travel_mm[2] = DEFAULT_Z_TRAVEL_MM;
  m->accel_hz_per_step = DEFAULT_ACCEL_HZ_PER_STEP;
  m->decel_hz_per_step = DEFAULT_DECEL_HZ_PER_STEP;
  m->start_rate_hz = DEFAULT_START_RATE_HZ;
  m->junction_deviation_mm = DEFAULT_JUNCTION_DEVIATION_MM;
  m->arc_tolerance_mm = DEFAULT_ARC_TOLERANCE_MM;
  m->buffer_blocks = DEFAULT_BUFFER_BLOCKS;
  m->laser_max_power_mw = DEFAULT_LASER_MAX_POWER_MW;
  m->timer_clock_hz = DEFAULT_TIMER_CLOCK_HZ;
  m->prescaler = DEFAULT_PRESCALER;
  m->timer_bits = DEFAULT_TIMER_BITS;
  m->step_pulse_us = DEFAULT_STEP_PULSE_US;
}

int32_t machine_max_step_rate_hz(const lk_machine_t *m, int axis)
{
  double rate = floor(m->max_rate_mm_min[axis] / 60.0 * m->steps_per_mm[axis] + 1e-9);
  /* saturate: a rate past int32 (absurd settings) is refused by machine_check, never cast */
  if (!(rate >= 0.0)) return 0;
  return rate >= 2147483647.0 ? INT32_MAX : (int32_t)rate;
}

uint8_t machine_check(const lk_machine_t *m)
{
  int32_t top = 0;
  for (int a = 0; a < 3; a++) {
    if (!(m->steps_per_mm[a] > 0 && isfinite(m->steps_per_mm[a]))) return STATUS_MAX_VALUE_EXCEEDED;
    if (!(m->max_rate_mm_min[a] > 0 && isfinite(m->max_rate_mm_min[a]))) return STATUS_MAX_VALUE_EXCEEDED;
    if (!(m->accel_mm_s2[a] > 0 && isfinite(m->accel_mm_s2[a]))) return STATUS_MAX_VALUE_EXCEEDED;
    if (!(m->travel_mm[a] > 0 && isfinite(m->travel_mm[a]))) return STATUS_MAX_VALUE_EXCEEDED;
    int32_t r = machine_max_step_rate_hz(m, a);
    if (r > top) top = r;
  }
  if (m->accel_hz_per_step < 1 || m->decel_hz_per_step < 1 || m->start_rate_hz < 1)
    return STATUS_MAX_VALUE_EXCEEDED;
  if (m->buffer_blocks < 1 || m->buffer_blocks > PLAN_MAX_DEPTH) return STATUS_MAX_VALUE_EXCEEDED;
  if (!(m->junction_deviation_mm > 0) || !(m->arc_tolerance_mm > 0) || !(m->laser_max_power_mw > 0))
    return STATUS_MAX_VALUE_EXCEEDED;
  if (m->timer_clock_hz < 1 || m->prescaler > 65535 || !(m->timer_bits == 16 || m->timer_bits == 32))
    return STATUS_MAX_VALUE_EXCEEDED;
  if (!(m->step_pulse_us > 0)) return STATUS_MAX_VALUE_EXCEEDED;
  if (m->start_rate_hz > top) return STATUS_MAX_VALUE_EXCEEDED;
  uint64_t q = (uint64_t)m->start_rate_hz * (m->prescaler + 1);
  uint64_t longest = (m->timer_clock_hz + q - 1) / q - 1;
  if (longest > ((1ull << m->timer_bits) - 1)) return STATUS_MAX_VALUE_EXCEEDED;
  if (2e-6 * m->step_pulse_us * top > 1.0) return STATUS_MAX_VALUE_EXCEEDED;
  if ((uint64_t)top * (m->prescaler + 1) > m->timer_clock_hz) return STATUS_MAX_VALUE_EXCEEDED;
  return STATUS_OK;
}

