/*
  arc.h - the octant walk of an arc on the step lattice
  (labkit.motion.bresenham.arc_lattice_points, operation by operation).

  The walk visits 8-connected lattice points from the start to the end: in
  each octant one axis (the driver) moves one step a tick and the other stays
  or moves, whichever point lies nearest the circle (|X^2 + Y^2 - r^2| in
  fixed point, LK_ARC_SCALE sub-steps a step); the first point is the nearest
  of the eight neighbours, and the last piece is a straight line to the end.
  A clockwise arc is walked as its mirror image y -> -y.

  Used twice, both in the main loop: the planner counts a block's ticks with
  it (plan_prepare_move) and st_prep_buffer() walks it again for the step
  bits. Integer arithmetic only after arc_init.
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

/* Signed sweep (radians) from p0 to p1 around c, a full turn when they meet
   (labkit.geometry.circle.sweep_angle). Any unit of length. */
double arc_sweep_angle(double p0x, double p0y, double p1x, double p1y, double cx, double cy,
                       int clockwise);

#endif /* LK_ARC_H */
