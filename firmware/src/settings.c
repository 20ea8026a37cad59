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
  s->dialect = GC_DIALECT_GRBL;   /* a GRBL sender is never silently wrong; $208=0 for labkit-fw */
  s->step_idle_delay = 25;
  s->homing_feed = 25.0;
  s->homing_seek = 500.0;
  s->homing_debounce_ms = 250;
  s->homing_pulloff = 1.0;
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
  if (st != STATUS_OK) {         /* the core keeps the machine it had; the rest still applies */
    *m = old;
    (void)plan_apply_machine();
  }
  plan_set_mode(settings_plan_mode());
  plan_set_law(settings.law);
  plan_set_depth((uint32_t)settings.machine.buffer_blocks);
  gc_set_dialect(settings.dialect);
  if (settings.dialect == GC_DIALECT_GRBL)
    gc_set_s_max(settings.s_max);
  return st;
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

/* Kinds of settings, as GRBL 1.1h types them: a float (three decimals), a
   whole number GRBL keeps in 8 bits (the value is truncated, then wraps:
   $26=1000 stores 232, as GRBL does), a flag (any non-zero value is 1), the
   spindle speeds (float, printed whole); labkit's own whole numbers are
   range-checked instead. */
enum { K_DOUBLE, K_BYTE, K_FLAG, K_RPM, K_I32, K_U32, K_U8 };

typedef struct {
  uint16_t num;
  uint8_t kind;
  uint8_t flag;          /* K_FLAG: SET_FLAG_* bit (0: a byte of its own) */
  uint16_t offset;
  double lo, hi;         /* labkit's own settings (K_I32 K_U32 K_U8); K_DOUBLE too */
} setting_def_t;

#define MOFF(f) ((uint16_t)(offsetof(settings_t, machine) + offsetof(lk_machine_t, f)))
#define SOFF(f) ((uint16_t)offsetof(settings_t, f))
#define BIG 1e300
/* GRBL's per-axis settings: $n, $n+1, $n+2 are X, Y, Z of one machine array, at least lo. */
#define PER_AXIS(n, f, lo)                                                          \
  {n, K_DOUBLE, 0, MOFF(f[0]), lo, BIG}, {n + 1, K_DOUBLE, 0, MOFF(f[1]), lo, BIG}, \
      {n + 2, K_DOUBLE, 0, MOFF(f[2]), lo, BIG}

static const setting_def_t defs[] = {
    {0, K_BYTE, 0, MOFF(step_pulse_us), 3, 255},
    {1, K_BYTE, 0, SOFF(step_idle_delay), 0, 255},
    {2, K_BYTE, 0, SOFF(step_invert), 0, 255},
    {3, K_BYTE, 0, SOFF(dir_invert), 0, 255},
    {4, K_FLAG, SET_FLAG_STEP_ENABLE_INVERT, SOFF(flags), 0, 1},
    {5, K_FLAG, SET_FLAG_LIMIT_INVERT, SOFF(flags), 0, 1},
    {6, K_FLAG, SET_FLAG_PROBE_INVERT, SOFF(flags), 0, 1},
    {10, K_BYTE, 0, SOFF(status_mask), 0, 255},
    {11, K_DOUBLE, 0, MOFF(junction_deviation_mm), 0.0, BIG},
    {12, K_DOUBLE, 0, MOFF(arc_tolerance_mm), 0.0, BIG},
    {13, K_FLAG, SET_FLAG_REPORT_INCHES, SOFF(flags), 0, 1},
    {20, K_FLAG, 0, SOFF(soft_limits), 0, 1},
    {21, K_FLAG, SET_FLAG_HARD_LIMITS, SOFF(flags), 0, 1},
    {22, K_FLAG, SET_FLAG_HOMING, SOFF(flags), 0, 1},
    {23, K_BYTE, 0, SOFF(homing_dir), 0, 255},
    {24, K_DOUBLE, 0, SOFF(homing_feed), 0.0, BIG},
    {25, K_DOUBLE, 0, SOFF(homing_seek), 0.0, BIG},
    {26, K_BYTE, 0, SOFF(homing_debounce_ms), 0, 255},
    {27, K_DOUBLE, 0, SOFF(homing_pulloff), 0.0, BIG},
    {30, K_RPM, 0, SOFF(s_max), 0.0, BIG},
    {31, K_RPM, 0, SOFF(s_min), 0.0, BIG},
    {32, K_FLAG, 0, SOFF(laser_mode), 0, 1},
    PER_AXIS(100, steps_per_mm, 0.001),
    PER_AXIS(110, max_rate_mm_min, 0.001),
    PER_AXIS(120, accel_mm_s2, 0.001),
    PER_AXIS(130, travel_mm, 0.0),
    /* labkit's own (listed by $$ in the labkit-fw dialect only) */
    {200, K_I32, 0, MOFF(accel_hz_per_step), 1, 1000000},
    {201, K_I32, 0, MOFF(decel_hz_per_step), 1, 1000000},
    {202, K_I32, 0, MOFF(start_rate_hz), 1, 10000000},
    {203, K_DOUBLE, 0, MOFF(laser_max_power_mw), 0.001, 1e7},
    {204, K_U8, 0, SOFF(planner), 0, 1},
    {205, K_U8, 0, SOFF(mbla_mode), 0, 2},
    {206, K_U8, 0, SOFF(law), 0, 1},
    {207, K_I32, 0, MOFF(buffer_blocks), 1, PLAN_MAX_DEPTH},
    {208, K_U8, 0, SOFF(dialect), 0, 1},
    {209, K_U32, 0, MOFF(prescaler), 0, 65535},
};
#define N_DEFS (sizeof defs / sizeof defs[0])
#define FIRST_LABKIT 200

static double get_value(const settings_t *s, const setting_def_t *d) {
  const uint8_t *p = (const uint8_t *)s + d->offset;
  if (d->kind == K_FLAG && d->flag)
    return (*p & d->flag) ? 1.0 : 0.0;
  if (d->num == 0) { double v; memcpy(&v, p, sizeof v); return floor(v); }
  switch (d->kind) {
  case K_DOUBLE: case K_RPM: { double v; memcpy(&v, p, sizeof v); return v; }
  case K_I32: { int32_t v; memcpy(&v, p, sizeof v); return v; }
  case K_U32: { uint32_t v; memcpy(&v, p, sizeof v); return v; }
  default: return *p;
  }
}

static void set_value(settings_t *s, const setting_def_t *d, double v) {
  uint8_t *p = (uint8_t *)s + d->offset;
  if (d->kind == K_FLAG) {
    if (!d->flag)
      *p = v != 0.0;
    else if (v != 0.0)
      *p |= d->flag;
    else
      *p &= (uint8_t)~d->flag;
    return;
  }
  if (d->kind == K_BYTE) {
    /* The value wraps as GRBL's uint8_t store does; fmod keeps a huge value
       defined (a cast of a double beyond the integer's range is undefined). */
    double wrapped = fmod(trunc(v), 256.0);
    uint8_t b = (wrapped >= 0.0 && wrapped < 256.0) ? (uint8_t)wrapped : 0u;
    if (d->num == 0) { double x = b; memcpy(p, &x, sizeof x); }   /* $0 lives in the machine, us */
    else *p = b;
    return;
  }
  switch (d->kind) {
  case K_DOUBLE: case K_RPM: memcpy(p, &v, sizeof v); break;
  case K_I32: { int32_t x = (int32_t)v; memcpy(p, &x, sizeof x); break; }
  case K_U32: { uint32_t x = (uint32_t)v; memcpy(p, &x, sizeof x); break; }
  default: *p = (uint8_t)v; break;
  }
}

void settings_report(void) {
  uint8_t all = settings.dialect == GC_DIALECT_LABKIT;
  for (unsigned i = 0; i < N_DEFS; i++) {
    const setting_def_t *d = &defs[i];
    if (d->num >= FIRST_LABKIT && !all)
      continue;
    serial_putc('$');
    report_uint(d->num);
    serial_putc('=');
    uint8_t decimals = d->kind == K_DOUBLE ? (d->num == 203 ? 1 : 3) : 0;
    report_float(get_value(&settings, d), decimals);
    serial_write("\r\n");
  }
}

/* GRBL's number reader for $ lines: [+-]digits[.digits] (or .digits); 0 when none. */
uint8_t settings_store_setting(const char *line) {
  double num, v;
  uint8_t k = settings_read_number(line, &num);
  if (!k)
    return STATUS_BAD_NUMBER;
  if (line[k] != '=')
    return STATUS_INVALID_STATEMENT;
  const char *val = line + k + 1;
  uint8_t kv = settings_read_number(val, &v);
  if (!kv)
    return STATUS_BAD_NUMBER;
  if (val[kv] != 0)
    return STATUS_INVALID_STATEMENT;
  if (v < 0)
    return STATUS_NEGATIVE_VALUE;
  double number = trunc(num);        /* GRBL: $1.5= is $1= */
  const setting_def_t *d = 0;
  for (unsigned i = 0; i < N_DEFS; i++)
    if (num >= 0 && defs[i].num == number)
      d = &defs[i];
  if (!d)
    return STATUS_INVALID_STATEMENT;  /* GRBL: an unknown setting is error 3 */
  if (d->kind == K_BYTE && d->num == 0 && trunc(v) < 3)
    return STATUS_SETTING_STEP_PULSE_MIN;
  if (d->num == 20 && v != 0.0 && !(settings.flags & SET_FLAG_HOMING))
    return STATUS_SOFT_LIMIT_ERROR;  /* soft limits need homing (GRBL) */
  if (d->kind == K_I32 || d->kind == K_U32 || d->kind == K_U8) {
    if (v != floor(v))
      return STATUS_NON_INTEGER_COMMAND;
    if (v < d->lo || v > d->hi)
      return STATUS_MAX_VALUE_EXCEEDED;
  }
  uint8_t grbl_number = settings.dialect == GC_DIALECT_GRBL && d->num < FIRST_LABKIT;
  if (d->kind == K_DOUBLE && !grbl_number && (v < d->lo || v > d->hi))
    return STATUS_MAX_VALUE_EXCEEDED;  /* a value the machine cannot run with (labkit) */
  settings_t old = settings;
  set_value(&settings, d, v);
  if (d->num == 22 && v == 0.0)
    settings.soft_limits = 0;        /* GRBL: no homing, no soft limits */
  if (machine_check(&settings.machine) != 0) {
    if (!grbl_number) {
      settings = old;
      return STATUS_MAX_VALUE_EXCEEDED;
    }
    /* GRBL keeps any value of its own settings it can store ($100=0, $12=0); the core cannot
       run on such a machine and keeps the last one it could (settings_apply) */
  }
  uint8_t st = settings_apply();
  if (st != STATUS_OK && !grbl_number) {
    settings = old;
    (void)settings_apply();
    return st;
  }
  settings_store();
  if (d->num == 13)
    gc_load_offsets();               /* GRBL: WCO: in the next report, in the new unit */
  return STATUS_OK;
}

void settings_store_coord(uint8_t index, const double mm[3]) {
  double *dst = index < SET_N_COORD ? settings.coord[index] : settings.home_pos[index - SET_N_COORD];
  for (int i = 0; i < 3; i++)
    dst[i] = mm[i];
  settings_store();
}

uint8_t settings_restore(char what) {
  if (what != '$' && what != '*' && what != '#')
    return STATUS_INVALID_STATEMENT;
  settings_t old = settings;
  settings_defaults(&settings);
  if (what == '#') {                /* only the offsets and home positions */
    memcpy(old.coord, settings.coord, sizeof old.coord);
    memcpy(old.home_pos, settings.home_pos, sizeof old.home_pos);
    settings = old;
  } else if (what == '$') {         /* settings only: the EEPROM data stays */
    memcpy(settings.coord, old.coord, sizeof old.coord);
    memcpy(settings.home_pos, old.home_pos, sizeof old.home_pos);
    memcpy(settings.startup, old.startup, sizeof old.startup);
    memcpy(settings.build_info, old.build_info, sizeof old.build_info);
    settings.dialect = old.dialect; /* keep talking the language the host speaks */
  }
  settings_store();
  return settings_apply();
}
