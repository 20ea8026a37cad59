/*
  settings.c - settings struct, checksum, storage, $$ / $N= / $RST.
*/
#include "settings.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "defaults.h"
#include "gcode.h"
#include "planner.h"
#include "report.h"
#include "serial.h"
#include "status_codes.h"

settings_t settings;

void settings_defaults(settings_t *s) {
  memset(s, 0, sizeof *s);
  s->magic = SETTINGS_MAGIC;
  s->size = sizeof *s;
  machine_load_defaults(&s->machine);
  s->s_max = DEFAULT_GRBL_S_MAX;
  s->s_min = 0.0;
  s->laser_mode = 1;
  s->status_mask = 1;
  s->soft_limits = 0;            /* GRBL default; $20=1 turns the envelope check on */
  s->planner = SET_PLANNER_JUNCTION;
  s->mbla_mode = SET_MBLA_NORMAL;
  s->law = PLAN_LAW_ACCEL;
  s->dialect = GC_DIALECT_LABKIT;
  s->checksum = settings_checksum(s);
}

uint32_t settings_checksum(const settings_t *s) {
  const uint8_t *p = (const uint8_t *)s;
  size_t n = offsetof(settings_t, checksum);
  uint32_t a = 1, b = 0;   /* Fletcher-32 over bytes, modulo 65535 */
  for (size_t i = 0; i < n; i++) {
    a = (a + p[i]) % 65535u;
    b = (b + a) % 65535u;
  }
  return (b << 16) | a;
}

void settings_store(void) {
  settings.magic = SETTINGS_MAGIC;
  settings.size = sizeof settings;
  settings.checksum = settings_checksum(&settings);
  (void)hal_storage_write(&settings, sizeof settings);
}

uint8_t settings_init(void) {
  settings_t s;
  if (hal_storage_read(&s, sizeof s) && s.magic == SETTINGS_MAGIC && s.size == sizeof s &&
      s.checksum == settings_checksum(&s) && machine_check(&s.machine) == 0) {
    settings = s;
    return 1;
  }
  settings_defaults(&settings);
  settings_store();
  return 0;
}

uint8_t settings_plan_mode(void) {
  if (settings.planner == SET_PLANNER_JUNCTION)
    return PLAN_MODE_JUNCTION;
  switch (settings.mbla_mode) {
  case SET_MBLA_FAST: return PLAN_MODE_FAST;
  case SET_MBLA_HQ: return PLAN_MODE_HQ;
  default: return PLAN_MODE_NORMAL;
  }
}

uint8_t settings_apply(void) {
  lk_machine_t *m = plan_machine();
  lk_machine_t old = *m;
  *m = settings.machine;
  uint8_t st = plan_apply_machine();
  if (st != STATUS_OK) {
    *m = old;
    (void)plan_apply_machine();
    return st;
  }
  plan_set_mode(settings_plan_mode());
  plan_set_law(settings.law);
  plan_set_depth((uint32_t)settings.machine.buffer_blocks);
  gc_set_dialect(settings.dialect);
  if (settings.dialect == GC_DIALECT_GRBL)
    gc_set_s_max(settings.s_max);
  return STATUS_OK;
}

uint8_t settings_read_number(const char *s, double *out) {
  const char *p = s;
  int neg = 0, digits = 0;
  double v = 0.0, scale = 1.0;
  if (*p == '+' || *p == '-')
    neg = *p++ == '-';
  while (*p >= '0' && *p <= '9') {
    v = v * 10.0 + (*p++ - '0');
    if (++digits > 15)
      return 0;
  }
  if (*p == '.') {
    p++;
    while (*p >= '0' && *p <= '9') {
      scale *= 0.1;
      v += (*p++ - '0') * scale;
      if (++digits > 15)
        return 0;
    }
  }
  if (digits == 0)
    return 0;
  *out = neg ? -v : v;
  return (uint8_t)(p - s);
}

/* Kinds of settings. */
enum { K_DOUBLE, K_I32, K_U32, K_U8 };

typedef struct {
  uint16_t num;
  uint8_t kind;
  uint8_t decimals;
  uint16_t offset;
  double lo, hi;
} setting_def_t;

#define MOFF(f) ((uint16_t)(offsetof(settings_t, machine) + offsetof(lk_machine_t, f)))
#define SOFF(f) ((uint16_t)offsetof(settings_t, f))

static const setting_def_t defs[] = {
    {0, K_DOUBLE, 1, MOFF(step_pulse_us), 1.0, 255.0},
    {10, K_U8, 0, SOFF(status_mask), 0, 255},
    {11, K_DOUBLE, 3, MOFF(junction_deviation_mm), 0.0, 10.0},
    {12, K_DOUBLE, 3, MOFF(arc_tolerance_mm), 0.0001, 10.0},
    {20, K_U8, 0, SOFF(soft_limits), 0, 1},
    {30, K_DOUBLE, 0, SOFF(s_max), 1.0, 100000.0},
    {31, K_DOUBLE, 0, SOFF(s_min), 0.0, 100000.0},
    {32, K_U8, 0, SOFF(laser_mode), 0, 1},
    {100, K_DOUBLE, 3, MOFF(steps_per_mm[0]), 0.001, 1e6},
    {101, K_DOUBLE, 3, MOFF(steps_per_mm[1]), 0.001, 1e6},
    {102, K_DOUBLE, 3, MOFF(steps_per_mm[2]), 0.001, 1e6},
    {110, K_DOUBLE, 3, MOFF(max_rate_mm_min[0]), 0.001, 1e6},
    {111, K_DOUBLE, 3, MOFF(max_rate_mm_min[1]), 0.001, 1e6},
    {112, K_DOUBLE, 3, MOFF(max_rate_mm_min[2]), 0.001, 1e6},
    {120, K_DOUBLE, 3, MOFF(accel_mm_s2[0]), 0.001, 1e6},
    {121, K_DOUBLE, 3, MOFF(accel_mm_s2[1]), 0.001, 1e6},
    {122, K_DOUBLE, 3, MOFF(accel_mm_s2[2]), 0.001, 1e6},
    {130, K_DOUBLE, 3, MOFF(travel_mm[0]), 0.0, 1e5},
    {131, K_DOUBLE, 3, MOFF(travel_mm[1]), 0.0, 1e5},
    {132, K_DOUBLE, 3, MOFF(travel_mm[2]), 0.0, 1e5},
    {200, K_I32, 0, MOFF(accel_hz_per_step), 1, 1000000},
    {201, K_I32, 0, MOFF(decel_hz_per_step), 1, 1000000},
    {202, K_I32, 0, MOFF(start_rate_hz), 1, 10000000},
    {203, K_DOUBLE, 1, MOFF(laser_max_power_mw), 0.001, 1e7},
    {204, K_U8, 0, SOFF(planner), 0, 1},
    {205, K_U8, 0, SOFF(mbla_mode), 0, 2},
    {206, K_U8, 0, SOFF(law), 0, 1},
    {207, K_I32, 0, MOFF(buffer_blocks), 1, PLAN_MAX_DEPTH},
    {208, K_U8, 0, SOFF(dialect), 0, 1},
    {209, K_U32, 0, MOFF(prescaler), 0, 65535},
};
#define N_DEFS (sizeof defs / sizeof defs[0])

static double get_value(const settings_t *s, const setting_def_t *d) {
  const uint8_t *p = (const uint8_t *)s + d->offset;
  switch (d->kind) {
  case K_DOUBLE: { double v; memcpy(&v, p, sizeof v); return v; }
  case K_I32: { int32_t v; memcpy(&v, p, sizeof v); return v; }
  case K_U32: { uint32_t v; memcpy(&v, p, sizeof v); return v; }
  default: return *p;
  }
}

static void set_value(settings_t *s, const setting_def_t *d, double v) {
  uint8_t *p = (uint8_t *)s + d->offset;
  switch (d->kind) {
  case K_DOUBLE: memcpy(p, &v, sizeof v); break;
  case K_I32: { int32_t x = (int32_t)v; memcpy(p, &x, sizeof x); break; }
  case K_U32: { uint32_t x = (uint32_t)v; memcpy(p, &x, sizeof x); break; }
  default: *p = (uint8_t)v; break;
  }
}

void settings_report(void) {
  for (unsigned i = 0; i < N_DEFS; i++) {
    serial_putc('$');
    report_uint(defs[i].num);
    serial_putc('=');
    report_float(get_value(&settings, &defs[i]), defs[i].decimals);
    serial_write("\r\n");
  }
}

uint8_t settings_store_setting(const char *line) {
  double num, v;
  uint8_t k = settings_read_number(line, &num);
  if (!k || line[0] == '-' || line[0] == '+' || num != floor(num))
    return STATUS_BAD_NUMBER;
  if (line[k] != '=')
    return STATUS_UNSUPPORTED_COMMAND;
  const char *val = line + k + 1;
  uint8_t kv = settings_read_number(val, &v);
  if (!kv || val[kv] != 0)
    return STATUS_BAD_NUMBER;
  const setting_def_t *d = 0;
  for (unsigned i = 0; i < N_DEFS; i++)
    if (defs[i].num == num)
      d = &defs[i];
  if (!d)
    return STATUS_UNSUPPORTED_COMMAND;
  if (v < 0 && d->lo >= 0)
    return STATUS_NEGATIVE_VALUE;
  if (d->kind != K_DOUBLE && v != floor(v))
    return STATUS_NON_INTEGER_COMMAND;
  if (v < d->lo || v > d->hi)
    return STATUS_MAX_VALUE_EXCEEDED;
  settings_t old = settings;
  set_value(&settings, d, v);
  if (machine_check(&settings.machine) != 0) {
    settings = old;
    return STATUS_MAX_VALUE_EXCEEDED;
  }
  uint8_t st = settings_apply();
  if (st != STATUS_OK) {
    settings = old;
    (void)settings_apply();
    return st;
  }
  settings_store();
  return STATUS_OK;
}

uint8_t settings_restore(char what) {
  if (what == '#')
    return STATUS_OK;   /* no offsets are kept (G10/G92 are not supported) */
  if (what != '$' && what != '*')
    return STATUS_UNSUPPORTED_COMMAND;
  uint8_t dialect = settings.dialect;
  settings_defaults(&settings);
  if (what == '$')
    settings.dialect = dialect;   /* keep talking the language the host speaks */
  settings_store();
  return settings_apply();
}
