/*
  planner.h - block buffer and look-ahead of the labkit firmware.

  Moves from the parser become blocks (plan_prepare_move + plan_push_block):
  start and end in steps (llround of mm x steps/mm, chained), ticks, length,
  directions, speed cap, acceleration, rest speed, laser power - the
  conventions of labkit.motion.blocks. Blocks wait in a ring buffer.

  The stepper takes the oldest block with plan_get_current_block(); only then
  is its exit speed fixed, by the look-ahead chosen at run time:
    PLAN_MODE_JUNCTION  GRBL's junction deviation, backward pass over the
                        buffer window and forward pass (labkit.motion.planner)
    PLAN_MODE_FAST / NORMAL / HQ   [CBR40]'s multi-block look-ahead: super
                        blocks planned from rest to rest.
  and the ramp law PLAN_LAW_LINEAR (Hz per step) or PLAN_LAW_ACCEL (mm/s^2).
  Planning block k needs blocks k .. k + depth in the buffer, or the end of
  the stream (plan_flush()); fast MBLA also needs the super block of block
  k + depth complete (its top speed is every member's cap), as far as the
  buffer holds it. Speeds are doubles: the planner runs in the main
  loop, never in the step interrupt.

  The block also carries its integer step-rate program (f_entry, f_peak,
  f_exit, f_min, up, down, f_feed: labkit.motion.timer.step_blocks) which the
  stepper turns into ticks.
*/
#ifndef LK_PLANNER_H
#define LK_PLANNER_H

#include <stdint.h>
#include "arc.h"
#include "config.h"
#include "machine.h"

#define PLAN_MODE_JUNCTION 0
#define PLAN_MODE_FAST     1
#define PLAN_MODE_NORMAL   2
#define PLAN_MODE_HQ       3

#define PLAN_LAW_LINEAR 0
#define PLAN_LAW_ACCEL  1

/* Move kinds given to plan_prepare_move (labkit.toolpath.MoveKind order). */
#define PLAN_MOVE_RAPID   0
#define PLAN_MOVE_LINE    1
#define PLAN_MOVE_ARC_CW  2
#define PLAN_MOVE_ARC_CCW 3

/* Block kinds. */
#define PLAN_BLOCK_LINE  1
#define PLAN_BLOCK_ARC   2
#define PLAN_BLOCK_DWELL 4

/* stop_before values */
#define PLAN_STOP_NONE  0
#define PLAN_STOP_DWELL 1   /* a dwell between this block and the previous motion */
#define PLAN_STOP_START 2   /* first block of a new stream (after a flush or reset) */

typedef struct {
  uint8_t kind;          /* PLAN_MOVE_* */
  uint8_t plane;         /* 0 XY, 1 ZX, 2 YZ */
  uint8_t laser;         /* 0, 3, 4: already 0 when the beam does not burn */
  double start_mm[3], end_mm[3], centre_mm[3];
  double feed_mm_min;    /* programmed feed (ignored for rapids) */
  double power_mw;       /* programmed power (0 when the beam does not burn) */
  uint32_t line;
} plan_move_t;

typedef struct {
  uint8_t kind;                  /* PLAN_BLOCK_* */
  uint8_t rapid;
  uint8_t laser;                 /* 0 3 4 */
  uint8_t stop_before;           /* PLAN_STOP_* */
  uint8_t plane;
  uint8_t dir_bits;              /* net direction: bit i when axis i moves negative */
  uint32_t line;
  int32_t start_steps[3], end_steps[3];
  uint32_t ticks;
  double length_mm;
  double unit_in[3], unit_out[3];
  double prog_feed_mm_s;         /* as programmed; inf for rapids */
  double feed_mm_s;              /* after the feed override; inf for rapids */
  double limit_mm_s, cap_mm_s, accel_mm_s2, rest_mm_s;
  double power_mw;
  double dwell_s;
  int32_t group;                 /* MBLA super block id (set when buffered) */
  arc_walk_t arc;                /* the arc walk at its start (arcs) */
  arc_kept_t kept;               /* its steps as counted, when the ring kept them (arcs) */
  /* set by plan_get_current_block(): */
  double entry_mm_s, peak_mm_s, exit_mm_s, plan_cap_mm_s;   /* the profile (no slower than the floor) */
  double junction_exit_mm_s;     /* planned speed at the end junction: the next block's entry */
  int32_t super_block;
  uint32_t f_entry, f_peak, f_exit, f_min, up, down, f_feed;
  uint64_t dwell_cycles;
} plan_block_t;

void plan_init(void);                        /* defaults machine, empty buffer, position 0 */
lk_machine_t *plan_machine(void);            /* live settings */
uint8_t plan_apply_machine(void);            /* check after changing *plan_machine() */
void plan_reset(void);                       /* drop every block (position kept) */

void plan_set_mode(uint8_t mode);            /* PLAN_MODE_*; the law follows the mode */
uint8_t plan_get_mode(void);
void plan_set_law(uint8_t law);              /* PLAN_LAW_* (after plan_set_mode) */
uint8_t plan_get_law(void);
void plan_set_depth(uint32_t blocks);        /* 1 .. PLAN_MAX_DEPTH */
uint32_t plan_get_depth(void);

/* Parser side. plan_prepare_move computes the block of a move into *out
   (returns STATUS_OK, or STATUS_INVALID_ARC for an arc the machine cannot
   walk, STATUS_VALUE_OUT_OF_RANGE for a position beyond the step counters).
   out->ticks == 0 means the move makes no block (it still moves the
   planner position when pushed). */
uint8_t plan_prepare_move(const plan_move_t *mv, plan_block_t *out);
void plan_push_block(const plan_block_t *b);     /* needs !plan_is_full() */
void plan_push_dwell(double seconds, uint32_t line);
void plan_flush(void);                       /* end of stream: the last block stops */
uint8_t plan_is_full(void);
uint8_t plan_is_empty(void);
uint8_t plan_free_slots(void);
void plan_get_position(int32_t steps[3]);    /* where the last pushed move ends */
void plan_sync_position(const int32_t steps[3]);

/* Feed and rapid overrides (GRBL 1.1's 0x90..0x97), in percent: feed
   10 .. 200, rapid 25, 50 or 100. They set the speed cap of every block not
   yet taken by the stepper and of every block pushed later: the change shows
   from the next block on, planned with the new caps (GRBL re-plans the block
   in motion too; here it finishes at its planned speeds). In fast MBLA a
   super block's top is recomputed from its members still in the buffer.
   M4's power/speed ratio keeps the programmed feed, so the energy per
   millimetre stays what the job asked for. 100 / 100 (the default, and
   after plan_init) leaves every block as labkit.motion plans it. */
void plan_set_overrides(uint8_t feed_percent, uint8_t rapid_percent);
void plan_get_overrides(uint8_t *feed_percent, uint8_t *rapid_percent);

/* Stepper side. */
plan_block_t *plan_get_current_block(void);  /* NULL when none can be planned yet */
void plan_discard_current_block(void);

/* Helpers shared with the stepper and tests. */
int32_t plan_to_steps(double mm, double steps_per_mm);   /* llround, halves away from 0 */
uint32_t plan_isqrt(uint64_t x);
uint32_t plan_tick_rate(const plan_block_t *b, uint32_t k, uint8_t law);
uint32_t plan_timer_period(uint32_t f_hz);               /* ceil(clock/(f(pre+1))) - 1 */

#endif /* LK_PLANNER_H */
