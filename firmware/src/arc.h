/*
  arc.h - the octant walk of an arc on the step lattice
  (labkit.motion.bresenham.arc_lattice_points, operation by operation).

  The walk visits 8-connected lattice points from the start to the end: in
  each octant one axis (the driver) moves one step a tick and the other stays
  or moves, whichever point lies nearest the circle (|X^2 + Y^2 - r^2| in
  fixed point, LK_ARC_SCALE sub-steps a step); the first point is the nearest
  of the eight neighbours, and the last piece is a straight line to the end.
  A clockwise arc is walked as its mirror image y -> -y.

  The planner walks an arc once to count its ticks (arc_count, in
  plan_prepare_move) and keeps each tick's in-plane step (4 bits) in a ring
  of ARC_KEEP_TICKS, from which st_prep_buffer() takes them; an arc that
  does not fit in what the ring has free is walked a second time by the
  stepper from its start (arc_next), both in the main loop. Integer
  arithmetic only after arc_init.
*/
#ifndef LK_ARC_H
#define LK_ARC_H

#include <stdint.h>

/* The walk's state; a copy made after arc_init walks the same points. */
typedef struct {
  int64_t cxq, cyq, r2, q;           /* centre and radius^2 in fixed point, scale */
  int32_t x, y, ex, ey;              /* point now, end (mirrored when clockwise) */
  int32_t n, max_ticks;              /* points so far, bound before failing */
  int32_t crossed, n_cross;          /* octant boundaries crossed so far, to cross */
  int8_t octant, phase, mirror;      /* phase 0 octants, 1 the straight tail, 2 done */
  int32_t t_n, t_k, t_dx, t_dy, t_errx, t_erry;   /* the tail's Bresenham */
  int8_t t_sx, t_sy;
} arc_walk_t;

/* Set up the walk from lattice start s to lattice end e (steps) around
   centre c (steps, any real) with radius r (steps) and signed sweep
   (radians, counter-clockwise > 0). Returns 0, or -1 when the arc is beyond
   the exact integer walk or longer than LK_ARC_MAX_TICKS. */
int arc_init(arc_walk_t *a, const int32_t s[2], const int32_t e[2], const double c[2],
             int clockwise, double r, double sweep);

/* Next lattice point into *x, *y (steps): 1; the end of the walk: 0; the walk
   failed to close (a start off the circle): -1. */
int arc_next(arc_walk_t *a, int32_t *x, int32_t *y);

/* Ticks of counted arcs whose steps the ring keeps (4 bits a tick); an arc
   that does not fit in its free part is walked again by the stepper. */
#ifndef ARC_KEEP_TICKS
#define ARC_KEEP_TICKS 32768u   /* power of two; 16 KB */
#endif

/* Where a counted walk's steps are kept: ticks [at, at + len) of the ring
   (len 0: not kept, walk again); the ring's epoch (reset) and the count's
   number, which the commit checks. */
typedef struct {
  uint32_t at, len, epoch, count;
} arc_kept_t;

/* In-plane step of a kept tick: bit 0 first axis steps, 1 it steps
   negative, 2 second axis steps, 3 it steps negative. */
#define ARC_STEP_A0  0x1u
#define ARC_NEG_A0   0x2u
#define ARC_STEP_A1  0x4u
#define ARC_NEG_A1   0x8u

/* Walk *start (not changed) to its end from lattice point (x0, y0): its
   ticks into *ticks, its steps kept in the ring's free space when they fit
   (*kept; committed only by arc_keep_commit). idle() is called every 4096
   ticks (a long arc: the motors keep being fed). 0, or -1 when the walk
   fails to close. */
int arc_count(const arc_walk_t *start, int32_t x0, int32_t y0, uint32_t *ticks, arc_kept_t *kept,
              void (*idle)(void));
/* The block of *kept is queued: its steps stay until released. Clears
   kept->len when another count or a reset came since its count. */
void arc_keep_commit(arc_kept_t *kept);
/* Step code (ARC_STEP_A0 ...) of tick k of a committed walk. */
uint8_t arc_kept_step(const arc_kept_t *kept, uint32_t k);
/* The stepper is done with *kept: its ticks are free again. */
void arc_keep_release(const arc_kept_t *kept);
/* Empty the ring (planner reset): every kept walk is void. */
void arc_keep_reset(void);

/* Signed sweep (radians) from p0 to p1 around c, a full turn when they meet
   (labkit.geometry.circle.sweep_angle). Any unit of length. */
double arc_sweep_angle(double p0x, double p0y, double p1x, double p1y, double cx, double cy,
                       int clockwise);

#endif /* LK_ARC_H */
