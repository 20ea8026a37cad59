/*
  planner.c - blocks, the block ring buffer, the look-ahead (GRBL junction
  deviation and [CBR40]'s MBLA super blocks) and the integer step-rate
  program of each block. The arc walk that counts an arc's ticks is arc.c;
  the machine's fields and their checks are machine.c.

  The arithmetic follows labkit.motion (blocks.py, planner.py,
  _planner.py, profile.py, _ramp.py, timer.py) operation by operation in
  IEEE double, so that the tests can hold the firmware to the shared
  vectors exactly.
*/
#include "planner.h"

#include <math.h>
#include <string.h>

#include "arc.h"
#include "status_codes.h"
#include "stepper.h"

/* largest |position| in steps: int32 counters with room for the arithmetic */
#define PLAN_MAX_STEPS 536870912.0   /* 2^29: 2N of a line stays in int32 */

/* ------------------------------------------------------------------ state */

static struct {
  lk_machine_t m;
  plan_block_t ring[PLAN_BUFFER_SIZE];
  uint8_t tail, count;
  uint8_t mode, law;
  uint32_t depth;
  int32_t pos[3];             /* end of the last pushed move, steps */
  uint8_t flushed;            /* the stream ended: the next block starts a new one */
  uint8_t pending_dwell;      /* a dwell was pushed since the last motion block */
  /* last pushed motion block (grouping) */
  uint8_t have_last;
  uint8_t last_rapid, last_kind;
  double last_unit_out[3];
  int32_t group_id;
  uint32_t group_size;
  double group_top;
  /* last planned motion block (the entry of the next) */
  uint8_t current_planned;
  double prev_exit, prev_rest, prev_cap;
  int32_t run_id;             /* junction planner: runs between full stops */
  uint8_t ovr_feed, ovr_rapid; /* overrides, % */
} pl;

lk_machine_t *plan_machine(void) { return &pl.m; }

static void clear_buffer(void)
{
  arc_keep_reset();
  pl.tail = 0;
  pl.count = 0;
  pl.flushed = 1;
  pl.pending_dwell = 0;
  pl.have_last = 0;
  pl.current_planned = 0;
}

void plan_init(void)
{
  memset(&pl, 0, sizeof pl);
  machine_load_defaults(&pl.m);
  pl.mode = PLAN_MODE_JUNCTION;
  pl.law = PLAN_LAW_ACCEL;
  pl.ovr_feed = pl.ovr_rapid = 100;
  pl.depth = (uint32_t)pl.m.buffer_blocks;
  pl.group_id = -1;
  pl.run_id = -1;
  clear_buffer();
}

uint8_t plan_apply_machine(void)
{
  uint8_t st = machine_check(&pl.m);
  if (st == STATUS_OK) pl.depth = (uint32_t)pl.m.buffer_blocks;
  return st;
}

void plan_reset(void) { clear_buffer(); }

void plan_set_mode(uint8_t mode)
{
  pl.mode = mode <= PLAN_MODE_HQ ? mode : PLAN_MODE_JUNCTION;
  pl.law = pl.mode == PLAN_MODE_JUNCTION ? PLAN_LAW_ACCEL : PLAN_LAW_LINEAR;
}
uint8_t plan_get_mode(void) { return pl.mode; }
void plan_set_law(uint8_t law) { pl.law = law == PLAN_LAW_LINEAR ? PLAN_LAW_LINEAR : PLAN_LAW_ACCEL; }
uint8_t plan_get_law(void) { return pl.law; }
void plan_set_depth(uint32_t blocks)
{
  pl.depth = blocks < 1 ? 1 : blocks > PLAN_MAX_DEPTH ? PLAN_MAX_DEPTH : blocks;
}
uint32_t plan_get_depth(void) { return pl.depth; }

uint8_t plan_is_full(void) { return pl.count >= PLAN_BUFFER_SIZE; }
uint8_t plan_is_empty(void) { return pl.count == 0; }
uint8_t plan_free_slots(void) { return (uint8_t)(PLAN_BUFFER_SIZE - pl.count); }
void plan_get_position(int32_t steps[3]) { memcpy(steps, pl.pos, sizeof pl.pos); }
void plan_sync_position(const int32_t steps[3]) { memcpy(pl.pos, steps, sizeof pl.pos); }
void plan_flush(void) { pl.flushed = 1; }

/* ------------------------------------------------------------------ helpers */

int32_t plan_to_steps(double mm, double steps_per_mm)
{
  double x = mm * steps_per_mm;
  double r = floor(fabs(x) + 0.5);
  return (int32_t)(x < 0 ? -r : r);
}

uint32_t plan_isqrt(uint64_t x)
{
  uint64_t r = (uint64_t)sqrt((double)x);
  while (r * r > x) r--;
  while ((r + 1) * (r + 1) <= x) r++;
  return (uint32_t)r;
}

uint32_t plan_tick_rate(const plan_block_t *b, uint32_t k, uint8_t law)
{
  uint64_t back = (uint64_t)b->ticks - 1 - k, rise, fall;
  if (law == PLAN_LAW_LINEAR) {
    rise = (uint64_t)b->f_entry + (uint64_t)b->up * k;
    fall = (uint64_t)b->f_exit + (uint64_t)b->down * back;
  } else {
    rise = plan_isqrt((uint64_t)b->f_entry * b->f_entry + 2ull * b->up * k);
    fall = plan_isqrt((uint64_t)b->f_exit * b->f_exit + 2ull * b->down * back);
  }
  uint64_t f = rise < b->f_peak ? rise : b->f_peak;
  if (fall < f) f = fall;
  if (f < b->f_min) f = b->f_min;
  return (uint32_t)f;
}

uint32_t plan_timer_period(uint32_t f_hz)
{
  uint64_t q = (uint64_t)f_hz * (pl.m.prescaler + 1);
  if (q == 0) q = 1;
  return (uint32_t)((pl.m.timer_clock_hz + q - 1) / q - 1);
}

/* double -> uint32, saturating (absurd feeds must not be undefined behaviour) */
static uint32_t sat_u32(double x)
{
  if (!(x > 0.0)) return 0;
  if (x >= 4294967295.0) return UINT32_MAX;
  return (uint32_t)x;
}

static double reach(double v0, double d, double slope, uint8_t law)
{
  if (law == PLAN_LAW_LINEAR) return v0 + slope * d;
  return sqrt(v0 * v0 + 2.0 * slope * d);
}

static double dmin(double a, double b) { return a < b ? a : b; }
static double dmax(double a, double b) { return a > b ? a : b; }

/* min_i(values_i / |u_i|) over the axes the direction uses */
static double axis_limit(const double values[3], const double u[3])
{
  double best = INFINITY;
  for (int a = 0; a < 3; a++) {
    if (fabs(u[a]) > 1e-12) {
      double v = values[a] / fabs(u[a]);
      if (v < best) best = v;
    }
  }
  return best;
}

/* ------------------------------------------------------------------ blocks */

static const uint8_t plane_axes[3][3] = {{0, 1, 2}, {2, 0, 1}, {1, 2, 0}};

static void apply_overrides(plan_block_t *b);

uint8_t plan_prepare_move(const plan_move_t *mv, plan_block_t *b)
{
  const lk_machine_t *m = &pl.m;
  const double *spm = m->steps_per_mm;
  double vmax[3];
  memset(b, 0, sizeof *b);
  for (int a = 0; a < 3; a++) {   /* positions must fit the step counters */
    double x = mv->end_mm[a] * spm[a];
    if (!(fabs(x) < PLAN_MAX_STEPS)) return STATUS_VALUE_OUT_OF_RANGE;
    if (mv->kind >= PLAN_MOVE_ARC_CW && !(fabs(mv->centre_mm[a] * spm[a]) < PLAN_MAX_STEPS))
      return STATUS_VALUE_OUT_OF_RANGE;
  }
  for (int a = 0; a < 3; a++) {
    vmax[a] = m->max_rate_mm_min[a] / 60.0;
    b->start_steps[a] = pl.pos[a];
    b->end_steps[a] = plan_to_steps(mv->end_mm[a], spm[a]);
  }
  b->kind = mv->kind >= PLAN_MOVE_ARC_CW ? PLAN_BLOCK_ARC : PLAN_BLOCK_LINE;
  b->rapid = mv->kind == PLAN_MOVE_RAPID;
  b->plane = mv->plane;
  b->line = mv->line;
  double delta[3], length = 0.0;
  uint32_t ticks = 0;
  for (int a = 0; a < 3; a++) {
    int32_t d = b->end_steps[a] - b->start_steps[a];
    delta[a] = (double)d / spm[a];
    uint32_t ad = (uint32_t)(d < 0 ? -d : d);
    if (ad > ticks) ticks = ad;
    if (d < 0) b->dir_bits |= (uint8_t)(1u << a);
  }
  length = sqrt(delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]);
  for (int a = 0; a < 3; a++) {
    double u = length > 0 ? delta[a] / length : 0.0;
    b->unit_in[a] = u;
    b->unit_out[a] = u;
  }
  double limit = axis_limit(vmax, b->unit_in);
  double accel = axis_limit(m->accel_mm_s2, b->unit_in);

  if (b->kind == PLAN_BLOCK_ARC) {
    int a0 = plane_axes[mv->plane][0], a1 = plane_axes[mv->plane][1], lin = plane_axes[mv->plane][2];
    const double *c = mv->centre_mm, *p0 = mv->start_mm, *p1 = mv->end_mm;
    if (!(fabs(spm[a0] - spm[a1]) <= 1e-12 * dmax(fabs(spm[a0]), fabs(spm[a1]))))
      return STATUS_INVALID_ARC;
    int cw = mv->kind == PLAN_MOVE_ARC_CW;
    double sw = arc_sweep_angle(p0[a0], p0[a1], p1[a0], p1[a1], c[a0], c[a1], cw);
    double r = hypot(p0[a0] - c[a0], p0[a1] - c[a1]);
    double r_end = hypot(p1[a0] - c[a0], p1[a1] - c[a1]);
    if (fabs(r_end - r) > 0.005 && fabs(r_end - r) > 0.001 * r) return STATUS_INVALID_ARC;
    int32_t s2[2] = {b->start_steps[a0], b->start_steps[a1]};
    int32_t e2[2] = {b->end_steps[a0], b->end_steps[a1]};
    double c2[2] = {c[a0] * spm[a0], c[a1] * spm[a0]};
    if (arc_init(&b->arc, s2, e2, c2, cw, r * spm[a0], sw) != 0) return STATUS_INVALID_ARC;
    uint32_t n_ticks;
    /* a big arc takes a while to count: the motors are fed meanwhile */
    if (arc_count(&b->arc, s2[0], s2[1], &n_ticks, &b->kept, st_prep_buffer) != 0)
      return STATUS_INVALID_ARC;
    int32_t h = b->end_steps[lin] - b->start_steps[lin];
    if ((uint32_t)(h < 0 ? -h : h) > n_ticks) return STATUS_INVALID_ARC;
    ticks = n_ticks;
    double arc_len = fabs(sw) * r;
    double rise = (double)h / spm[lin];
    length = hypot(arc_len, rise);
    double sgn = sw > 0 ? 1.0 : sw < 0 ? -1.0 : 0.0;
    for (int pass = 0; pass < 2; pass++) {
      const double *pt = pass == 0 ? p0 : p1;
      double *tgt = pass == 0 ? b->unit_in : b->unit_out;
      double rx = pt[a0] - c[a0], ry = pt[a1] - c[a1];
      double nrm = dmax(hypot(rx, ry), 1e-300);
      double t0 = -ry * sgn / nrm, t1 = rx * sgn / nrm;
      tgt[a0] = t0 * arc_len / length;
      tgt[a1] = t1 * arc_len / length;
      tgt[lin] = rise / length;
    }
    limit = dmin(dmin(vmax[a0], vmax[a1]), sqrt(dmin(m->accel_mm_s2[a0], m->accel_mm_s2[a1]) * r));
    accel = dmin(m->accel_mm_s2[a0], m->accel_mm_s2[a1]);
    if (h != 0) {
      limit = dmin(dmin(dmin(vmax[a0], vmax[a1]), vmax[lin]),
                   sqrt(dmin(m->accel_mm_s2[a0], m->accel_mm_s2[a1]) * r));
      accel = dmin(accel, m->accel_mm_s2[lin]);
    }
  }
  b->ticks = ticks;
  b->length_mm = length;
  b->prog_feed_mm_s = b->rapid ? INFINITY : mv->feed_mm_min / 60.0;
  b->limit_mm_s = limit;
  b->accel_mm_s2 = accel;
  apply_overrides(b);
  b->laser = mv->laser;
  b->power_mw = mv->power_mw;
  return STATUS_OK;
}

/* feed_mm_s, cap_mm_s and rest_mm_s of a motion block from its programmed
   feed, its limit and the overrides (at 100 % exactly labkit.motion's). */
static void apply_overrides(plan_block_t *b)
{
  b->feed_mm_s = b->prog_feed_mm_s;
  double limit = b->limit_mm_s;
  if (b->rapid) {
    if (pl.ovr_rapid != 100) limit = limit * (double)pl.ovr_rapid / 100.0;
  } else if (pl.ovr_feed != 100) {
    b->feed_mm_s = b->prog_feed_mm_s * (double)pl.ovr_feed / 100.0;
  }
  b->cap_mm_s = dmin(b->feed_mm_s, limit);
  b->rest_mm_s = b->ticks > 0
                     ? dmin((double)pl.m.start_rate_hz * b->length_mm / (double)b->ticks, b->cap_mm_s)
                     : 0.0;
}

static plan_block_t *slot(uint32_t i) { return &pl.ring[(pl.tail + i) % PLAN_BUFFER_SIZE]; }

static void push_raw(const plan_block_t *b)
{
  *slot(pl.count) = *b;
  pl.count++;
}

void plan_push_block(const plan_block_t *src)
{
  memcpy(pl.pos, src->end_steps, sizeof pl.pos);
  if (src->ticks == 0 || plan_is_full()) return;   /* no step: no block (GRBL drops them too) */
  plan_block_t b = *src;
  apply_overrides(&b);   /* the overrides may have changed since it was prepared */
  if (b.kind == PLAN_BLOCK_ARC) arc_keep_commit(&b.kept);
  if (pl.flushed)
    b.stop_before = PLAN_STOP_START;
  else if (pl.pending_dwell)
    b.stop_before = PLAN_STOP_DWELL;
  else
    b.stop_before = PLAN_STOP_NONE;
  pl.flushed = 0;
  pl.pending_dwell = 0;
  if (b.stop_before == PLAN_STOP_START) pl.have_last = 0;
  /* MBLA super blocks (labkit.motion._planner.group_blocks) */
  int is_new = !pl.have_last || b.stop_before != PLAN_STOP_NONE || b.rapid != pl.last_rapid ||
               pl.group_size >= pl.depth;
  if (!is_new && pl.mode == PLAN_MODE_HQ) {
    double dot = pl.last_unit_out[0] * b.unit_in[0] + pl.last_unit_out[1] * b.unit_in[1] +
                 pl.last_unit_out[2] * b.unit_in[2];
    int same = dot >= 1.0 - 1e-9 && b.kind == PLAN_BLOCK_LINE && pl.last_kind == PLAN_BLOCK_LINE;
    if (!same) is_new = 1;
  }
  if (is_new) {
    pl.group_id++;
    pl.group_size = 0;
    pl.group_top = 0.0;
  }
  b.group = pl.group_id;
  pl.group_size++;
  pl.group_top = dmax(pl.group_top, b.cap_mm_s);
  b.plan_cap_mm_s = pl.group_top;   /* top of the group so far (fast mode) */
  for (uint32_t i = 0; i < pl.count; i++) {   /* raise the top of the group's earlier blocks */
    plan_block_t *o = slot(i);
    if (o->kind != PLAN_BLOCK_DWELL && o->group == b.group) o->plan_cap_mm_s = pl.group_top;
  }
  pl.have_last = 1;
  pl.last_rapid = b.rapid;
  pl.last_kind = b.kind;
  memcpy(pl.last_unit_out, b.unit_out, sizeof b.unit_out);
  push_raw(&b);
}

void plan_push_dwell(double seconds, uint32_t line)
{
  if (plan_is_full()) return;
  plan_block_t b;
  memset(&b, 0, sizeof b);
  b.kind = PLAN_BLOCK_DWELL;
  b.line = line;
  b.dwell_s = seconds;
  memcpy(b.start_steps, pl.pos, sizeof pl.pos);
  memcpy(b.end_steps, pl.pos, sizeof pl.pos);
  if (!pl.flushed) pl.pending_dwell = 1;
  push_raw(&b);
}

/* ------------------------------------------------------------------ look-ahead */

/* GRBL's junction speed limit between two directions (labkit.motion.planner.junction_speed_caps) */
static double junction_safe(const double up[3], const double un[3])
{
  const lk_machine_t *m = &pl.m;
  double cos_theta = -(up[0] * un[0] + up[1] * un[1] + up[2] * un[2]);
  double j[3] = {un[0] - up[0], un[1] - up[1], un[2] - up[2]};
  double norm = sqrt(j[0] * j[0] + j[1] * j[1] + j[2] * j[2]);
  double a = INFINITY;
  for (int i = 0; i < 3; i++) {
    double ji = norm > 0 ? j[i] / norm : 0.0;
    if (fabs(ji) > 1e-12) a = dmin(a, m->accel_mm_s2[i] / fabs(ji));
  }
  double c = 0.5 * (1.0 - cos_theta);
  if (c < 0.0) c = 0.0;
  if (c > 1.0) c = 1.0;
  double sin_half = sqrt(c);
  double v = sqrt(a * m->junction_deviation_mm * sin_half / (1.0 - sin_half));
  if (cos_theta > 0.999999) v = 0.0;
  if (cos_theta < -0.999999) v = INFINITY;
  return v;
}

static double block_cap(const plan_block_t *b)
{
  if (pl.mode == PLAN_MODE_FAST) return dmin(b->plan_cap_mm_s, b->limit_mm_s);
  return b->cap_mm_s;
}

static double block_floor(const plan_block_t *b) { return dmin(b->rest_mm_s, block_cap(b)); }

static double slope_up(const plan_block_t *b)
{
  return pl.law == PLAN_LAW_LINEAR ? (double)pl.m.accel_hz_per_step : b->accel_mm_s2;
}
static double slope_down(const plan_block_t *b)
{
  return pl.law == PLAN_LAW_LINEAR ? (double)pl.m.decel_hz_per_step : b->accel_mm_s2;
}

/* junction between motion blocks p and n: planner cap and rest speed */
static void junction(const plan_block_t *p, const plan_block_t *n, double *jcap, double *jrest)
{
  double cp = block_cap(p), cn = block_cap(n);
  /* a stop is passed at the larger rest speed, but across a dwell the machine stands
     still and each side ramps from or to its own rest (labkit.motion.planner.lookahead) */
  double pair = n->stop_before == PLAN_STOP_DWELL ? dmin(p->rest_mm_s, n->rest_mm_s)
                                                  : dmax(p->rest_mm_s, n->rest_mm_s);
  double rest = dmin(pair, dmin(cp, cn));
  int stop = n->stop_before != PLAN_STOP_NONE;
  double cap;
  if (pl.mode == PLAN_MODE_JUNCTION) {
    cap = dmin(junction_safe(p->unit_out, n->unit_in), dmin(cp, cn));
  } else {
    cap = dmin(cp, cn);
    if (p->group != n->group) stop = 1;
  }
  *jrest = rest;
  *jcap = stop ? rest : dmax(cap, rest);
}

static void set_step_program(plan_block_t *b)
{
  const lk_machine_t *m = &pl.m;
  double scale = (double)b->ticks / b->length_mm;
  double fm = floor(b->cap_mm_s * scale);   /* the block's own cap, also in fast mode */
  if (fm > (double)m->start_rate_hz) fm = (double)m->start_rate_hz;
  if (fm < 1) fm = 1;
  uint32_t f_min = (uint32_t)fm;
  double v[3] = {b->entry_mm_s, b->peak_mm_s, b->exit_mm_s};
  uint32_t f[3];
  for (int i = 0; i < 3; i++) {
    uint32_t r = sat_u32(floor(v[i] * scale + 1e-9));
    f[i] = r > f_min ? r : f_min;
  }
  b->f_entry = f[0];
  b->f_peak = f[1];
  b->f_exit = f[2];
  b->f_min = f_min;
  if (pl.law == PLAN_LAW_LINEAR) {
    b->up = (uint32_t)m->accel_hz_per_step;
    b->down = (uint32_t)m->decel_hz_per_step;
  } else {
    uint32_t u = sat_u32(floor(b->accel_mm_s2 * scale));
    b->up = b->down = u < 1 ? 1u : u;
  }
  double feed = isfinite(b->prog_feed_mm_s) ? b->prog_feed_mm_s : 0.0;   /* M4 ratio: as programmed */
  b->f_feed = sat_u32(floor(feed * scale + 1e-9));
}

plan_block_t *plan_get_current_block(void)
{
  if (pl.count == 0) return NULL;
  plan_block_t *b = slot(0);
  if (pl.current_planned) return b;
  if (b->kind == PLAN_BLOCK_DWELL) {
    double c = floor(b->dwell_s * (double)pl.m.timer_clock_hz + 0.5);
    b->dwell_cycles = c < 1.8e19 ? (uint64_t)c : (uint64_t)1.8e19;   /* beyond: centuries */
    pl.current_planned = 1;
    return b;
  }
  /* the window: this block and up to depth more motion blocks of its stream */
  uint32_t W = pl.depth;
  plan_block_t *win[PLAN_BUFFER_SIZE];
  uint32_t cnt = 0;
  int seq_end = 0;
  for (uint32_t i = 0; i < pl.count && cnt < W + 1; i++) {
    plan_block_t *o = slot(i);
    if (o->kind == PLAN_BLOCK_DWELL) continue;
    if (cnt > 0 && o->stop_before == PLAN_STOP_START) {
      seq_end = 1;
      break;
    }
    win[cnt++] = o;
  }
  if (cnt < W + 1 && !seq_end) {
    if (pl.flushed) {
      seq_end = 1;
    } else if (plan_is_full()) {
      /* dwells fill the ring before the window is complete: plan with the
         blocks there are (a shorter window), or stop at the only one */
      if (cnt >= 2)
        W = cnt - 1;
      else
        seq_end = 1;
    } else {
      return NULL;   /* wait for more blocks or the end of the stream */
    }
  }
  if (pl.mode == PLAN_MODE_FAST && !seq_end) {
    /* fast MBLA: the caps in the window are the tops of their super blocks, so
       the super block of the window's last block must be complete too */
    int complete = 0;
    uint32_t seen = 0;
    for (uint32_t i = 0; i < pl.count; i++) {
      plan_block_t *o = slot(i);
      if (o->kind == PLAN_BLOCK_DWELL) continue;
      if (++seen <= cnt) continue;
      if (o->stop_before == PLAN_STOP_START || o->group != win[cnt - 1]->group) complete = 1;
      break;
    }
    if (!complete && !pl.flushed && !plan_is_full()) return NULL;
  }
  /* speeds at the junctions 0 .. e of the window (0 = entry of this block) */
  double jcap[PLAN_BUFFER_SIZE + 1] = {0}, jrest[PLAN_BUFFER_SIZE + 1] = {0};
  uint32_t e = seq_end ? (cnt < W ? cnt : W) : W;
  for (uint32_t j = 1; j <= e; j++) {
    if (j < cnt)
      junction(win[j - 1], win[j], &jcap[j], &jrest[j]);
    else
      jcap[j] = jrest[j] = win[cnt - 1]->rest_mm_s;   /* end of the stream */
  }
  double entry, entry_rest;
  if (b->stop_before == PLAN_STOP_START) {
    entry = entry_rest = b->rest_mm_s;
  } else {
    entry = pl.prev_exit;
    double cp = pl.prev_cap, cn = block_cap(b);
    double pair = b->stop_before == PLAN_STOP_DWELL ? dmin(pl.prev_rest, b->rest_mm_s)
                                                    : dmax(pl.prev_rest, b->rest_mm_s);
    entry_rest = dmin(pair, dmin(cp, cn));
  }
  double vb = jrest[e];
  if (e < cnt)   /* the block past the window may have to stop within itself */
    vb = dmin(vb, reach(dmin(win[e]->rest_mm_s, vb), win[e]->length_mm, slope_down(win[e]), pl.law));
  /* a block runs no slower than its floor (its rest speed): below it the
     speed changes at once, so a block only has to slow down to its floor and
     the junction takes the rest (labkit.motion._planner.windowed_passes) */
  for (uint32_t j = e - 1; j >= 1 && j < e; j--)
    vb = dmin(jcap[j], reach(dmax(vb, block_floor(win[j])), win[j]->length_mm, slope_down(win[j]), pl.law));
  double exitv = dmin(vb, reach(dmax(entry, block_floor(b)), b->length_mm, slope_up(b), pl.law));
  b->junction_exit_mm_s = exitv;   /* the next block's entry */

  if (pl.mode == PLAN_MODE_JUNCTION) {
    if (entry <= entry_rest * (1 + 1e-12)) pl.run_id++;
    b->super_block = pl.run_id;
  } else {
    b->super_block = b->group;
  }
  entry = dmax(entry, block_floor(b));   /* the profile: from and to the floor at least */
  exitv = dmax(exitv, block_floor(b));
  /* profile peak (profile.block_profiles) */
  double vc = block_cap(b), L = b->length_mm, a = slope_up(b), d = slope_down(b), v_meet;
  if (pl.law == PLAN_LAW_LINEAR) {
    double s = (exitv - entry + d * L) / (a + d);
    v_meet = entry + a * s;
  } else {
    double s = (exitv * exitv - entry * entry + 2.0 * d * L) / (2.0 * (a + d));
    v_meet = sqrt(dmax(entry * entry + 2.0 * a * s, 0.0));
  }
  b->entry_mm_s = entry;
  b->exit_mm_s = exitv;
  b->peak_mm_s = dmin(vc, dmax(v_meet, dmax(entry, exitv)));
  b->plan_cap_mm_s = vc;
  set_step_program(b);
  pl.current_planned = 1;
  return b;
}

void plan_discard_current_block(void)
{
  if (pl.count == 0) return;
  plan_block_t *b = slot(0);
  if (b->kind != PLAN_BLOCK_DWELL && pl.current_planned) {
    pl.prev_exit = b->junction_exit_mm_s;
    pl.prev_rest = b->rest_mm_s;
    pl.prev_cap = b->plan_cap_mm_s;
  }
  pl.tail = (uint8_t)((pl.tail + 1) % PLAN_BUFFER_SIZE);
  pl.count--;
  pl.current_planned = 0;
}

void plan_set_overrides(uint8_t feed_percent, uint8_t rapid_percent)
{
  feed_percent = feed_percent < 10 ? 10 : feed_percent > 200 ? 200 : feed_percent;
  rapid_percent = rapid_percent >= 100 ? 100 : rapid_percent >= 50 ? 50 : 25;
  if (feed_percent == pl.ovr_feed && rapid_percent == pl.ovr_rapid) return;
  pl.ovr_feed = feed_percent;
  pl.ovr_rapid = rapid_percent;
  uint32_t first = pl.current_planned ? 1u : 0u;   /* the block in motion keeps its plan */
  for (uint32_t i = first; i < pl.count; i++) {
    plan_block_t *o = slot(i);
    if (o->kind != PLAN_BLOCK_DWELL) apply_overrides(o);
  }
  /* fast MBLA: each super block's top from its members in the buffer */
  for (uint32_t i = first; i < pl.count; i++) {
    plan_block_t *o = slot(i);
    if (o->kind == PLAN_BLOCK_DWELL) continue;
    double top = 0.0;
    for (uint32_t j = first; j < pl.count; j++) {
      plan_block_t *q = slot(j);
      if (q->kind != PLAN_BLOCK_DWELL && q->group == o->group) top = dmax(top, q->cap_mm_s);
    }
    o->plan_cap_mm_s = top;
    if (o->group == pl.group_id) pl.group_top = top;
  }
}

void plan_get_overrides(uint8_t *feed_percent, uint8_t *rapid_percent)
{
  *feed_percent = pl.ovr_feed;
  *rapid_percent = pl.ovr_rapid;
}
