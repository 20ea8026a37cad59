/*
  report.c - replies, status reports, banner, $I, $G, $#.
*/
#include "report.h"

#include <math.h>

#include "config.h"
#include "gcode.h"
#include "laser.h"
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
  serial_write("\r\nGrbl 1.1h ['$' for help] [labkit-fw " LK_FW_VERSION " dialect:");
  serial_write(settings.dialect == GC_DIALECT_GRBL ? "grbl" : "labkit-fw");
  serial_write("]\r\n");
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

const char *report_state_name(void) {
  switch (protocol_state()) {
  case PROTO_ALARM: return "Alarm";
  case PROTO_CHECK: return "Check";
  case PROTO_JOG: return "Jog";
  default: break;
  }
  if (protocol_hold_requested() && st_state() == ST_IDLE)
    return "Hold:0";
  switch (st_state()) {
  case ST_HOLDING: return "Hold:1";
  case ST_HELD: return "Hold:0";
  case ST_RUN:
  case ST_DWELL: return "Run";
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
  float mm[3];
  double pos[3];
  st_get_position_mm(mm);
  for (int i = 0; i < 3; i++)
    pos[i] = mm[i];
  serial_putc('<');
  serial_write(report_state_name());
  serial_write("|MPos:");
  report_axes(pos, 3);
  serial_write("|FS:");
  report_float(report_feed_mm_min(), 0);
  serial_putc(',');
  double s = (double)laser_current_duty() / (double)LK_LASER_PWM_TOP * gc_get_s_max();
  report_float(s, 0);
  serial_write("|Bf:");
  report_uint(plan_free_slots());
  serial_putc(',');
  report_uint(serial_rx_free());
  uint32_t ln = st_current_line();
  if (ln && !st_is_idle()) {
    serial_write("|Ln:");
    report_uint(ln);
  }
  uint8_t feed_ov, rapid_ov;
  plan_get_overrides(&feed_ov, &rapid_ov);
  serial_write("|Ov:");
  report_uint(feed_ov);
  serial_putc(',');
  report_uint(rapid_ov);
  serial_putc(',');
  report_uint(laser_get_override());
  serial_write(">\r\n");
}

void report_build_info(void) {
  serial_write("[VER:1.1h.20261123:labkit-fw " LK_FW_VERSION "]\r\n[OPT:VL,");
  report_uint(protocol_planner_blocks());
  serial_putc(',');
  report_uint(SERIAL_RX_SIZE);
  serial_write("]\r\n");
}

void report_help(void) {
  serial_write("[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $C $X $H $RST=$ $RST=* $LCD ~ ! ? ctrl-x]\r\n");
}

void report_gcode_modes(void) {
  const gc_state_t *g = gc_state();
  serial_write("[GC:G");
  report_uint(g->motion);
  serial_write(" G54 G");
  report_uint(17u + g->plane);
  serial_write(g->inches ? " G20" : " G21");
  serial_write(g->absolute ? " G90" : " G91");
  serial_write(g->arc_absolute ? " G90.1" : "");
  serial_write(" G94 M");
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
  report_float(g->power_s, labkit ? 1 : 0);
  serial_write("]\r\n");
}

void report_offsets(void) {
  static const char *const names[] = {"G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30", "G92"};
  const double zero[3] = {0, 0, 0};
  for (unsigned i = 0; i < sizeof names / sizeof names[0]; i++) {
    serial_putc('[');
    serial_write(names[i]);
    serial_putc(':');
    report_axes(zero, 3);
    serial_write("]\r\n");
  }
  serial_write("[TLO:0.000]\r\n[PRB:0.000,0.000,0.000:0]\r\n");
}
