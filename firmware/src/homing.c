/*
  homing.c - the homing cycle (see homing.h). Written from GRBL 1.1h's
  documented behaviour and the transcripts recorded from it
  (tests/vectors/grbl/homing*.json).
*/
#include "homing.h"

#include <math.h>
#include <string.h>

#include "hal.h"
#include "limits.h"
#include "planner.h"
#include "protocol.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "status_codes.h"
#include "stepper.h"

#define SEARCH_SCALE 1.5   /* the first search covers 1.5 x the longest travel of the group */
#define LOCATE_SCALE 10.0  /* the slow search covers 10 x the pull-off */

/* A move that makes no step for this long (or this many passes, for a hal whose clock stands
   still) is a stalled machine or a hal without a step timer: the cycle fails (ALARM:9) rather
   than wait for ever. Legitimate homing rates step every few ms. */
#define STALL_MS 2000u
#define STALL_PASSES 20000000u
/* Passes per millisecond of debounce after which a clock that stands still is not waited for. */
#define SETTLE_PASSES_PER_MS 100000u

/* GRBL's default groups: Z, then X and Y together. */
static const uint8_t groups[] = {HAL_AXIS_Z, HAL_AXIS_X | HAL_AXIS_Y};

static uint8_t reset_asked(void) { return (serial_rt_flags & RT_RESET) != 0; }

/* +1 when axis a meets its switch moving towards +, else -1 ($23). */
static double switch_side(int a) { return (settings.homing_dir & (1u << a)) ? -1.0 : 1.0; }

/* Wait ms milliseconds, the hal polled meanwhile. 0 when a reset came. */
static uint8_t settle(uint32_t ms)
{
  uint32_t t0 = hal_millis(), passes = 0;
  while ((uint32_t)(hal_millis() - t0) < ms && passes++ / SETTLE_PASSES_PER_MS < ms) {
    hal_poll();
    if (reset_asked()) return 0;
  }
  return 1;
}

/* Plan one straight move of the axes in mask to the phase targets, beam off. */
static uint8_t start_move(uint8_t mask, const double target_mm[3], double rate_mm_min)
{
  int32_t steps[3];
  const lk_machine_t *m = plan_machine();
  plan_move_t mv;
  plan_block_t b;
  memset(&mv, 0, sizeof mv);
  st_get_position(steps);
  plan_sync_position(steps);
  mv.kind = PLAN_MOVE_LINE;
  for (int a = 0; a < 3; a++) {
    mv.start_mm[a] = (double)steps[a] / m->steps_per_mm[a];
    mv.end_mm[a] = (mask & (1u << a)) ? target_mm[a] : mv.start_mm[a];
  }
  mv.feed_mm_min = rate_mm_min;
  if (plan_prepare_move(&mv, &b) != STATUS_OK || b.ticks == 0) return 0;
  plan_push_block(&b);
  plan_flush();
  return 1;
}

/* One phase for the axes in mask: their positions restart at 0 and each
   moves dist_mm (towards its switch when seek, else away from it) at
   rate_mm_min per axis. A seeking axis stops at its switch. Returns 0, 6 (a
   reset) or, for a search, 9 when an axis never met its switch. */
static uint8_t phase(uint8_t mask, double dist_mm, double rate_mm_min, uint8_t seek)
{
  int32_t steps[3];
  double target[3];
  uint8_t moving = mask;
  st_get_position(steps);
  for (int a = 0; a < 3; a++) {
    if (mask & (1u << a)) steps[a] = 0;
    target[a] = (seek ? 1.0 : -1.0) * switch_side(a) * dist_mm;
  }
  st_set_position(steps);
  while (moving) {
    uint8_t n = 0;
    for (int a = 0; a < 3; a++) n += (moving >> a) & 1u;
    /* GRBL moves every axis of the group at the homing rate: the path's rate grows with sqrt(n) */
    if (!start_move(moving, target, rate_mm_min * sqrt((double)n))) break;
    int32_t last[3];
    uint32_t last_ms = hal_millis(), passes = 0;
    st_get_position(last);
    for (;;) {
      hal_poll();
      st_prep_buffer();
      st_get_position(steps);
      if (memcmp(steps, last, sizeof last)) {
        memcpy(last, steps, sizeof last);
        last_ms = hal_millis();
        passes = 0;
      } else if ((uint32_t)(hal_millis() - last_ms) > STALL_MS || ++passes > STALL_PASSES) {
        st_reset();
        return ALARM_HOMING_FAIL_APPROACH;
      }
      if (reset_asked()) {
        st_reset();
        return ALARM_HOMING_FAIL_RESET;
      }
      uint8_t hit = seek ? (uint8_t)(limits_pressed() & moving) : 0;
      if (hit) {
        st_reset();               /* stop; the others go on in a new move */
        moving &= (uint8_t)~hit;
        break;
      }
      if (st_is_idle() && plan_is_empty()) {
        if (seek) return ALARM_HOMING_FAIL_APPROACH;
        moving = 0;
        break;
      }
    }
  }
  st_reset();
  if (!settle(settings.homing_debounce_ms)) return ALARM_HOMING_FAIL_RESET;
  if (!seek && (limits_pressed() & mask)) return ALARM_HOMING_FAIL_PULLOFF;
  return HOMING_OK;
}

uint8_t homing_cycle(void)
{
  const lk_machine_t *m = plan_machine();
  for (unsigned g = 0; g < sizeof groups; g++) {
    uint8_t mask = groups[g];
    double search = 0.0;
    for (int a = 0; a < 3; a++)
      if ((mask & (1u << a)) && SEARCH_SCALE * m->travel_mm[a] > search)
        search = SEARCH_SCALE * m->travel_mm[a];
    double pulloff = settings.homing_pulloff;
    uint8_t st = phase(mask, search, settings.homing_seek, 1);
    if (st == HOMING_OK) st = phase(mask, pulloff, settings.homing_seek, 0);
    if (st == HOMING_OK) st = phase(mask, LOCATE_SCALE * pulloff, settings.homing_feed, 1);
    if (st == HOMING_OK) st = phase(mask, pulloff, settings.homing_seek, 0);
    if (st != HOMING_OK) return st;
    /* homed: 0 is the switch end of the travel, the axis one pull-off inside it */
    int32_t steps[3];
    st_get_position(steps);
    for (int a = 0; a < 3; a++) {
      if (!(mask & (1u << a))) continue;
      double mm = switch_side(a) > 0 ? -pulloff : -m->travel_mm[a] + pulloff;
      steps[a] = (int32_t)lround(mm * m->steps_per_mm[a]);
    }
    st_set_position(steps);
  }
  int32_t steps[3];
  st_get_position(steps);
  plan_sync_position(steps);
  return HOMING_OK;
}
