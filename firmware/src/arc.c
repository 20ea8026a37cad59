/*
  arc.c - the octant walk of an arc (see arc.h).
*/
#include "arc.h"

#include <math.h>
#include <string.h>

#include "config.h"

#define LK_PI 3.141592653589793

/* the kept walks: 4 bits a tick, head and tail count ticks (mod 2^32) */
static struct {
  uint8_t codes[ARC_KEEP_TICKS / 2];
  uint32_t head, tail, epoch, count;
} keep;


/* per CCW octant: driver axis, driver direction, driven axis, driven direction */
static const int8_t arc_octant_moves[8][4] = {
  {1, +1, 0, -1}, {0, -1, 1, +1}, {0, -1, 1, -1}, {1, -1, 0, -1},
  {1, -1, 0, +1}, {0, +1, 1, -1}, {0, +1, 1, +1}, {1, +1, 0, +1},
};

static int arc_octant(int64_t X, int64_t Y)
{
  if (Y >= 0 && X > 0 && Y < X) return 0;
  if (Y > 0 && X > 0 && X <= Y) return 1;
  if (Y > 0 && X <= 0 && -X < Y) return 2;
  if (Y > 0 && X < 0) return 3;
  if (Y <= 0 && X < 0 && -Y < -X) return 4;
  if (Y < 0 && X < 0) return 5;
  if (Y < 0 && X >= 0 && X < -Y) return 6;
  return 7;
}

/* |X² + Y² − r2| in int64, saturated. Near the circle the set-up keeps it exact
 * (LK_ARC_MAX_FIXED_RADIUS); a lattice point far off it (an arc whose start lies far
 * from its circle) must not overflow: the squares are summed unsigned (each ≤ 2⁶³ when
 * |X|, |Y| ≤ 3037000499) and a larger error saturates at INT64_MAX. */
static int64_t arc_err_abs(int64_t X, int64_t Y, int64_t r2)
{
  const int64_t lim = 3037000499LL;                   /* floor(sqrt(2^63)) */
  if (X > lim || X < -lim || Y > lim || Y < -lim) return INT64_MAX;
  uint64_t sum = (uint64_t)(X * X) + (uint64_t)(Y * Y);
  uint64_t r = (uint64_t)r2;
  uint64_t e = sum >= r ? sum - r : r - sum;
  return e > (uint64_t)INT64_MAX ? INT64_MAX : (int64_t)e;
}

static int64_t arc_fixed_round(double value, int64_t scale)
{
  double v = value * (double)scale;
  return v >= 0 ? (int64_t)floor(v + 0.5) : -(int64_t)floor(-v + 0.5);
}

static void arc_start_tail(arc_walk_t *a)
{
  int32_t dx = a->ex - a->x, dy = a->ey - a->y;
  a->t_dx = dx < 0 ? -dx : dx;
  a->t_dy = dy < 0 ? -dy : dy;
  a->t_sx = a->ex > a->x ? 1 : -1;
  a->t_sy = a->ey > a->y ? 1 : -1;
  a->t_n = a->t_dx > a->t_dy ? a->t_dx : a->t_dy;
  a->t_errx = 2 * a->t_dx - a->t_n;
  a->t_erry = 2 * a->t_dy - a->t_n;
  a->t_k = 0;
  a->phase = 1;
}

static void arc_emit(const arc_walk_t *a, int32_t *x, int32_t *y)
{
  *x = a->x;
  *y = a->mirror ? -a->y : a->y;
}

int arc_next(arc_walk_t *a, int32_t *px, int32_t *py)
{
  if (a->phase == 0) {
    const int8_t *mv = arc_octant_moves[(int)a->octant];
    int tail = 0;
    if (a->crossed > a->n_cross) {
      tail = 1;
    } else if (a->crossed == a->n_cross) {
      int32_t e_end = mv[0] == 0 ? a->ex : a->ey;
      int32_t p_now = mv[0] == 0 ? a->x : a->y;
      if (mv[1] * (int64_t)(p_now - e_end) >= 0) tail = 1;
    }
    if (!tail) {
      if (a->n > a->max_ticks) return -1;
      const int64_t q = a->q;
      int64_t X = q * a->x - a->cxq, Y = q * a->y - a->cyq;
      int32_t x = a->x, y = a->y;
      if (a->n == 1) {
        int bx = 0, by = 0;
        int64_t e_best = -1;
        for (int dx = -1; dx <= 1; dx++) {
          for (int dy = -1; dy <= 1; dy++) {
            if ((dx == 0 && dy == 0) || X * dy - Y * dx < 0) continue;
            int64_t e = arc_err_abs(X + q * dx, Y + q * dy, a->r2);
            if (e_best < 0 || e < e_best) {
              e_best = e;
              bx = dx;
              by = dy;
            }
          }
        }
        x += bx;
        y += by;
      } else {
        if (mv[0] == 0) {
          X += q * mv[1];
          x += mv[1];
        } else {
          Y += q * mv[1];
          y += mv[1];
        }
        int64_t step = q * mv[3], e_stay, e_fwd, e_back;
        e_stay = arc_err_abs(X, Y, a->r2);
        if (mv[2] == 0) {
          e_fwd = arc_err_abs(X + step, Y, a->r2);
          e_back = arc_err_abs(X - step, Y, a->r2);
        } else {
          e_fwd = arc_err_abs(X, Y + step, a->r2);
          e_back = arc_err_abs(X, Y - step, a->r2);
        }
        int best = 0;
        int64_t e_best = e_stay;
        if (e_fwd < e_best) {
          best = 1;
          e_best = e_fwd;
        }
        if (e_back < e_best) best = -1;
        if (mv[2] == 0)
          x += best * mv[3];
        else
          y += best * mv[3];
      }
      int o_new = arc_octant(q * x - a->cxq, q * y - a->cyq);
      if (a->crossed == a->n_cross && o_new != a->octant) {
        tail = 1;   /* the end lies in this octant: stay on the previous point */
      } else {
        int32_t c_new = a->crossed;
        if (o_new == (a->octant + 1) % 8) c_new++;
        if (c_new == a->n_cross) {
          const int8_t *mvn = arc_octant_moves[o_new];
          int32_t p_new = mvn[0] == 0 ? x : y;
          int32_t e_end = mvn[0] == 0 ? a->ex : a->ey;
          int32_t ddx = a->ex - a->x, ddy = a->ey - a->y;
          if (mvn[1] * (int64_t)(p_new - e_end) >= 0 && ddx <= 1 && ddx >= -1 && ddy <= 1 &&
              ddy >= -1) {
            x = a->ex;
            y = a->ey;
            o_new = arc_octant(q * x - a->cxq, q * y - a->cyq);
          }
        }
        a->x = x;
        a->y = y;
        a->n++;
        if (o_new != a->octant) {
          if (o_new == (a->octant + 1) % 8)
            a->crossed++;
          else if (o_new == (a->octant + 7) % 8)
            a->crossed--;
          else
            return -1;
          a->octant = (int8_t)o_new;
        }
        arc_emit(a, px, py);
        return 1;
      }
    }
    arc_start_tail(a);
  }
  if (a->phase == 1) {
    /* the tail is a short straight piece to the end point; a long one means the walk
       never met the end (a start off the arc's circle): fail instead of walking it */
    if (a->t_k == 0 && a->max_ticks > 0 && (int64_t)a->n + a->t_n > (int64_t)a->max_ticks) return -1;
    if (a->t_k >= a->t_n) {
      a->phase = 2;
      return 0;
    }
    if (a->t_errx >= 0) {
      a->x += a->t_sx;
      a->t_errx -= 2 * a->t_n;
    }
    a->t_errx += 2 * a->t_dx;
    if (a->t_erry >= 0) {
      a->y += a->t_sy;
      a->t_erry -= 2 * a->t_n;
    }
    a->t_erry += 2 * a->t_dy;
    a->t_k++;
    arc_emit(a, px, py);
    return 1;
  }
  return 0;
}

/* Set up the walk of labkit.motion.bresenham.arc_lattice_points: start s, end e
   (lattice), centre c and radius r in steps, signed sweep. 0 ok, -1 when the
   arc is beyond the exact integer walk. */
int arc_init(arc_walk_t *a, const int32_t s[2], const int32_t e[2], const double c_in[2],
             int clockwise, double r, double sweep)
{
  memset(a, 0, sizeof *a);
  a->x = s[0];
  a->y = s[1];
  a->ex = e[0];
  a->ey = e[1];
  a->n = 1;
  if (r < LK_ARC_MIN_RADIUS_STEPS) {   /* a straight line to the end */
    arc_start_tail(a);
    return 0;
  }
  int64_t scale = LK_ARC_SCALE;
  if ((r + 4) * (double)scale > LK_ARC_MAX_FIXED_RADIUS) {
    scale = (int64_t)floor(LK_ARC_MAX_FIXED_RADIUS / (r + 4));
    if (scale < 1) return -1;
  }
  double c0 = c_in[0], c1 = c_in[1];
  if (clockwise) {   /* walk the mirror image y -> -y counter-clockwise */
    a->mirror = 1;
    a->y = -s[1];
    a->ey = -e[1];
    c1 = -c1;
    sweep = -sweep;
  }
  const int64_t q = scale;
  a->q = q;
  a->cxq = arc_fixed_round(c0, q);
  a->cyq = arc_fixed_round(c1, q);
  int64_t rq = arc_fixed_round(r, q);
  a->r2 = rq * rq;
  int o_s = arc_octant(q * a->x - a->cxq, q * a->y - a->cyq);
  int o_e = arc_octant(q * a->ex - a->cxq, q * a->ey - a->cyq);
  if (!(sweep > 0)) return -1;
  int base = ((o_e - o_s) % 8 + 8) % 8;
  double turns = (sweep / (LK_PI / 4) - base) / 8;
  a->n_cross = base + 8 * (int32_t)nearbyint(turns);
  double full = ceil(sweep / (2 * LK_PI));
  double lim1 = 8 * (r + 2) * (full > 1 ? full : 1);
  double lim2 = 1.05 * r * sweep + 8 * ((a->n_cross < 0 ? -a->n_cross : a->n_cross) + 3);
  double lim = lim1 < lim2 ? lim1 : lim2;
  if (lim > 2.0e9) return -1;
  if (lim > (double)LK_ARC_MAX_TICKS) return -1;   /* too long to count in the main loop */
  a->max_ticks = (int32_t)lim + 16;
  a->octant = (int8_t)o_s;
  if (rq < 2 * q) return -1;
  return 0;
}

double arc_sweep_angle(double p0x, double p0y, double p1x, double p1y, double cx, double cy,
                       int clockwise)
{
  double r0x = p0x - cx, r0y = p0y - cy, r1x = p1x - cx, r1y = p1y - cy;
  double ang = atan2(r0x * r1y - r0y * r1x, r0x * r1x + r0y * r1y);
  if (clockwise && ang >= -5e-7) ang -= 2.0 * LK_PI;
  if (!clockwise && ang <= 5e-7) ang += 2.0 * LK_PI;
  return ang;
}


/* ------------------------------------------------------------------ kept walks */

static void keep_put(uint32_t i, uint8_t code)
{
  uint8_t *c = &keep.codes[(i % ARC_KEEP_TICKS) / 2];
  *c = (i & 1u) ? (uint8_t)((*c & 0x0Fu) | (code << 4)) : (uint8_t)((*c & 0xF0u) | code);
}

int arc_count(const arc_walk_t *start, int32_t x0, int32_t y0, uint32_t *ticks, arc_kept_t *kept,
              void (*idle)(void))
{
  arc_walk_t walk = *start;
  int32_t x, y, px = x0, py = y0;
  uint32_t n = 0;
  int st, fits = 1;
  kept->at = keep.head;
  kept->epoch = keep.epoch;
  kept->count = ++keep.count;
  while ((st = arc_next(&walk, &x, &y)) == 1) {
    if (fits && n + (keep.head - keep.tail) >= ARC_KEEP_TICKS) fits = 0;
    if (fits) {
      uint8_t code = 0;
      if (x != px) code |= x < px ? ARC_STEP_A0 | ARC_NEG_A0 : ARC_STEP_A0;
      if (y != py) code |= y < py ? ARC_STEP_A1 | ARC_NEG_A1 : ARC_STEP_A1;
      keep_put(keep.head + n, code);
    }
    px = x;
    py = y;
    if ((++n & 4095u) == 0 && idle) idle();
  }
  *ticks = n;
  kept->len = fits ? n : 0;
  return st < 0 ? -1 : 0;
}

void arc_keep_commit(arc_kept_t *kept)
{
  if (kept->len == 0) return;
  if (kept->epoch != keep.epoch || kept->count != keep.count || kept->at != keep.head) {
    kept->len = 0;
    return;
  }
  keep.head += kept->len;
}

uint8_t arc_kept_step(const arc_kept_t *kept, uint32_t k)
{
  uint32_t i = kept->at + k;
  uint8_t c = keep.codes[(i % ARC_KEEP_TICKS) / 2];
  return (uint8_t)((i & 1u) ? c >> 4 : c & 0x0Fu);
}

void arc_keep_release(const arc_kept_t *kept)
{
  if (kept->len && kept->epoch == keep.epoch) keep.tail = kept->at + kept->len;
}

void arc_keep_reset(void)
{
  keep.head = keep.tail = 0;
  keep.epoch++;
}
