/*
  test_planner.c - invariants of the planner and the stepper on random jobs,
  for every look-ahead mode, both ramp laws and several depths:

  - the exit speed of a block is the entry of the next one;
  - no planned speed exceeds the block's cap, none falls below its rest speed
    (linear law), entry <= peak >= exit;
  - a stream ends at rest (the last block exits at its rest speed) and every
    exit can still be brought down to rest by the end of the look-ahead window;
  - every tick runs between f_min and f_peak, the first at f_entry, the last
    at f_exit; each axis steps at most once per tick;
  - Bresenham: a line steps |delta| times on each axis and its driver every
    tick; every block's signed steps add up to end - start, and the stepper's
    position to the job's end;
  - more blocks than the ring buffer holds stream through; feed hold stops
    with the laser off, resume finishes the job; reset drops the job and keeps
    the position.

  usage: test_planner <repository root>
*/
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "core_test.h"
#include "gcode.h"
#include "hal_record.h"
#include "laser.h"
#include "planner.h"
#include "status_codes.h"
#include "stepper.h"

static const char *ctx = "";

static void fail_where(const char *file, int line) {
  printf("test_planner: FAIL (%s) %s:%d: ", ctx, file, line);
}

static uint32_t rng = 12345u;
static double urand(double lo, double hi)
{
  rng = rng * 1664525u + 1013904223u;
  return lo + (hi - lo) * (double)(rng >> 8) / 16777216.0;
}

static void reset(uint8_t mode, uint8_t law, uint32_t depth)
{
  hal_record_reset();
  plan_init();
  plan_set_mode(mode);
  plan_set_law(law);
  plan_set_depth(depth);
  hal_record_start_core(GC_DIALECT_LABKIT);
}

static uint8_t run(const char *text) { return hal_record_line(text); }

/* a random job: lines, rapids, arcs, dwells, power changes; returns its end in mm */
static void random_job(int n, int with_arcs, double end_mm[3], int pump_each_line)
{
  char line[200];
  double x = 0, y = 0, z = 0;
  run("M4 S200");
  for (int i = 0; i < n; i++) {
    double r = urand(0, 1);
    if (r < 0.05) {
      snprintf(line, sizeof line, "G4 P%.1f", urand(0, 3));
    } else if (r < 0.15) {
      x = round(urand(-2, 2) * 1e4) / 1e4;
      y = round(urand(-2, 2) * 1e4) / 1e4;
      snprintf(line, sizeof line, "G0 X%.4f Y%.4f", x, y);
    } else if (with_arcs && r < 0.35) {
      double rad = urand(0.01, 0.2), ang = urand(0, 6.283185307179586);
      double cx = x - rad * cos(ang), cy = y - rad * sin(ang), a2 = ang + urand(-6, 6);
      double ex = cx + rad * cos(a2), ey = cy + rad * sin(a2);
      snprintf(line, sizeof line, "G%d X%.6f Y%.6f I%.6f J%.6f F%.1f", urand(0, 1) < 0.5 ? 2 : 3, ex, ey,
               cx - x, cy - y, urand(1, 30));
      x = ex;
      y = ey;
      /* the printed end may be a little off; the parser's tolerance takes it */
    } else {
      x = round((x + urand(-0.3, 0.3)) * 1e4) / 1e4;
      y = round((y + urand(-0.3, 0.3)) * 1e4) / 1e4;
      if (urand(0, 1) < 0.3) z = round((z + urand(-0.05, 0.05)) * 1e4) / 1e4;
      snprintf(line, sizeof line, "G1 X%.4f Y%.4f Z%.4f F%.1f S%d", x, y, z, urand(0.5, 30),
               (int)urand(0, 256));
    }
    uint8_t st = run(line);
    CHECK(st == STATUS_OK, "line '%s' status %u", line, st);
    if (st == STATUS_OK && line[1] != '4') {
      x = gc_state()->pos_mm[0];
      y = gc_state()->pos_mm[1];
      z = gc_state()->pos_mm[2];
    }
    if (pump_each_line) hal_record_pump();
  }
  end_mm[0] = x;
  end_mm[1] = y;
  end_mm[2] = z;
}

static void finish(void)
{
  plan_flush();
  hal_record_pump();
}

static double cap_of(const st_block_info_t *b) { (void)b; return 0; }

/* the invariants over a recorded job */
static void check_job(uint8_t law, const double end_mm[3])
{
  const lk_machine_t *m = plan_machine();
  CHECK(plan_is_empty() && !rec.running, "job did not finish");
  CHECK(rec.double_pulses == 0 && rec.stray_pulses == 0, "%u double, %u stray pulses", rec.double_pulses,
        rec.stray_pulses);
  int32_t pos[3];
  st_get_position(pos);
  for (int a = 0; a < 3; a++)
    CHECK(pos[a] == plan_to_steps(end_mm[a], m->steps_per_mm[a]), "axis %d ends at %d steps, job at %d", a,
          pos[a], plan_to_steps(end_mm[a], m->steps_per_mm[a]));
  uint32_t ti = 0;
  const st_block_info_t *prev = NULL;
  for (uint32_t i = 0; i < rec.n_blocks; i++) {
    const st_block_info_t *b = &rec.blocks[i];
    int32_t sum[3] = {0, 0, 0}, abs_sum[3] = {0, 0, 0};
    uint32_t n = 0;
    uint32_t first = ti;
    while (ti < rec.n_ticks && rec.ticks[ti].seq == b->seq) {
      const rec_tick_t *t = &rec.ticks[ti];
      if (b->kind != PLAN_BLOCK_DWELL) {
        CHECK(t->rate >= b->f_min && t->rate <= (b->f_peak > b->f_min ? b->f_peak : b->f_min),
              "block %u tick %u rate %u outside [%u, %u]", i, n, t->rate, b->f_min, b->f_peak);
        CHECK(t->period == plan_timer_period(t->rate), "period");
      }
      for (int a = 0; a < 3; a++) {
        sum[a] += t->step[a];
        abs_sum[a] += abs(t->step[a]);
      }
      if (b->kind == PLAN_BLOCK_LINE) {
        int driver = 0;
        for (int a = 0; a < 3; a++)
          if (abs(b->end_steps[a] - b->start_steps[a]) == (int32_t)b->ticks && t->step[a] != 0) driver = 1;
        CHECK(driver, "block %u tick %u: the driver axis did not step", i, n);
      }
      n++;
      ti++;
    }
    if (b->kind == PLAN_BLOCK_DWELL) continue;
    CHECK(n == b->ticks, "block %u ran %u ticks of %u", i, n, b->ticks);
    if (n > 0) {
      uint32_t fe = b->f_entry > b->f_min ? b->f_entry : b->f_min;
      uint32_t fx = b->f_exit > b->f_min ? b->f_exit : b->f_min;
      /* the ramp may not reach f_entry (f_exit) when the other ramp is shorter: never above */
      CHECK(rec.ticks[first].rate <= fe, "block %u first tick %u > f_entry %u", i, rec.ticks[first].rate,
            b->f_entry);
      CHECK(rec.ticks[ti - 1].rate <= fx, "block %u last tick %u > f_exit %u", i, rec.ticks[ti - 1].rate,
            b->f_exit);
    }
    for (int a = 0; a < 3; a++) {
      CHECK(sum[a] == b->end_steps[a] - b->start_steps[a], "block %u axis %d: steps %d, delta %d", i, a, sum[a],
            b->end_steps[a] - b->start_steps[a]);
      if (b->kind == PLAN_BLOCK_LINE)
        CHECK(abs_sum[a] == abs(b->end_steps[a] - b->start_steps[a]), "line %u axis %d stepped back", i, a);
    }
    CHECK(b->entry_mm_s <= b->peak_mm_s * (1 + 1e-12) && b->exit_mm_s <= b->peak_mm_s * (1 + 1e-12),
          "block %u entry %g peak %g exit %g", i, b->entry_mm_s, b->peak_mm_s, b->exit_mm_s);
    if (law == PLAN_LAW_LINEAR) CHECK(b->entry_mm_s > 0 && b->exit_mm_s > 0, "block %u stops at 0 on a linear ramp", i);
    /* one planned junction speed; each block runs it no slower than its own floor (rest
       speed, f_min): the speed may change at a junction only below the larger floor */
    if (prev && prev->kind != PLAN_BLOCK_DWELL) {
      double fp = (prev->f_min + 1.0) * prev->length_mm / prev->ticks;   /* floor, one Hz up */
      double fb = (b->f_min + 1.0) * b->length_mm / b->ticks;
      double top = fp > fb ? fp : fb;
      CHECK(prev->exit_mm_s == b->entry_mm_s || (prev->exit_mm_s <= top && b->entry_mm_s <= top),
            "block %u enters at %.17g, the previous left at %.17g (floors %g, %g)", i, b->entry_mm_s,
            prev->exit_mm_s, fp, fb);
    }
    prev = b;
  }
  (void)cap_of;
}

/* speeds against the caps and rests, on planner blocks directly */
static void check_caps(uint8_t mode, uint8_t law, uint32_t depth)
{
  char line[200];
  reset(mode, law, depth);
  double x = 0, y = 0;
  for (int i = 0; i < 25; i++) {
    x = round((x + urand(-0.2, 0.2)) * 1e4) / 1e4;
    y = round((y + urand(-0.2, 0.2)) * 1e4) / 1e4;
    snprintf(line, sizeof line, "G1 X%.4f Y%.4f F%.2f", x, y, urand(0.5, 25));
    CHECK(run(line) == STATUS_OK, "%s", line);
  }
  plan_flush();
  double prev_exit = -1;
  int k = 0;
  plan_block_t *b;
  while ((b = plan_get_current_block()) != NULL) {
    double cap = b->plan_cap_mm_s;
    CHECK(b->peak_mm_s <= cap * (1 + 1e-9) && b->entry_mm_s <= cap * (1 + 1e-9) && b->exit_mm_s <= cap * (1 + 1e-9),
          "block %d above its cap %g: %g %g %g", k, cap, b->entry_mm_s, b->peak_mm_s, b->exit_mm_s);
    if (mode != PLAN_MODE_FAST)
      CHECK(cap <= b->cap_mm_s && cap <= b->limit_mm_s, "block %d cap %g above feed/limit", k, cap);
    else
      CHECK(cap <= b->limit_mm_s * (1 + 1e-12), "fast block %d above the machine limit", k);
    CHECK(b->entry_mm_s >= b->rest_mm_s * (1 - 1e-12) || law == PLAN_LAW_ACCEL || k > 0,
          "block %d starts below rest", k);
    if (prev_exit >= 0) CHECK(b->entry_mm_s == prev_exit, "block %d entry != previous exit", k);
    prev_exit = b->exit_mm_s;
    /* the exit can be brought down to the stream's end in what is left of the window */
    if (plan_free_slots() == PLAN_BUFFER_SIZE - 1) {
      CHECK(b->exit_mm_s <= b->rest_mm_s * (1 + 1e-12), "the last block exits at %g, rest %g", b->exit_mm_s,
            b->rest_mm_s);
    }
    plan_discard_current_block();
    k++;
  }
  CHECK(k == 25, "%d blocks planned of 25", k);
}

int main(int argc, char **argv)
{
  (void)argc;
  (void)argv;
  static const uint8_t modes[4] = {PLAN_MODE_JUNCTION, PLAN_MODE_FAST, PLAN_MODE_NORMAL, PLAN_MODE_HQ};
  static const char *mode_names[4] = {"junction", "fast", "normal", "hq"};
  static const uint32_t depths[4] = {1, 2, 5, 16};
  int jobs = 0;
  long ticks = 0;
  char name[80];
  for (int mi = 0; mi < 4; mi++) {
    for (int law = 0; law < 2; law++) {
      for (int di = 0; di < 4; di++) {
        for (int pump = 0; pump < 2; pump++) {
          double end[3];
          snprintf(name, sizeof name, "%s %s depth %u %s", mode_names[mi], law ? "accel" : "linear",
                   depths[di], pump ? "streamed" : "buffered");
          ctx = name;
          reset(modes[mi], (uint8_t)law, depths[di]);
          random_job(60, 1, end, pump);
          finish();
          check_job((uint8_t)law, end);
          ticks += rec.n_ticks;
          jobs++;
        }
        check_caps(modes[mi], (uint8_t)law, depths[di]);
      }
    }
  }

  /* more blocks than the ring holds, without pumping: the parser's wait runs the machine */
  ctx = "long job";
  {
    double end[3];
    reset(PLAN_MODE_JUNCTION, PLAN_LAW_ACCEL, 16);
    random_job(3 * PLAN_BUFFER_SIZE + 7, 0, end, 0);
    finish();
    check_job(PLAN_LAW_ACCEL, end);
    CHECK(rec.n_blocks > PLAN_BUFFER_SIZE, "only %u blocks", rec.n_blocks);
    ticks += rec.n_ticks;
    jobs++;
  }

  /* a ring full of dwells cannot hold the look-ahead window: the job still runs */
  ctx = "dwells fill the ring";
  {
    reset(PLAN_MODE_JUNCTION, PLAN_LAW_ACCEL, PLAN_MAX_DEPTH);
    char l[64];
    int ok = 1;
    for (int i = 1; i <= 3 * PLAN_BUFFER_SIZE && ok; i++) {
      snprintf(l, sizeof l, i % 2 ? "G1 X%d F20" : "G4 P1", i);
      ok = run(l) == STATUS_OK;
    }
    CHECK(ok, "lines rejected");
    finish();
    int32_t p[3];
    st_get_position(p);
    CHECK(plan_is_empty() && p[0] == plan_to_steps(3 * PLAN_BUFFER_SIZE - 1, 6400.0 / 3.0), "ended at %d", p[0]);
    jobs++;
  }

  /* feed hold mid-job, both laws: decelerate, stop with the beam off, resume to the end */
  for (int law = 0; law < 2; law++) {
    ctx = law ? "feed hold (accel)" : "feed hold (linear)";
    reset(law ? PLAN_MODE_JUNCTION : PLAN_MODE_HQ, (uint8_t)law, 16);
    CHECK(run("M3 S255 G1 X2 F20") == STATUS_OK && run("G1 X0 Y1") == STATUS_OK, "job");
    plan_flush();
    st_prep_buffer();
    hal_record_ticks(1500);
    uint32_t before = rec.n_ticks;
    uint32_t rate_at_hold = rec.ticks[before - 1].rate;
    st_feed_hold();
    hal_record_ticks(1000000);
    CHECK(st_state() == ST_HELD, "state %u after the hold", st_state());
    CHECK(rec.duty == 0, "laser duty %u while held", rec.duty);
    uint32_t rises = 0, jumps = 0, prepared = 0;
    uint64_t prepared_end = 0;
    for (uint32_t k = before + 1; k < rec.n_ticks; k++) {
      if (rec.ticks[k].rate > rec.ticks[k - 1].rate && rec.ticks[k].seq == rec.ticks[k - 1].seq) rises++;
      if (rec.ticks[k].rate == rate_at_hold && !prepared_end) prepared++;
      else if (!prepared_end) prepared_end = rec.ticks[k - 1].cycles_end;
      /* never a drop faster than the slope allows */
      uint64_t a = rec.ticks[k - 1].rate, c = rec.ticks[k].rate;
      uint64_t down = 0;
      for (uint32_t q = 0; q < rec.n_blocks; q++)
        if (rec.blocks[q].seq == rec.ticks[k].seq) down = rec.blocks[q].down;
      uint64_t d = law ? (a * a - c * c) : (a - c);
      /* isqrt rounds down: allow one Hz of it on the accel law */
      if (c < a && d > (law ? 2ull * down + 2ull * a : down)) jumps++;
    }
    CHECK(rises == 0, "%u rate rises while holding", rises);
    CHECK(jumps == 0, "%u drops steeper than the slope", jumps);
    uint64_t late = prepared_end - rec.ticks[before - 1].cycles_end;
    CHECK(rec.n_ticks - before > 10 && late <= (uint64_t)plan_machine()->timer_clock_hz / 1000u * ST_PREP_LEAD_MS,
          "hold ran %u ticks; it slowed down after %u ticks (%.2f ms)", rec.n_ticks - before, prepared,
          (double)late / plan_machine()->timer_clock_hz * 1e3);
    int32_t held[3];
    st_get_position(held);
    CHECK(held[0] != 4267 || held[1] != 0, "the hold came too late to test");
    uint32_t at_resume = rec.n_ticks;
    st_resume();
    hal_record_pump();
    int32_t pos[3];
    st_get_position(pos);
    CHECK(pos[0] == 0 && pos[1] == 2133 && plan_is_empty(), "after resume at %d %d", pos[0], pos[1]);
    CHECK(at_resume < rec.n_ticks && rec.ticks[at_resume].rate <= rec.ticks[at_resume - 1].rate + 2000u,
          "resume jumped from %u to %u Hz", rec.ticks[at_resume - 1].rate, rec.ticks[at_resume].rate);
    jobs++;
  }

  /* a hold while the stepper waits for look-ahead keeps the queued work from starting */
  ctx = "hold while idle";
  {
    reset(PLAN_MODE_JUNCTION, PLAN_LAW_ACCEL, 16);
    CHECK(run("G1 X1 F10") == STATUS_OK, "job");
    st_prep_buffer();
    CHECK(!rec.running && st_is_idle(), "a lone block started before the window filled");
    st_feed_hold();
    CHECK(st_state() == ST_HELD, "state %u", st_state());
    plan_flush();
    st_prep_buffer();
    CHECK(!rec.running, "held work started");
    st_resume();
    hal_record_pump();
    int32_t p[3];
    st_get_position(p);
    CHECK(p[0] == 2133 && st_is_idle(), "after resume at %d", p[0]);
    jobs++;
  }

  /* reset drops the job, keeps the position, and a new job starts from there */
  ctx = "reset";
  {
    reset(PLAN_MODE_JUNCTION, PLAN_LAW_ACCEL, 16);
    CHECK(run("M3 S100 G1 X3 F10") == STATUS_OK && run("G1 Y3") == STATUS_OK, "job");
    plan_flush();
    st_prep_buffer();
    hal_record_ticks(700);
    st_reset();
    CHECK(!rec.running && rec.duty == 0 && plan_is_empty() && st_is_idle(), "reset left the machine running");
    int32_t p[3], q[3];
    st_get_position(p);
    plan_get_position(q);
    CHECK(p[0] > 0 && p[0] < 6400 && !memcmp(p, q, sizeof p), "positions after reset %d / %d", p[0], q[0]);
    gc_sync_position();
    CHECK(run("G1 X0 Y0 F10") == STATUS_OK, "new job");
    finish();
    st_get_position(p);
    CHECK(p[0] == 0 && p[1] == 0, "new job ended at %d %d", p[0], p[1]);
    jobs++;
  }

  /* slow feeds: ticks longer than the 16-bit period register run as several periods */
  ctx = "slow feed";
  {
    reset(PLAN_MODE_HQ, PLAN_LAW_LINEAR, 16);
    CHECK(run("M3 S100 G1 X0.05 Y0.02 F0.03") == STATUS_OK, "slow job");   /* 64 Hz: 750000 counts */
    double end[3] = {0.05, 0.02, 0.0};
    finish();
    check_job(PLAN_LAW_LINEAR, end);
    CHECK(rec.n_ticks == 107 && rec.ticks[0].period > 65535u, "%u ticks, first period %u", rec.n_ticks,
          rec.ticks[0].period);
    CHECK(rec.max_hal_period <= 65535u && rec.hal_periods > rec.n_ticks, "period register got %u",
          rec.max_hal_period);
    uint64_t c = 0;
    for (uint32_t k = 0; k < rec.n_ticks; k++) c += (uint64_t)rec.ticks[k].period + 1;
    CHECK(c == rec.cycles, "cycles %llu vs %llu", (unsigned long long)c, (unsigned long long)rec.cycles);
    ticks += rec.n_ticks;
    jobs++;
  }

  /* pulsed laser mode reaches the gate */
  ctx = "laser modes";
  laser_set_mode(LASER_MODE_PULSED, 20000, 500);
  CHECK(rec.gate_hz == 20000 && laser_get_mode() == LASER_MODE_PULSED, "pulsed gate %u Hz", rec.gate_hz);
  laser_set_mode(LASER_MODE_CONTINUOUS, 0, 0);
  CHECK(rec.gate_hz == 0 && laser_get_mode() == LASER_MODE_CONTINUOUS, "continuous gate");
  CHECK(laser_tick_power_mw(4, 1000.0, 1000, 4000, 2500.0) == 2500.0 &&
            laser_tick_power_mw(4, 1000.0, 1000, 500, 2500.0) == 500.0 &&
            laser_tick_power_mw(3, 1000.0, 1000, 4000, 2500.0) == 1000.0 &&
            laser_tick_power_mw(0, 1000.0, 1000, 4000, 2500.0) == 0.0,
        "tick power rules");
  CHECK(laser_duty_from_mw(2500.0, 2500.0) == LK_LASER_PWM_TOP && laser_duty_from_mw(0.0, 2500.0) == 0 &&
            laser_duty_from_mw(0.001, 2500.0) == 1,
        "duty scale");

  if (failures) {
    printf("test_planner: %d of %d checks failed (first failure above)\n", failures, checks);
    return 1;
  }
  printf("test_planner: %d jobs, %ld ticks, %d checks: all pass\n", jobs, ticks, checks);
  return 0;
}
