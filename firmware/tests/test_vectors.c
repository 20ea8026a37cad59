/*
  test_vectors.c - run every JSON file of tests/vectors/motion through the firmware
  (gc_execute_line -> planner -> stepper -> recording hal) and compare every
  block and every tick with the Python reference: integers and mW exactly,
  the *_mm_s speeds to 1e-9 relative (they agree to the bit on x86-64).

  usage: test_vectors <repository root>
*/
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gcode.h"
#include "hal_record.h"
#include "json_mini.h"
#include "laser.h"
#include "planner.h"
#include "settings.h"
#include "status_codes.h"
#include "stepper.h"

static const char *cur_file;
static long cur_block;
static int failed;

#define FAIL(...)                                                              \
  do {                                                                         \
    if (!failed) {                                                             \
      printf("test_vectors: MISMATCH %s block %ld: ", cur_file, cur_block);    \
      printf(__VA_ARGS__);                                                     \
      printf("\n");                                                            \
    }                                                                          \
    failed = 1;                                                                \
    return 0;                                                                  \
  } while (0)

static int eq_int(const char *field, int64_t got, const jm_node_t *want)
{
  if (!want) FAIL("field %s missing in the vector", field);
  if (got != jm_int(want)) FAIL("%s: firmware %lld, reference %s", field, (long long)got, want->str);
  return 1;
}

static int eq_exact(const char *field, double got, const jm_node_t *want)
{
  if (!want) FAIL("field %s missing in the vector", field);
  if (got != jm_num(want)) FAIL("%s: firmware %.17g, reference %s", field, got, want->str);
  return 1;
}

static int eq_rel(const char *field, double got, const jm_node_t *want)
{
  if (!want) FAIL("field %s missing in the vector", field);
  double w = jm_num(want);
  if (!(fabs(got - w) <= 1e-9 * fabs(w)) && !(got == w))
    FAIL("%s: firmware %.17g, reference %s (beyond 1e-9 relative)", field, got, want->str);
  return 1;
}

static int eq_triple(const char *field, const int32_t got[3], const jm_node_t *want)
{
  if (!want || want->n != 3) FAIL("field %s missing or not 3 numbers", field);
  for (int a = 0; a < 3; a++)
    if (got[a] != jm_int(jm_at(want, (size_t)a)))
      FAIL("%s[%d]: firmware %d, reference %s", field, a, got[a], jm_at(want, (size_t)a)->str);
  return 1;
}

static void triple_d(const jm_node_t *n, double out[3])
{
  for (int a = 0; a < 3; a++) out[a] = jm_num(jm_at(n, (size_t)a));
}

static void set_machine(const jm_node_t *mj)
{
  lk_machine_t *m = plan_machine();
  const jm_node_t *name = jm_get(mj, "name");
  if (name && name->str) {
    strncpy(m->name, name->str, sizeof m->name - 1);
    m->name[sizeof m->name - 1] = 0;
  }
  triple_d(jm_get(mj, "steps_per_mm"), m->steps_per_mm);
  triple_d(jm_get(mj, "max_rate_mm_min"), m->max_rate_mm_min);
  triple_d(jm_get(mj, "accel_mm_s2"), m->accel_mm_s2);
  triple_d(jm_get(mj, "travel_mm"), m->travel_mm);
  m->accel_hz_per_step = (int32_t)jm_int(jm_get(mj, "accel_hz_per_step"));
  m->decel_hz_per_step = (int32_t)jm_int(jm_get(mj, "decel_hz_per_step"));
  m->start_rate_hz = (int32_t)jm_int(jm_get(mj, "start_rate_hz"));
  m->junction_deviation_mm = jm_num(jm_get(mj, "junction_deviation_mm"));
  m->arc_tolerance_mm = jm_num(jm_get(mj, "arc_tolerance_mm"));
  m->buffer_blocks = (int32_t)jm_int(jm_get(mj, "buffer_blocks"));
  m->laser_max_power_mw = jm_num(jm_get(mj, "laser_max_power_mw"));
  m->timer_clock_hz = (uint32_t)jm_int(jm_get(mj, "timer_clock_hz"));
  m->prescaler = (uint32_t)jm_int(jm_get(mj, "prescaler"));
  m->timer_bits = (uint32_t)jm_int(jm_get(mj, "timer_bits"));
  m->step_pulse_us = jm_num(jm_get(mj, "step_pulse_us"));
}

static void wait_hook(void) { hal_record_run(); }

static const char *kind_name(const st_block_info_t *b)
{
  if (b->kind == PLAN_BLOCK_DWELL) return "DWELL";
  if (b->rapid) return "RAPID";
  return b->kind == PLAN_BLOCK_ARC ? "ARC" : "LINE";
}

static long total_blocks, total_ticks;

static int run_vector(const char *path, const char *fname)
{
  char err[200];
  jm_node_t *v = jm_parse_file(path, err, sizeof err);
  cur_file = fname;
  cur_block = -1;
  if (!v) {
    printf("test_vectors: %s: %s\n", fname, err);
    failed = 1;
    return 0;
  }
  int ok = 1;
  hal_record_reset();
  plan_init();
  set_machine(jm_get(v, "machine"));
  if (plan_apply_machine() != STATUS_OK) {
    printf("test_vectors: %s: machine rejected\n", fname);
    failed = 1;
    jm_free(v);
    return 0;
  }
  const char *planner = jm_get(v, "planner")->str;
  const char *law = jm_get(v, "law")->str;
  plan_set_mode(!strcmp(planner, "fast") ? PLAN_MODE_FAST : !strcmp(planner, "normal") ? PLAN_MODE_NORMAL
                : !strcmp(planner, "hq") ? PLAN_MODE_HQ : PLAN_MODE_JUNCTION);
  plan_set_law(!strcmp(law, "linear") ? PLAN_LAW_LINEAR : PLAN_LAW_ACCEL);
  plan_set_depth((uint32_t)jm_int(jm_get(v, "buffer_blocks")));
  st_init();
  laser_init();
  gc_init();
  gc_set_dialect(!strcmp(jm_get(v, "dialect")->str, "grbl") ? GC_DIALECT_GRBL : GC_DIALECT_LABKIT);
  settings.laser_mode = 1;   /* the vectors' GRBL is in laser mode ($32=1, labkit.gcode's grbl) */
  gc_set_wait_hook(wait_hook);

  /* stream the job line by line, letting the machine run between lines */
  char *text = strdup(jm_get(v, "gcode")->str);
  char *save = NULL;
  int lineno = 0;
  for (char *line = strtok_r(text, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
    lineno++;
    uint8_t st = gc_execute_line(line);
    if (st != STATUS_OK) {
      printf("test_vectors: MISMATCH %s line %d '%s': status %u, expected ok\n", fname, lineno, line, st);
      failed = 1;
      ok = 0;
      break;
    }
    hal_record_pump();
  }
  free(text);
  plan_flush();
  hal_record_pump();
  if (ok && (!plan_is_empty() || rec.running)) {
    printf("test_vectors: MISMATCH %s: the job did not run to its end\n", fname);
    failed = 1;
    ok = 0;
  }
  if (ok && (rec.double_pulses || rec.stray_pulses)) {
    printf("test_vectors: MISMATCH %s: %u double and %u stray step pulses\n", fname,
           rec.double_pulses, rec.stray_pulses);
    failed = 1;
    ok = 0;
  }

  const jm_node_t *blocks = jm_get(v, "blocks");
  uint32_t ti = 0;
  int32_t max_sb = -1;
  /* a dwell of 0 timer cycles makes no tick: the recorder cannot see it */
  uint32_t zero_dwells = 0;
  for (size_t i = 0; i < blocks->n; i++) {
    const jm_node_t *dc = jm_get(jm_at(blocks, i), "dwell_cycles");
    if (dc && jm_int(dc) == 0) zero_dwells++;
  }
  if (ok && blocks->n != rec.n_blocks + zero_dwells) {
    printf("test_vectors: MISMATCH %s: %u blocks run, reference %zu\n", fname, rec.n_blocks, blocks->n);
    failed = 1;
    ok = 0;
  }
  uint32_t ri = 0;
  for (size_t i = 0; ok && i < blocks->n; i++) {
    const jm_node_t *vb = jm_at(blocks, i);
    const jm_node_t *dc = jm_get(vb, "dwell_cycles");
    if (dc && jm_int(dc) == 0) continue;
    const st_block_info_t *b = &rec.blocks[ri++];
    cur_block = (long)i;
    const char *kind = jm_get(vb, "kind")->str;
    if (strcmp(kind, kind_name(b))) {
      printf("test_vectors: MISMATCH %s block %zu: kind: firmware %s, reference %s\n", fname, i,
             kind_name(b), kind);
      failed = 1;
      ok = 0;
      break;
    }
    if (!(ok = eq_int("line", b->line, jm_get(vb, "line")))) break;
    if (!strcmp(kind, "DWELL")) {
      uint64_t c = 0;
      while (ti < rec.n_ticks && rec.ticks[ti].seq == b->seq) {
        c += ((uint64_t)rec.ticks[ti].period + 1) * (plan_machine()->prescaler + 1);
        ti++;
      }
      if (!(ok = eq_int("dwell_cycles", b->dwell_cycles, jm_get(vb, "dwell_cycles")))) break;
      if (!(ok = eq_int("dwell_cycles (timer periods run)", (int64_t)c, jm_get(vb, "dwell_cycles")))) break;
      continue;
    }
    ok = eq_triple("start_steps", b->start_steps, jm_get(vb, "start_steps")) &&
         eq_triple("end_steps", b->end_steps, jm_get(vb, "end_steps")) &&
         eq_int("dir_bits", b->dir_bits, jm_get(vb, "dir_bits")) &&
         eq_int("ticks", b->ticks, jm_get(vb, "ticks")) &&
         eq_exact("length_mm", b->length_mm, jm_get(vb, "length_mm")) &&
         eq_int("super_block", b->super_block, jm_get(vb, "super_block")) &&
         eq_rel("entry_mm_s", b->entry_mm_s, jm_get(vb, "entry_mm_s")) &&
         eq_rel("peak_mm_s", b->peak_mm_s, jm_get(vb, "peak_mm_s")) &&
         eq_rel("exit_mm_s", b->exit_mm_s, jm_get(vb, "exit_mm_s")) &&
         eq_int("f_entry", b->f_entry, jm_get(vb, "f_entry")) &&
         eq_int("f_peak", b->f_peak, jm_get(vb, "f_peak")) &&
         eq_int("f_exit", b->f_exit, jm_get(vb, "f_exit")) &&
         eq_int("f_min", b->f_min, jm_get(vb, "f_min")) &&
         eq_int("up", b->up, jm_get(vb, "up")) &&
         eq_int("down", b->down, jm_get(vb, "down")) &&
         eq_int("f_feed", b->f_feed, jm_get(vb, "f_feed")) &&
         eq_int("laser", b->laser, jm_get(vb, "laser")) &&
         eq_exact("power_mw", b->power_mw, jm_get(vb, "power_mw"));
    if (!ok) break;
    if (b->super_block > max_sb) max_sb = b->super_block;
    const jm_node_t *ts = jm_get(vb, "tick_steps"), *tp = jm_get(vb, "tick_periods"),
                    *tw = jm_get(vb, "tick_power_mw");
    uint32_t first = ti, n = 0, pmin = UINT32_MAX;
    int32_t spa[3] = {0, 0, 0};
    char field[64];
    while (ti < rec.n_ticks && rec.ticks[ti].seq == b->seq) {
      const rec_tick_t *t = &rec.ticks[ti];
      if (n >= ts->n) break;
      const jm_node_t *st = jm_at(ts, n);
      for (int a = 0; a < 3; a++) {
        snprintf(field, sizeof field, "tick_steps[%u][%d]", n, a);
        if (!(ok = eq_int(field, t->step[a], jm_at(st, (size_t)a)))) break;
        spa[a] += t->step[a] < 0 ? -t->step[a] : t->step[a];
      }
      if (!ok) break;
      snprintf(field, sizeof field, "tick_periods[%u]", n);
      if (!(ok = eq_int(field, t->period, jm_at(tp, n)))) break;
      snprintf(field, sizeof field, "tick_power_mw[%u]", n);
      if (!(ok = eq_exact(field, t->power_mw, jm_at(tw, n)))) break;
      {
        uint16_t want = laser_duty_from_mw(t->power_mw, plan_machine()->laser_max_power_mw);
        if (t->duty != want) {
          printf("test_vectors: MISMATCH %s block %zu: tick %u laser duty %u on the output, %u for its power\n",
                 fname, i, n, t->duty, want);
          failed = 1;
          ok = 0;
          break;
        }
      }
      if (t->period < pmin) pmin = t->period;
      n++;
      ti++;
    }
    if (!ok) break;
    if (n != ts->n || (ti < rec.n_ticks && rec.ticks[ti].seq == b->seq)) {
      printf("test_vectors: MISMATCH %s block %zu: ticks run %u, reference %zu\n", fname, i, n, ts->n);
      failed = 1;
      ok = 0;
      break;
    }
    ok = eq_triple("steps_per_axis", spa, jm_get(vb, "steps_per_axis")) &&
         eq_int("period_entry", rec.ticks[first].period, jm_get(vb, "period_entry")) &&
         eq_int("period_peak", pmin, jm_get(vb, "period_peak")) &&
         eq_int("period_exit", rec.ticks[ti - 1].period, jm_get(vb, "period_exit")) &&
         eq_int("cycles_end", (int64_t)rec.ticks[ti - 1].cycles_end, jm_get(vb, "cycles_end"));
    if (!ok) break;
    total_ticks += n;
  }
  if (ok) {
    const jm_node_t *s = jm_get(v, "summary");
    int32_t pos[3];
    st_get_position(pos);
    cur_block = -1;
    uint32_t motion_ticks = 0;
    for (uint32_t k = 0; k < rec.n_blocks; k++)
      if (rec.blocks[k].kind != PLAN_BLOCK_DWELL) motion_ticks += rec.blocks[k].ticks;
    ok = eq_int("summary.blocks", rec.n_blocks + zero_dwells, jm_get(s, "blocks")) &&
         eq_int("summary.super_blocks", max_sb + 1, jm_get(s, "super_blocks")) &&
         eq_int("summary.ticks", motion_ticks, jm_get(s, "ticks")) &&
         eq_int("summary.cycles_total", (int64_t)rec.cycles, jm_get(s, "cycles_total")) &&
         (jm_get(s, "final_steps")->type == JM_NULL ||   /* the job ends with a dwell */
          eq_triple("summary.final_steps", pos, jm_get(s, "final_steps")));
    total_blocks += (long)rec.n_blocks;
  }
  jm_free(v);
  return ok;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

int main(int argc, char **argv)
{
  const char *root = argc > 1 ? argv[1] : ".";
  char dir[1024];
  snprintf(dir, sizeof dir, "%s/tests/vectors/motion", root);
  DIR *d = opendir(dir);
  if (!d) {
    printf("test_vectors: cannot open %s\n", dir);
    return 1;
  }
  char *names[64];
  int nfiles = 0;
  struct dirent *e;
  while ((e = readdir(d)) && nfiles < 64) {
    size_t len = strlen(e->d_name);
    if (len > 5 && !strcmp(e->d_name + len - 5, ".json")) names[nfiles++] = strdup(e->d_name);
  }
  closedir(d);
  qsort(names, (size_t)nfiles, sizeof names[0], cmp_str);
  int passed = 0;
  for (int i = 0; i < nfiles; i++) {
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", dir, names[i]);
    int was_failed = failed;
    failed = 0;
    if (run_vector(path, names[i])) passed++;
    failed = failed || was_failed;
  }
  if (nfiles == 0) {
    printf("test_vectors: no vector files in %s\n", dir);
    return 1;
  }
  if (passed == nfiles)
    printf("test_vectors: %d files, %ld blocks, %ld ticks: all equal\n", nfiles, total_blocks, total_ticks);
  else
    printf("test_vectors: %d files, %d equal, %d with a mismatch (first mismatch of each above)\n",
           nfiles, passed, nfiles - passed);
  for (int i = 0; i < nfiles; i++) free(names[i]);
  hal_record_reset();
  return passed == nfiles ? 0 : 1;
}
