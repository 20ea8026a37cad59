/*
  report.c - replies, status reports, banner, $I, $G, $#.
*/
#include "report.h"

#include <math.h>

#include "config.h"
#include "gcode.h"
#include "laser.h"
#include "limits.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"

uint16_t fmt_float(char *out, uint16_t n, double v, uint8_t decimals) {
  char tmp[32];
  uint16_t k = 0, w = 0;
  if (n == 0)
    return 0;
  if (!isfinite(v) || fabs(v) >= 4.0e9) { /* never happens for positions; keep it printable */
    const char *s = isnan(v) ? "nan" : (v < 0 ? "-inf" : "inf");
    if (isfinite(v))
      s = v < 0 ? "-4e9" : "4e9";
    while (*s && w + 1 < n)
      out[w++] = *s++;
    out[w] = 0;
    return w;
  }
  uint32_t scale = 1;
  for (uint8_t i = 0; i < decimals; i++)
    scale *= 10u;
  int neg = v < 0;
  double a = neg ? -v : v;
  /* round half away from zero at the last decimal */
  double scaled = floor(a * (double)scale + 0.5);
  uint64_t iv = (uint64_t)scaled;
  if (iv == 0)
    neg = 0;
  uint8_t d = 0;
  do {
    tmp[k++] = (char)('0' + (iv % 10u));
    iv /= 10u;
    d++;
    if (d == decimals)
      tmp[k++] = '.';
  } while (iv > 0 || d <= decimals);
  if (decimals == 0 && tmp[k - 1] == '.')
    k--;
  if (neg && w + 1 < n)
    out[w++] = '-';
  while (k > 0 && w + 1 < n)
    out[w++] = tmp[--k];
  out[w] = 0;
  return w;
}

void report_float(double v, uint8_t decimals) {
  char buf[40];
  fmt_float(buf, sizeof buf, v, decimals);
  serial_write(buf);
}

void report_uint(uint32_t v) {
  char tmp[12];
  int k = 0;
  do {
    tmp[k++] = (char)('0' + v % 10u);
    v /= 10u;
  } while (v);
  while (k)
    serial_putc(tmp[--k]);
}

void report_int(int32_t v) {
  if (v < 0) {
    serial_putc('-');
    report_uint((uint32_t)(-(int64_t)v));
  } else {
    report_uint((uint32_t)v);
  }
}

void report_status_message(uint8_t status) {
  if (status == STATUS_OK) {
    serial_write("ok\r\n");
    return;
  }
  serial_write(settings.dialect == GC_DIALECT_GRBL ? "error:" : "er:");
  report_uint(status);
  serial_write("\r\n");
}

void report_alarm(uint8_t alarm) {
  serial_write("ALARM:");
  report_uint(alarm);
  serial_write("\r\n");
}

void report_banner(void) {
  report_counters_reset();
  if (settings.dialect == GC_DIALECT_GRBL)
    serial_write("\r\nGrbl 1.1h ['$' for help]\r\n");
  else   /* not GRBL's units: a GRBL sender must not take it for GRBL */
    serial_write("\r\nlabkit-fw " LK_FW_VERSION " ['$' for help] [dialect:labkit-fw F mm/s S 0-255 "
                 "G4 P ms; $208=1 for grbl]\r\n");
}

void report_feedback(const char *msg) {
  serial_write("[MSG:");
  serial_write(msg);
  serial_write("]\r\n");
}

static void report_axes(const double v[3], uint8_t decimals) {
  for (int i = 0; i < 3; i++) {
    if (i)
      serial_putc(',');
    report_float(v[i], decimals);
  }
}

/* Positions as GRBL prints them: mm with 3 decimals, or inches with 4 ($13=1). */
static void report_coords(const double mm[3]) {
  if (settings.flags & SET_FLAG_REPORT_INCHES) {
    double in[3] = {mm[0] / 25.4, mm[1] / 25.4, mm[2] / 25.4};
    report_axes(in, 4);
  } else {
    report_axes(mm, 3);
  }
}

/* GRBL sends WCO: and Ov: only every few reports (10 at rest, 30 / 20 while
   busy) and at once after a change; a reset starts both counts again. */
static uint8_t wco_count, ovr_count;
static uint32_t seen_wco_changes;
static uint8_t seen_laser, seen_air, seen_ov[3];
static uint32_t seen_power_syncs;

void report_counters_reset(void) {
  wco_count = ovr_count = 0;
  seen_wco_changes = gc_state()->wco_changes;
}

void report_overrides_next(void) { ovr_count = 0; }

const char *report_state_name(void) {
  switch (protocol_state()) {
  case PROTO_ALARM: return "Alarm";
  case PROTO_CHECK: return "Check";
  case PROTO_JOG: return "Jog";
  case PROTO_SLEEP: return "Sleep";
  case PROTO_HOME: return "Home";
  default: break;
  }
  if (protocol_program_paused() && st_is_idle() && plan_is_empty())
    return "Hold:0";
  if (protocol_hold_requested() && st_state() == ST_IDLE)
    return "Hold:0";
  switch (st_state()) {
  case ST_HOLDING: return "Hold:1";
  case ST_HELD: return "Hold:0";
  case ST_RUN: return "Run";
  case ST_DWELL:                 /* GRBL dwells (G4) with its planner empty, in Idle */
    return settings.dialect == GC_DIALECT_GRBL ? "Idle" : "Run";
  default: break;
  }
  return plan_is_empty() ? "Idle" : "Run";
}

/* Feed of the running tick, mm/min: driver rate x (block length / ticks). */
double report_feed_mm_min(void) {
  const st_block_info_t *b = st_running_block();
  uint32_t f = st_current_rate_hz();
  if (!b || !f || !b->ticks)
    return 0.0;
  return (double)f * b->length_mm / (double)b->ticks * 60.0;
}

void report_status_report(void) {
  const gc_state_t *g = gc_state();
  uint8_t grbl = settings.dialect == GC_DIALECT_GRBL;
  uint8_t mask = grbl ? settings.status_mask : 3u;   /* labkit-fw: always MPos and Bf */
  float mm[3];
  double pos[3], wco[3];
  st_get_position_mm(mm);
  gc_wco(wco);
  for (int i = 0; i < 3; i++)
    pos[i] = (mask & 1u) ? mm[i] : mm[i] - wco[i];
  const char *name = report_state_name();
  uint8_t busy = name[0] == 'R' || name[0] == 'H' || name[0] == 'J';
  uint8_t feed_ov, rapid_ov;
  plan_get_overrides(&feed_ov, &rapid_ov);
  if (g->wco_changes != seen_wco_changes) {
    seen_wco_changes = g->wco_changes;
    wco_count = 0;
  }
  if (g->laser != seen_laser || g->air != seen_air || g->power_syncs != seen_power_syncs ||
      feed_ov != seen_ov[0] ||
      rapid_ov != seen_ov[1] || laser_get_override() != seen_ov[2]) {
    seen_laser = g->laser;
    seen_air = g->air;
    seen_power_syncs = g->power_syncs;
    seen_ov[0] = feed_ov;
    seen_ov[1] = rapid_ov;
    seen_ov[2] = laser_get_override();
    ovr_count = 0;
  }
  serial_putc('<');
  serial_write(name);
  serial_write((mask & 1u) ? "|MPos:" : "|WPos:");
  report_coords(pos);
  if (mask & 2u) {
    serial_write("|Bf:");
    report_uint(plan_free_slots());
    serial_putc(',');
    report_uint(serial_rx_free());
  }
  uint32_t ln = st_current_line();
  if (!grbl && ln && !st_is_idle()) {   /* GRBL 1.1h is built without line numbers */
    serial_write("|Ln:");
    report_uint(ln);
  }
  serial_write("|FS:");
  double feed = report_feed_mm_min();
  if (settings.flags & SET_FLAG_REPORT_INCHES)
    report_float(feed / 25.4, 1);
  else
    report_float(feed, 0);
  serial_putc(',');
  /* spindle mode ($32=0): the programmed S while M3/M4 is on (GRBL); laser mode: the beam now */
  uint8_t spindle = g->laser && !settings.laser_mode;
  double s = spindle ? (double)g->s_word
                     : (double)laser_current_duty() / (double)LK_LASER_PWM_TOP * gc_get_s_max();
  report_float(s, 0);
  uint8_t pins = limits_pressed();
  if (grbl && (pins || limits_probe_touching())) {   /* GRBL: the inputs that read active */
    serial_write("|Pn:");
    for (int a = 0; a < 3; a++)
      if (pins & (1u << a)) serial_putc((char)('X' + a));
    if (limits_probe_touching()) serial_putc('P');
  }
  uint8_t show_ov = !grbl;
  if (grbl && wco_count > 0) {
    wco_count--;
  } else if (grbl) {
    wco_count = busy ? 29 : 9;
    if (ovr_count == 0)
      ovr_count = 1;                   /* Ov: in the next report */
    serial_write("|WCO:");
    report_coords(wco);
  }
  if (grbl && ovr_count > 0) {
    ovr_count--;
  } else if (grbl) {
    ovr_count = busy ? 19 : 9;
    show_ov = 1;
  }
  if (show_ov) {
    serial_write("|Ov:");
    report_uint(feed_ov);
    serial_putc(',');
    report_uint(rapid_ov);
    serial_putc(',');
    report_uint(laser_get_override());
    /* accessories: M3/M4 while its output is on (spindle mode, or the beam burning) and the air */
    uint8_t on = spindle || (g->laser && laser_current_duty() > 0);
    if (grbl && (on || g->air)) {
      serial_write("|A:");
      if (on)
        serial_putc(g->laser == 3 ? 'S' : 'C');
      if (g->air & 2u)
        serial_putc('F');
      if (g->air & 1u)
        serial_putc('M');
    }
  }
  serial_write(">\r\n");
}

void report_build_info(void) {
  serial_write("[VER:1.1h.20261123:");
  if (settings.dialect == GC_DIALECT_GRBL)
    serial_write(settings.build_info);   /* GRBL: the $I= text */
  else
    serial_write("labkit-fw " LK_FW_VERSION);
  serial_write("]\r\n[OPT:VL,");
  report_uint(protocol_planner_blocks());
  serial_putc(',');
  report_uint(SERIAL_RX_SIZE);
  serial_write("]\r\n");
}

void report_help(void) {
  serial_write("[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]\r\n");
}

void report_gcode_modes(void) {
  const gc_state_t *g = gc_state();
  serial_write("[GC:G");
  if (g->motion >= GC_MOTION_PROBE) {
    serial_write("38.");
    report_uint(g->motion - GC_MOTION_PROBE);
  } else {
    report_uint(g->motion);
  }
  serial_write(" G");
  report_uint(54u + g->coord_select);
  serial_write(" G");
  report_uint(17u + g->plane);
  serial_write(g->inches ? " G20" : " G21");
  serial_write(g->absolute ? " G90" : " G91");
  serial_write(g->arc_absolute ? " G90.1" : "");
  serial_write(g->inverse_time ? " G93 M" : " G94 M");
  report_uint(g->laser ? g->laser : 5u);
  serial_write(g->air & 1u ? " M7" : "");
  serial_write(g->air & 2u ? " M8" : "");
  serial_write(g->air ? "" : " M9");
  serial_write(" T0 F");
  uint8_t labkit = gc_get_dialect() == GC_DIALECT_LABKIT;
  double f = g->feed_mm_min;
  if (labkit)
    f /= 60.0;                    /* labkit-fw: F in mm/s */
  report_float(f, labkit ? 3 : 0);
  serial_write(" S");
  report_float(g->s_word, labkit ? 1 : 0);
  serial_write("]\r\n");
}

void report_offsets(void) {
  static const char *const names[] = {"G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30", "G92"};
  const gc_state_t *g = gc_state();
  for (unsigned i = 0; i < sizeof names / sizeof names[0]; i++) {
    const double *v = i < SET_N_COORD ? settings.coord[i] : i < SET_N_COORD + 2
                      ? settings.home_pos[i - SET_N_COORD] : g->g92;
    serial_putc('[');
    serial_write(names[i]);
    serial_putc(':');
    report_coords(v);
    serial_write("]\r\n");
  }
  double tlo[3] = {g->tlo, 0, 0};
  serial_write("[TLO:");
  if (settings.flags & SET_FLAG_REPORT_INCHES)
    report_float(tlo[0] / 25.4, 4);
  else
    report_float(tlo[0], 3);
  serial_write("]\r\n");
  report_probe();
}

void report_probe(void) {
  double mm[3];
  uint8_t touched;
  limits_probe_result(mm, &touched);
  serial_write("[PRB:");
  report_coords(mm);
  serial_write(touched ? ":1]\r\n" : ":0]\r\n");
}
