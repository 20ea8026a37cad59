/*
  gcode.c - parse, check and execute one line of G-code.

  Three phases, as in labkit/gcode/_kernel.py: scan the words, check every
  command and value and compute the move, then (only when nothing failed)
  commit the modal state and hand the move to the planner. The numbers of
  the errors follow labkit/status_codes.csv.
*/
#include "gcode.h"

#include <math.h>
#include <string.h>

#include "config.h"
#include "defaults.h"
#include "planner.h"
#include "stepper.h"
#include "laser.h"
#include "hal.h"
#include "settings.h"
#include "status_codes.h"

#define MAX_COMMANDS 16

/* letter indices */
enum { L_F = 5, L_G = 6, L_I = 8, L_J = 9, L_K = 10, L_L = 11, L_M = 12, L_N = 13, L_P = 15,
       L_R = 17, L_S = 18, L_T = 19, L_X = 23, L_Y = 24, L_Z = 25 };

/* modal groups */
enum { G_MOTION, G_NONMODAL, G_PLANE, G_UNITS, G_DISTANCE, G_ARCDIST, G_FEEDMODE, G_CUTTER,
       G_TOOLLEN, G_COORD, G_PATH, M_STOP, M_LASER, M_COOLANT };

static const uint8_t plane_axes[3][3] = {{0, 1, 2}, {2, 0, 1}, {1, 2, 0}};

typedef struct {
  double feed_scale;     /* F word -> mm/min */
  double dwell_scale;    /* P word -> s */
  double arc_r_tol;      /* R shortfall taken as a half circle, mm */
  uint8_t full_circle_ok;
  uint8_t require_axis_words;
  const char *letters;   /* value letters besides G and M */
  const int16_t *g_codes;/* 10 x G number, -1 terminated */
  const uint8_t *coolant;/* 0 terminated */
  double max_tool;
} dialect_t;

static const int16_t g_labkit[] = {0, 10, 20, 30, 40, 50, 170, 180, 190, 200, 210, 400, 490, 540,
                                   610, 900, 910, 901, 911, 940, -1};
static const int16_t g_grbl[] = {0, 10, 20, 30, 40, 100, 170, 180, 190, 200, 210, 280, 281, 300, 301,
                                 382, 383, 384, 385, 400, 431, 490, 530, 540, 550, 560, 570, 580, 590, 610, 800,
                                 900,
                                 910, 911, 920, 921, 930, 940, -1};
static const uint8_t cool_labkit[] = {7, 8, 9, 0};
static const uint8_t cool_grbl[] = {8, 9, 0};

static const dialect_t dialects[2] = {
  {60.0, 0.001, 0.0005, 1, 1, "FIJKNPRSXYZ", g_labkit, cool_labkit, 2147483647.0},
  {1.0, 1.0, 0.0, 0, 0, "FIJKLNPRSTXYZ", g_grbl, cool_grbl, 255.0},
};

static gc_state_t gc;
static uint8_t gc_dialect;
static double gc_s_max_grbl = DEFAULT_GRBL_S_MAX;
static uint32_t gc_line_count;
static void (*gc_wait_hook)(void);
static plan_block_t gc_block;   /* the move of the line being executed */

void gc_init(void)
{
  memset(&gc, 0, sizeof gc);
  gc.absolute = 1;
  gc_dialect = GC_DIALECT_LABKIT;
  gc_line_count = 0;
  gc_sync_position();
  gc_load_offsets();
}

void gc_load_offsets(void)
{
  for (int a = 0; a < 3; a++)
    gc.coord[a] = settings.coord[gc.coord_select][a];
  gc.wco_changes++;
}

void gc_end_program(void)
{
  if (!gc.end_owed)
    return;
  gc.end_owed = 0;                 /* GRBL's program end: units, F and S stay */
  gc.motion = 1;
  gc.plane = 0;
  gc.absolute = 1;
  gc.laser = 0;
  gc.air = 0;
  gc.inverse_time = 0;
  gc.coord_select = 0;
  gc_load_offsets();
  hal_air_set(0);
}

void gc_wco(double out[3])
{
  uint8_t grbl = gc_dialect == GC_DIALECT_GRBL;   /* labkit-fw has no work offsets */
  for (int a = 0; a < 3; a++)
    out[a] = grbl ? gc.coord[a] + gc.g92[a] + (a == 2 ? gc.tlo : 0.0) : 0.0;
}

void gc_set_dialect(uint8_t dialect) { gc_dialect = dialect == GC_DIALECT_GRBL ? GC_DIALECT_GRBL : GC_DIALECT_LABKIT; }
uint8_t gc_get_dialect(void) { return gc_dialect; }
void gc_set_s_max(double s_max) { if (s_max > 0) gc_s_max_grbl = s_max; }
double gc_get_s_max(void) { return gc_dialect == GC_DIALECT_GRBL ? gc_s_max_grbl : DEFAULT_LABKIT_S_MAX; }
const gc_state_t *gc_state(void) { return &gc; }
uint32_t gc_current_line(void) { return st_current_line(); }
void gc_set_wait_hook(void (*hook)(void)) { gc_wait_hook = hook; }

void gc_sync_position(void)
{
  int32_t steps[3];
  const lk_machine_t *m = plan_machine();
  st_get_position(steps);
  plan_sync_position(steps);
  for (int a = 0; a < 3; a++)
    gc.pos_mm[a] = (double)steps[a] / m->steps_per_mm[a];
}

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/* [+-]digits[.digits], the way labkit.gcode reads it (18 significant digits,
   one exact division by a power of ten), so both sides get the same double.
   Returns 0 ok, 1 no digits, 2 bad character after it (*out is read), 3 too large. */
static int read_number(const char *s, int *i, double *out)
{
  static const double pow10[23] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
                                   1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21,
                                   1e22};
  int k = *i, neg = 0, ndigits = 0, nsig = 0, dot = 0, frac = 0, extra = 0;
  int64_t mant = 0;
  if (s[k] == '-' || s[k] == '+') {
    neg = s[k] == '-';
    k++;
  }
  for (;; k++) {
    char c = s[k];
    if (c >= '0' && c <= '9') {
      ndigits++;
      if (mant == 0 && c == '0') {
        if (dot) frac++;
      } else if (nsig < 18) {
        mant = mant * 10 + (c - '0');
        nsig++;
        if (dot) frac++;
      } else if (!dot) {
        extra++;
      }
    } else if (c == '.' && !dot) {
      dot = 1;
    } else {
      break;
    }
  }
  *i = k;
  if (ndigits == 0) return 1;
  char c = s[k];
  int bad_after = 0;
  if (c != 0) {
    int ok = is_space(c) || c == '\n' || c == '(' || c == ';' || c == '*' ||
             (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
    bad_after = !ok;
  }
  if (extra > 0) return bad_after ? 2 : 3;
  double v = (double)mant;
  while (frac > 22) {
    v = v / 1e22;
    frac -= 22;
  }
  if (frac > 0) v = v / pow10[frac];
  if (v >= GC_MAX_ABS_VALUE) return bad_after ? 2 : 3;
  *out = neg ? -v : v;
  return bad_after ? 2 : 0;   /* 2: the number is read, a stray character follows it */
}

static int in_list16(const int16_t *list, int v)
{
  for (; *list >= 0; list++)
    if (*list == v) return 1;
  return 0;
}

static int in_range(double v) { return fabs(v) < GC_MAX_ABS_VALUE; }

/* Wait for a free planner slot, preparing ticks meanwhile. 0 when a reset
   cut the wait short. */
static int wait_for_slot(void)
{
  while (plan_is_full()) {
    st_prep_buffer();
    if (!plan_is_full()) break;
    if (gc_wait_hook) gc_wait_hook();
    if (st_take_abort()) return 0;
  }
  return 1;
}

/* Wait until every move before this line has ended (GRBL's buffer synchronisation before a
   probe cycle), preparing ticks meanwhile. 0 when a reset cut the wait short. */
static uint8_t gc_syncing;      /* in wait_for_idle: the motion stops by the program's will */
static int wait_for_idle(void)
{
  plan_flush();
  gc_syncing = 1;
  while (!plan_is_empty() || !st_is_idle()) {
    st_prep_buffer();
    if (gc_wait_hook) gc_wait_hook();
    if (st_take_abort()) {
      gc_syncing = 0;
      return 0;
    }
  }
  gc_syncing = 0;
  return 1;
}

uint8_t gc_waiting_for_idle(void) { return gc_syncing; }

/* The commands of one line, as its G and M words set them. */
typedef struct {
  uint32_t groups;           /* modal groups seen */
  int motion_new, dwell, lookahead, stop, coolant;
  int nonmodal;              /* 10 x G of G10 G28 G28.1 G30 G30.1 G53 G92 G92.1 */
  int axis_command;          /* GRBL: 1 motion, 2 non-modal (G10 G28 G30 G92), 3 tool length */
  int tool_new;              /* 0 G49, 1 G43.1 */
  uint8_t coord_new, inverse_new, plane_new, inches_new, absolute_new, arc_absolute_new, laser_new;
} commands_t;

static void commands_init(commands_t *c)
{
  memset(c, 0, sizeof *c);
  c->motion_new = -1;
  c->stop = -1;
  c->coolant = -1;
  c->tool_new = -1;
  c->coord_new = gc.coord_select;
  c->inverse_new = gc.inverse_time;
  c->plane_new = gc.plane;
  c->inches_new = gc.inches;
  c->absolute_new = gc.absolute;
  c->arc_absolute_new = gc.arc_absolute;
  c->laser_new = gc.laser;
}

/* One G word: its command, its modal group, its conflicts. */
static uint8_t take_g(commands_t *c, const dialect_t *d, double v)
{
  if (v < 0 || v >= 100000.0) return STATUS_UNSUPPORTED_COMMAND;   /* no such G (and no overflow) */
  int t10 = (int)lrint(v * 10.0);
  int grp;
  if (fabs(v * 10.0 - t10) > 1e-6) return STATUS_UNSUPPORTED_COMMAND;
  if (!in_list16(d->g_codes, t10)) {
    int base = t10 - t10 % 10;
    if (t10 % 10 != 0 && in_list16(d->g_codes, base) && !(base == 900 || base == 910 ||
        base == 280 || base == 300 || base == 920 || base == 610))
      return STATUS_NON_INTEGER_COMMAND;
    return STATUS_UNSUPPORTED_COMMAND;
  }
  int code = t10 / 10;
  if (code <= 3 || code == 38 || t10 == 100 || t10 == 280 || t10 == 300 || t10 == 920 ||
      code == 43 || code == 49) {
    if (c->axis_command && gc_dialect == GC_DIALECT_GRBL)
      return STATUS_AXIS_COMMAND_CONFLICT;   /* GRBL: before the modal groups */
    c->axis_command = (code <= 3 || code == 38) ? 1 : (code == 43 || code == 49) ? 3 : 2;
  }
  if (code <= 3 || code == 80) {
    grp = G_MOTION;
    c->motion_new = code;
  } else if (code == 38) {
    grp = G_MOTION;
    c->motion_new = GC_MOTION_PROBE + t10 % 10;   /* G38.2 .. G38.5 */
  } else if (code == 4) {
    grp = G_NONMODAL;
    c->dwell = 1;
  } else if (code == 5) {
    grp = G_NONMODAL;
    c->lookahead = 1;
  } else if (code >= 17 && code <= 19) {
    grp = G_PLANE;
    c->plane_new = (uint8_t)(code - 17);
  } else if (code == 20 || code == 21) {
    grp = G_UNITS;
    c->inches_new = code == 20;
  } else if (t10 == 900 || t10 == 910) {
    grp = G_DISTANCE;
    c->absolute_new = code == 90;
  } else if (t10 == 901 || t10 == 911) {
    grp = G_ARCDIST;
    c->arc_absolute_new = t10 == 901;
  } else if (code == 10 || code == 28 || code == 30 || code == 53 || code == 92) {
    grp = G_NONMODAL;
    c->nonmodal = t10;
  } else if (code == 93 || code == 94) {
    grp = G_FEEDMODE;
    c->inverse_new = code == 93;
  } else if (code == 40) {
    grp = G_CUTTER;
  } else if (code == 49 || code == 43) {
    grp = G_TOOLLEN;
    c->tool_new = code == 43;
  } else if (code >= 54 && code <= 59) {
    grp = G_COORD;
    c->coord_new = (uint8_t)(code - 54);
  } else if (code == 61) {
    grp = G_PATH;
  } else {
    return STATUS_UNSUPPORTED_COMMAND;
  }
  if (c->groups & (1u << grp)) return STATUS_MODAL_GROUP_VIOLATION;
  c->groups |= 1u << grp;
  return STATUS_OK;
}

/* One M word. */
static uint8_t take_m(commands_t *c, const dialect_t *d, double v)
{
  if (v < 0 || fabs(v - nearbyint(v)) > 1e-9) return STATUS_NON_INTEGER_COMMAND;
  if (v >= 100000.0) return STATUS_UNSUPPORTED_COMMAND;   /* no such M (and no overflow) */
  long code = lrint(v);
  int grp;
  if (code == 0 || code == 1 || code == 2 || code == 30) {
    grp = M_STOP;
    c->stop = (int)code;
  } else if (code == 3 || code == 4) {
    grp = M_LASER;
    c->laser_new = (uint8_t)code;
  } else if (code == 5) {
    grp = M_LASER;
    c->laser_new = 0;
  } else if (code < 256 && strchr((const char *)d->coolant, (int)code) && code != 0) {
    grp = M_COOLANT;
    c->coolant = (int)code;
  } else {
    return STATUS_UNSUPPORTED_COMMAND;
  }
  if (c->groups & (1u << grp)) return STATUS_MODAL_GROUP_VIOLATION;
  c->groups |= 1u << grp;
  return STATUS_OK;
}

uint8_t gc_execute_line(char *line)
{
  const dialect_t *d = &dialects[gc_dialect];
  uint8_t present[26] = {0};
  double val[26] = {0};
  double g_val[MAX_COMMANDS], m_val[MAX_COMMANDS];
  int ng = 0, nm = 0, checksum_seen = 0, first = 1;
  int i = 0;
  uint8_t grbl = gc_dialect == GC_DIALECT_GRBL;
  commands_t cmd;
  commands_init(&cmd);

  /* ---- phase 1: scan ---- */
  while (line[i] != 0 && line[i] != '\n') {
    char c = line[i];
    if (is_space(c)) {
      i++;
      continue;
    }
    if (c == '(') {
      int j = i + 1;
      while (line[j] != 0 && line[j] != '\n' && line[j] != ')') j++;
      if (line[j] != ')') return STATUS_BAD_DELIMITER;
      i = j + 1;
      continue;
    }
    if (c == ';') break;
    if (c == '*' && grbl) return STATUS_EXPECTED_LETTER;   /* GRBL has no checksums */
    if (c == '*') {
      uint8_t x = 0;
      for (int k = 0; k < i; k++) x ^= (uint8_t)line[k];
      int j = i + 1, nd = 0;
      uint32_t cs = 0;
      while (line[j] >= '0' && line[j] <= '9') {
        cs = cs * 10 + (uint32_t)(line[j] - '0');
        nd++;
        j++;
      }
      if (nd == 0 || nd > 3) return STATUS_BAD_NUMBER;
      if (cs != x) return STATUS_BAD_CHECKSUM;
      checksum_seen = 1;
      i = j;
      continue;
    }
    if (first && c == '$') return STATUS_UNSUPPORTED_COMMAND;   /* system lines: the shell's */
    if (first && c == '%' && gc_dialect == GC_DIALECT_GRBL)
      return STATUS_EXPECTED_LETTER;   /* GRBL has no program delimiter */
    if (first && c == '%') {
      int j = i + 1;
      while (is_space(line[j])) j++;
      if (line[j] != 0 && line[j] != '\n') return STATUS_EXPECTED_LETTER;
      break;
    }
    first = 0;
    if (checksum_seen) return STATUS_BAD_DELIMITER;
    char u = (c >= 'a' && c <= 'z') ? (char)(c - 32) : c;
    if (!(u >= 'A' && u <= 'Z')) return STATUS_EXPECTED_LETTER;
    int letter = u - 'A';
    i++;
    while (is_space(line[i])) i++;
    double v = 0;
    int rc = read_number(line, &i, &v);
    /* GRBL reads the number and then finds no letter where the next word should start: 1 */
    if (rc != 0 && !(rc == 2 && gc_dialect == GC_DIALECT_GRBL)) return STATUS_BAD_NUMBER;
    if (grbl && (letter == L_G || letter == L_M)) {
      /* GRBL checks each command word as it reads it: an unknown M fails before a bad word after it */
      uint8_t st = letter == L_G ? take_g(&cmd, d, v) : take_m(&cmd, d, v);
      if (st != STATUS_OK) return st;
    } else if (letter == L_G) {
      if (ng == MAX_COMMANDS) return STATUS_MODAL_GROUP_VIOLATION;
      g_val[ng++] = v;
    } else if (letter == L_M) {
      if (nm == MAX_COMMANDS) return STATUS_MODAL_GROUP_VIOLATION;
      m_val[nm++] = v;
    } else {
      if (!strchr(d->letters, u)) return STATUS_UNSUPPORTED_COMMAND;
      if (grbl && letter == L_T && v > d->max_tool) return STATUS_MAX_VALUE_EXCEEDED;
      if (present[letter]) return STATUS_REPEATED_WORD;
      /* GRBL: F N P T S are never negative, checked as the word is read */
      if (grbl && v < 0 && (letter == L_F || letter == L_N || letter == L_P || letter == L_T ||
                            letter == L_S))
        return STATUS_NEGATIVE_VALUE;
      present[letter] = 1;
      val[letter] = v;
    }
  }

  /* ---- phase 2: check and compute ---- */
  if (gc_dialect != GC_DIALECT_GRBL) {      /* GRBL's were taken word by word */
    for (int k = 0; k < ng; k++) {
      uint8_t st = take_g(&cmd, d, g_val[k]);
      if (st != STATUS_OK) return st;
    }
    for (int k = 0; k < nm; k++) {
      uint8_t st = take_m(&cmd, d, m_val[k]);
      if (st != STATUS_OK) return st;
    }
  }
  int motion_new = cmd.motion_new, dwell = cmd.dwell, lookahead = cmd.lookahead, stop = cmd.stop;
  int coolant = cmd.coolant, nonmodal = cmd.nonmodal, axis_command = cmd.axis_command;
  int tool_new = cmd.tool_new;
  uint8_t coord_new = cmd.coord_new, inverse_new = cmd.inverse_new, plane_new = cmd.plane_new;
  uint8_t inches_new = cmd.inches_new, absolute_new = cmd.absolute_new;
  uint8_t arc_absolute_new = cmd.arc_absolute_new, laser_new = cmd.laser_new;

  double scale = inches_new ? 25.4 : 1.0;
  double feed_new = gc.feed_mm_min;
  float power_new = gc.s_word;
  double dwell_s = 0.0, lookahead_p = 0.0;
  int axis_words = present[L_X] || present[L_Y] || present[L_Z];
  int motion_mode = motion_new >= 0 ? motion_new : gc.motion;
  int moving = 0, move_kind = PLAN_MOVE_RAPID, arc_taken = 0;
  double target[3], ctr[3] = {0, 0, 0};

  if (present[L_N] && grbl) {
    val[L_N] = trunc(val[L_N]);        /* GRBL: N1.5 is N1; at most 10,000,000 */
    if (val[L_N] > GC_GRBL_MAX_LINE_NUMBER) return STATUS_BAD_LINE_NUMBER;
  } else if (present[L_N]) {
    double nv = val[L_N];
    if (nv < 0 || nv > GC_MAX_LINE_NUMBER || nv != floor(nv)) return STATUS_BAD_LINE_NUMBER;
  }
  if (inverse_new) {
    feed_new = 0.0;          /* G93: F is 1/min of each move, given in its line */
  } else if (gc.inverse_time && !present[L_F]) {
    feed_new = 0.0;          /* GRBL: leaving G93 leaves no feed */
  }
  if (present[L_F]) {
    if (val[L_F] < 0) return STATUS_NEGATIVE_VALUE;
    feed_new = inverse_new ? val[L_F] : val[L_F] * scale * d->feed_scale;
  }
  int feed_ok = feed_new > 0;
  double wco_new[3], g92_new[3], tlo_new = gc.tlo, coord_data[3] = {0, 0, 0};
  int coord_store = -1;      /* G10: the system written */
  int home_move = -1;        /* G28 / G30: index of the stored position */
  double home[3] = {0, 0, 0};
  for (int a = 0; a < 3; a++) {
    g92_new[a] = gc.g92[a];
    wco_new[a] = (coord_new == gc.coord_select ? gc.coord[a] : settings.coord[coord_new][a]);
  }
  if (tool_new == 1) {
    if (!(present[L_Z] && !present[L_X] && !present[L_Y])) return STATUS_G43_DYNAMIC_AXIS_ERROR;
    tlo_new = val[L_Z] * scale;
  } else if (tool_new == 0) {
    tlo_new = 0.0;
  }
  if (nonmodal == 100) {
    if (!axis_words) return STATUS_MISSING_AXIS_WORDS;
    if (!present[L_P] && !present[L_L]) return STATUS_MISSING_VALUE_WORD;
    double p = present[L_P] ? trunc(val[L_P]) : 0.0;
    if (p < 0 || p > SET_N_COORD) return STATUS_UNSUPPORTED_COORD_SYS;
    double l = trunc(val[L_L]);       /* compared as a double: a huge L is no int */
    if (l != 2.0 && l != 20.0) return STATUS_UNSUPPORTED_COMMAND;
    if (l == 2 && present[L_R]) return STATUS_UNSUPPORTED_COMMAND;
    coord_store = p > 0 ? (int)p - 1 : coord_new;
    for (int a = 0; a < 3; a++) {
      coord_data[a] = settings.coord[coord_store][a];
      if (!present[L_X + a]) continue;
      double v = val[L_X + a] * scale;
      coord_data[a] = l == 20 ? gc.pos_mm[a] - gc.g92[a] - v - (a == 2 ? tlo_new : 0.0) : v;
    }
  } else if (nonmodal == 920) {
    if (!axis_words) return STATUS_MISSING_AXIS_WORDS;
    for (int a = 0; a < 3; a++)
      if (present[L_X + a])
        g92_new[a] = gc.pos_mm[a] - wco_new[a] - val[L_X + a] * scale - (a == 2 ? tlo_new : 0.0);
  } else if (nonmodal == 921) {
    g92_new[0] = g92_new[1] = g92_new[2] = 0.0;
  } else if (nonmodal == 280 || nonmodal == 300) {
    home_move = nonmodal == 280 ? 0 : 1;
    for (int a = 0; a < 3; a++)
      home[a] = settings.home_pos[home_move][a];
  }
  for (int a = 0; a < 3; a++)
    wco_new[a] = gc_dialect == GC_DIALECT_GRBL ? wco_new[a] + g92_new[a] + (a == 2 ? tlo_new : 0.0) : 0.0;
  /* axis words belong to G10, G92 and G43.1 when given; else to the motion */
  int motion_axes = axis_words && axis_command != 2 && axis_command != 3;
  if (home_move >= 0)
    motion_axes = 0;
  if (present[L_T]) {
    if (val[L_T] < 0) return STATUS_NEGATIVE_VALUE;
    if (val[L_T] > d->max_tool) return STATUS_MAX_VALUE_EXCEEDED;
  }
  if (present[L_S]) {
    if (val[L_S] < 0) return STATUS_NEGATIVE_VALUE;
    power_new = (float)val[L_S];
  }
  if (dwell || lookahead) {
    if (!present[L_P]) return STATUS_MISSING_VALUE_WORD;
    if (val[L_P] < 0) return STATUS_NEGATIVE_VALUE;
    if (dwell)
      dwell_s = val[L_P] * d->dwell_scale;
    else
      lookahead_p = val[L_P];
  }
  for (int a = 0; a < 3; a++) {
    if (present[L_X + a] && axis_command != 2 && axis_command != 3) {
      double v = val[L_X + a] * scale;
      if (nonmodal == 530)
        target[a] = v + 0.0;                          /* G53: machine coordinates */
      else
        target[a] = absolute_new ? v + wco_new[a] : gc.pos_mm[a] + v;
    } else {
      target[a] = gc.pos_mm[a];
    }
  }
  if (home_move >= 0) {
    if (axis_words) {              /* through the given point; only its axes go home */
      for (int a = 0; a < 3; a++) {
        double v = present[L_X + a] ? val[L_X + a] * scale : 0.0;
        target[a] = !present[L_X + a] ? gc.pos_mm[a] : absolute_new ? v + wco_new[a] : gc.pos_mm[a] + v;
        if (!present[L_X + a]) home[a] = gc.pos_mm[a];
      }
    }
    moving = 1;
    move_kind = PLAN_MOVE_RAPID;
  }
  if (nonmodal == 530 && !(motion_mode == 0 || motion_mode == 1))
    return STATUS_G53_INVALID_MOTION_MODE;
  if (home_move < 0 && (motion_new >= 0 || motion_axes)) {
    if (motion_mode == 80) {
      if (axis_words) return STATUS_AXIS_WORDS_EXIST;
    } else if (motion_mode == 0 || motion_mode == 1) {
      if (!axis_words) {
        if (d->require_axis_words && motion_new >= 0) return STATUS_MISSING_AXIS_WORDS;
      } else if (motion_mode == 1 && (!feed_ok || (inverse_new && !present[L_F]))) {
        return STATUS_UNDEFINED_FEED;
      } else {
        moving = 1;
        move_kind = motion_mode == 0 ? PLAN_MOVE_RAPID : PLAN_MOVE_LINE;
      }
    } else if (motion_mode >= GC_MOTION_PROBE) {
      /* G38.2-.5 (GRBL): a straight move at F, beam off, that the probe input may end */
      if (!feed_ok || (inverse_new && !present[L_F])) return STATUS_UNDEFINED_FEED;
      if (!axis_words) return STATUS_MISSING_AXIS_WORDS;
      if (target[0] == gc.pos_mm[0] && target[1] == gc.pos_mm[1] && target[2] == gc.pos_mm[2])
        return STATUS_INVALID_ARC;     /* GRBL's invalid target (33): the probe is already there */
      moving = 1;
      move_kind = PLAN_MOVE_LINE;
    } else {
      int a0 = plane_axes[plane_new][0], a1 = plane_axes[plane_new][1];
      int lin = plane_axes[plane_new][2];
      int in_plane = present[L_X + a0] || present[L_X + a1];
      const double *pos = gc.pos_mm;
      if (!feed_ok || (inverse_new && !present[L_F])) return STATUS_UNDEFINED_FEED;
      if (!axis_words && gc_dialect == GC_DIALECT_GRBL) return STATUS_MISSING_AXIS_WORDS;
      if (present[L_R]) {
        double r = val[L_R] * scale;
        double dx = target[a0] - pos[a0];
        double dy = target[a1] - pos[a1];
        double q = sqrt(dx * dx + dy * dy);
        if (!in_plane) return STATUS_MISSING_PLANE_AXIS;
        if (q <= 1e-9) return STATUS_INVALID_ARC;
        double h2 = r * r - 0.25 * q * q;
        if (h2 < 0.0) {
          if (0.5 * q - fabs(r) <= d->arc_r_tol)
            h2 = 0.0;
          else
            return gc_dialect == GC_DIALECT_GRBL ? STATUS_ARC_RADIUS_ERROR : STATUS_INVALID_ARC;
        }
        double h = sqrt(h2);
        int left = (motion_mode == 3) != (r < 0);
        double sgn = left ? 1.0 : -1.0;
        ctr[a0] = 0.5 * (pos[a0] + target[a0]) - sgn * h * dy / q;
        ctr[a1] = 0.5 * (pos[a1] + target[a1]) + sgn * h * dx / q;
        ctr[lin] = pos[lin];
        moving = 1;
        arc_taken = 1;
      } else {
        int io0 = L_I + a0, io1 = L_I + a1;
        if (!(present[io0] || present[io1])) return STATUS_MISSING_OFFSET_WORDS;
        if (arc_absolute_new && !(present[io0] && present[io1])) return STATUS_MISSING_OFFSET_WORDS;
        if (!in_plane && !d->full_circle_ok) return STATUS_MISSING_PLANE_AXIS;
        double o0 = present[io0] ? val[io0] * scale : 0.0;
        double o1 = present[io1] ? val[io1] * scale : 0.0;
        if (arc_absolute_new) {
          ctr[a0] = o0;
          ctr[a1] = o1;
        } else {
          ctr[a0] = pos[a0] + o0;
          ctr[a1] = pos[a1] + o1;
        }
        ctr[lin] = pos[lin];
        double r0 = hypot(pos[a0] - ctr[a0], pos[a1] - ctr[a1]);
        double r1 = hypot(target[a0] - ctr[a0], target[a1] - ctr[a1]);
        double dr = fabs(r1 - r0);
        arc_taken = 1;
        if (r0 <= 1e-9 && grbl) {
          /* GRBL 1.1h: a centre on the start point is a circle of radius 0, accepted when the end
             is within 0.005 mm of it; it moves (at most) straight to the end */
          if (dr > 0.005) return STATUS_INVALID_ARC;
          moving = target[0] != pos[0] || target[1] != pos[1] || target[2] != pos[2];
          move_kind = PLAN_MOVE_LINE;
        } else {
          if (r0 <= 1e-9) return STATUS_INVALID_ARC;
          if (dr > 0.005 && dr > 0.001 * r0) return STATUS_INVALID_ARC;
          moving = 1;
        }
      }
      if (move_kind != PLAN_MOVE_LINE)
        move_kind = motion_mode == 2 ? PLAN_MOVE_ARC_CW : PLAN_MOVE_ARC_CCW;
    }
  }
  if (moving) {
    for (int a = 0; a < 3; a++)
      if (!(in_range(target[a]) && (move_kind < PLAN_MOVE_ARC_CW || in_range(ctr[a]))))
        return STATUS_VALUE_OUT_OF_RANGE;
  }
  {
    int arc_r = arc_taken && present[L_R];
    int arc_ijk = arc_taken && !present[L_R];
    static const uint8_t checked[] = {L_I, L_J, L_K, L_R, L_P, L_L};
    for (unsigned k = 0; k < sizeof checked; k++) {
      int letter = checked[k], used;
      if (!present[letter]) continue;
      if (letter == L_R)
        used = arc_r;
      else if (letter == L_P)
        used = dwell || lookahead || nonmodal == 100;
      else if (letter == L_L)
        used = nonmodal == 100;
      else
        used = arc_ijk;
      if (!used) return STATUS_UNUSED_WORDS;
    }
  }

  /* the block of the move: the machine may still refuse it (an arc it cannot walk) */
  if (moving) {
    plan_move_t mv;
    int burning = move_kind != PLAN_MOVE_RAPID && laser_new != 0 && power_new > 0 &&
                  motion_mode < GC_MOTION_PROBE;   /* a probe never fires the beam */
    mv.kind = (uint8_t)move_kind;
    mv.plane = plane_new;
    mv.laser = burning ? laser_new : 0;
    double frac = (double)power_new / gc_get_s_max();
    if (frac < 0.0) frac = 0.0;
    if (frac > 1.0) frac = 1.0;
    mv.power_mw = burning ? frac * plan_machine()->laser_max_power_mw : 0.0;
    mv.feed_mm_min = feed_new;
    if (inverse_new && move_kind != PLAN_MOVE_RAPID) {
      /* G93: the move takes 1/F minutes */
      double len = 0.0;
      if (move_kind == PLAN_MOVE_LINE) {
        for (int a = 0; a < 3; a++)
          len += (target[a] - gc.pos_mm[a]) * (target[a] - gc.pos_mm[a]);
        len = sqrt(len);
      } else {
        int a0 = plane_axes[plane_new][0], a1 = plane_axes[plane_new][1], lin = plane_axes[plane_new][2];
        double r = hypot(gc.pos_mm[a0] - ctr[a0], gc.pos_mm[a1] - ctr[a1]);
        double t0 = atan2(gc.pos_mm[a1] - ctr[a1], gc.pos_mm[a0] - ctr[a0]);
        double t1 = atan2(target[a1] - ctr[a1], target[a0] - ctr[a0]);
        double sweep = move_kind == PLAN_MOVE_ARC_CW ? t0 - t1 : t1 - t0;
        if (sweep <= 1e-12) sweep += 6.283185307179586;   /* a full turn */
        len = hypot(r * sweep, target[lin] - gc.pos_mm[lin]);
      }
      mv.feed_mm_min = len * feed_new;
    }
    mv.line = present[L_N] ? (uint32_t)val[L_N] : gc_line_count + 1;
    for (int a = 0; a < 3; a++) {
      mv.start_mm[a] = gc.pos_mm[a];
      mv.end_mm[a] = target[a];
      mv.centre_mm[a] = move_kind >= PLAN_MOVE_ARC_CW ? ctr[a] : 0.0;
    }
    uint8_t st = plan_prepare_move(&mv, &gc_block);
    if (st != STATUS_OK) return st;
  }

  /* ---- phase 3: commit ---- */
  gc.stop_now = 0;
  gc.probe_now = moving && motion_mode >= GC_MOTION_PROBE ? (uint8_t)(motion_mode - GC_MOTION_PROBE) : 0;
  /* A probe starts from rest, as GRBL's probe cycle does: the line has been checked whole
     (a wrong one is answered at once, whatever is queued), a good one waits here for the
     moves before it. A reset meanwhile drops it. */
  if (gc.probe_now && !wait_for_idle()) {
    gc.probe_now = 0;
    gc.sync_now = 0;
    return STATUS_OK;
  }
  /* GRBL changes the work offsets (G92, G92.1, G54-G59) and stored positions (G10, G28.1,
     G30.1) only once the moves before the line have ended, so a status report meanwhile still
     shows the old WCO (planner_sync #21-#34): checked above, waited for here, committed below.
     G43.1/G49 it applies at once and answers after the moves (#37, #38: sync_now). A reset
     (or a hard limit) that cuts the wait short drops the line, but what it writes to the
     settings storage is written, as GRBL's EEPROM write follows its aborted wait (reset_wait:
     G10 L20 then a reset). */
  /* GRBL also switches the laser (spindle) and the coolant only with its planner empty
     (planner_sync #4-#18): a new M3/M4/M5; a new S while the laser is on, except on a motion
     line in laser mode ($32=1), whose power rides with its move; in laser mode M3's switch
     between a G1-G3 mode and another on a line without motion (the beam's level at rest
     changes); a new M8 or M9. The moves before the line end at rest there (the step stream
     stops, as labkit.motion.plan does at labkit.gcode.grbl_sync_lines) and a report meanwhile
     shows the old state. The labkit-fw dialect keeps power in the step stream ([CBR40]). */
  uint8_t power_sync = 0;
  if (gc_dialect == GC_DIALECT_GRBL) {
    int motion_line = axis_words && axis_command != 2 && axis_command != 3;
    int cut_old = gc.motion >= 1 && gc.motion <= 3, cut_new = motion_mode >= 1 && motion_mode <= 3;
    int force = settings.laser_mode && gc.laser == 3 && !motion_line && cut_old != cut_new;
    power_sync = laser_new != gc.laser ||
                 (gc.laser != 0 && !(settings.laser_mode && motion_line) &&
                  (power_new != gc.s_word || force)) ||
                 (coolant == 8 && !(gc.air & 2)) || (coolant == 9 && gc.air);
  }
  if (gc_dialect == GC_DIALECT_GRBL &&
      (nonmodal == 100 || nonmodal == 281 || nonmodal == 301 || nonmodal == 920 ||
       nonmodal == 921 || coord_new != gc.coord_select || power_sync) &&
      !wait_for_idle()) {
    if (coord_store >= 0)
      settings_store_coord((uint8_t)coord_store, coord_data);
    if (nonmodal == 281 || nonmodal == 301)
      settings_store_coord(nonmodal == 281 ? SET_N_COORD : SET_N_COORD + 1, gc.pos_mm);
    gc.sync_now = 0;
    return STATUS_OK;
  }
  gc.sync_now = gc_dialect == GC_DIALECT_GRBL &&
                (dwell || gc.probe_now || stop == 2 || stop == 30 ||
                 (tool_new >= 0 && tlo_new != gc.tlo));   /* GRBL: a new tool offset only */
  gc_line_count++;
  if (power_sync)
    gc.power_syncs++;
  if (coord_new != gc.coord_select || nonmodal == 920 || nonmodal == 921 || tool_new >= 0)
    gc.wco_changes++;
  gc.coord_select = coord_new;
  gc.inverse_time = inverse_new;
  gc.tlo = tlo_new;
  for (int a = 0; a < 3; a++) {
    gc.g92[a] = g92_new[a];
    gc.coord[a] = settings.coord[coord_new][a];
  }
  if (coord_store >= 0) {
    settings_store_coord((uint8_t)coord_store, coord_data);
    if (coord_store == gc.coord_select) {   /* another system's values change no WCO */
      for (int a = 0; a < 3; a++)
        gc.coord[a] = coord_data[a];
      gc.wco_changes++;
    }
  }
  if (nonmodal == 281 || nonmodal == 301)
    settings_store_coord(nonmodal == 281 ? SET_N_COORD : SET_N_COORD + 1, gc.pos_mm);
  gc.line = present[L_N] ? (uint32_t)val[L_N] : gc_line_count;
  gc.feed_mm_min = feed_new;
  gc.s_word = power_new;
  gc.laser = laser_new;
  if (coolant >= 0) {
    if (coolant == 7) gc.air |= 1;
    if (coolant == 8) gc.air |= 2;
    if (coolant == 9) gc.air = 0;
    hal_air_set(gc.air);
  }
  if (dwell) {
    if (!wait_for_slot()) return STATUS_OK;
    plan_push_dwell(dwell_s, gc.line);
  }
  if (lookahead) {
    uint32_t depth = lookahead_p < 1.0 ? 1u : lookahead_p > PLAN_MAX_DEPTH ? PLAN_MAX_DEPTH
                                                                          : (uint32_t)lookahead_p;
    gc.lookahead = depth;
    plan_set_depth(depth);
  }
  gc.plane = plane_new;
  gc.inches = inches_new;
  gc.absolute = absolute_new;
  gc.arc_absolute = arc_absolute_new;
  if (motion_new >= 0) gc.motion = (uint8_t)motion_new;
  if (moving) {
    if (!wait_for_slot()) return STATUS_OK;
    plan_push_block(&gc_block);
    for (int a = 0; a < 3; a++) gc.pos_mm[a] = target[a];
  }
  if (home_move >= 0) {          /* G28 / G30: then to the stored position, rapid */
    plan_move_t mv;
    memset(&mv, 0, sizeof mv);
    mv.kind = PLAN_MOVE_RAPID;
    mv.plane = gc.plane;
    mv.feed_mm_min = feed_new;
    mv.line = gc.line;
    for (int a = 0; a < 3; a++) {
      mv.start_mm[a] = gc.pos_mm[a];
      mv.end_mm[a] = home[a];
    }
    if (plan_prepare_move(&mv, &gc_block) == STATUS_OK) {
      if (!wait_for_slot()) return STATUS_OK;
      plan_push_block(&gc_block);
      for (int a = 0; a < 3; a++) gc.pos_mm[a] = home[a];
    }
  }
  if (stop >= 0) {
    gc.program_flow = stop == 0 ? GC_FLOW_PAUSED : stop == 1 ? GC_FLOW_OPTIONAL_PAUSE : GC_FLOW_END;
    gc.stop_now = gc.program_flow;
    plan_flush();
    /* GRBL resets the modal state only once the moves before the program end have ended (a
       report meanwhile shows the old WCO: program_end_moving); nothing is read meanwhile, so
       the grbl dialect leaves the reset to the protocol (gc_end_program), at rest. */
    if (stop == 2 || stop == 30) {
      gc.end_owed = 1;
      if (gc_dialect != GC_DIALECT_GRBL)
        gc_end_program();
    }
  } else if (moving || dwell) {
    gc.program_flow = GC_FLOW_RUNNING;
  }
  return STATUS_OK;
}
