/*
  test_beam.c - the beam-state property (beam_property.h) over every file of
  the fuzz corpora and regressions, over seeded random streams, and on the
  UTF-8 '²' case; and the property itself shown to catch a beam that is on
  where the program does not command it.
*/
#define _DEFAULT_SOURCE
#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "beam_property.h"
#include "gcode.h"
#include "laser.h"
#include "menu.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "shell_test.h"
#include "status_codes.h"
#include "stepper.h"

/* ------------------------------------------------------------ violations */

static int violations;
static char first_violation[300];
static void count_violation(const char *what) {
  if (!violations++)
    snprintf(first_violation, sizeof first_violation, "%s", what);
}

static void run_bytes(const uint8_t *data, size_t n) {
  beam_power_on();
  beam_run(data, n);
}

/* ------------------------------------------------------------ files */

static uint8_t file_buf[1 << 20];

static int run_dir(const char *root, const char *dir, int *files) {
  char path[1024];
  snprintf(path, sizeof path, "%s/firmware/tests/fuzz/%s", root, dir);
  DIR *d = opendir(path);
  if (!d)
    return 0;
  struct dirent *e;
  char names[256][128];
  int n = 0;
  while ((e = readdir(d)) && n < 256)
    if (e->d_name[0] != '.' && strlen(e->d_name) < sizeof names[0])
      strcpy(names[n++], e->d_name);
  closedir(d);
  qsort(names, (size_t)n, sizeof names[0], (int (*)(const void *, const void *))strcmp);
  for (int i = 0; i < n; i++) {
    char f[1024 + 130];
    snprintf(f, sizeof f, "%.1023s/%.127s", path, names[i]);
    FILE *fp = fopen(f, "rb");
    if (!fp)
      continue;
    size_t len = fread(file_buf, 1, sizeof file_buf, fp);
    fclose(fp);
    int before = violations;
    run_bytes(file_buf, len);
    if (violations != before)
      fprintf(stderr, "%s: beam property violated: %s\n", f, first_violation);
    (*files)++;
  }
  return n;
}

/* ------------------------------------------------------------ random streams */

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static uint32_t rnd(uint32_t n) {   /* xorshift64*, seeded: the same streams every run */
  rng ^= rng >> 12;
  rng ^= rng << 25;
  rng ^= rng >> 27;
  return (uint32_t)((rng * 0x2545F4914F6CDD1Dull) >> 33) % n;
}

static size_t put(uint8_t *buf, size_t k, size_t cap, const char *s) {
  while (*s && k < cap)
    buf[k++] = (uint8_t)*s++;
  return k;
}

/* A stream a sender might write, mistakes and interruptions included:
   G-code lines of random words (mostly small burning moves), $ commands,
   real-time bytes, UTF-8 text, stray bytes and panel events. */
static size_t random_stream(uint8_t *buf, size_t cap) {
  static const char *const words[] = {"G0", "G1", "G1", "G1", "G2", "G3", "G80", "M3", "M3", "M4",
                                      "M5", "M2", "M30", "G4P1", "G91", "G90", "G20", "G21", "M8"};
  static const char *const system[] = {"$C\n", "$X\n", "$H\n", "$J=G91X1F600\n", "$$\n", "$G\n",
                                       "$20=1\n", "$I\n", "$LCD\n", "$22=1\n", "$21=1\n", "$21=0\n"};
  static const char *const realtime[] = {"!", "~", "?", "\x18", "\x84", "\x85", "\x90", "\x91",
                                         "\x99", "\x9A", "\x9B", "\x95"};
  static const char *const text[] = {"(mm\xc2\xb2)", "\xc2\xb2", "\xb2\xb2", "\xb0\xb2\xb2",
                                     "(\xb8)", ";\xe2\x80\x94 note", "%", "\xff"};
  static const uint8_t panel[] = {PANEL_CW, PANEL_CCW, PANEL_OK, PANEL_OK, PANEL_CW, PANEL_OK,
                                  PANEL_OK, PANEL_CCW, PANEL_OK, PANEL_ESTOP};
  /* each stream names its dialect, so that its feeds mean what they say whatever the
     default: F in mm/s (labkit-fw) or mm/min (GRBL) */
  int grbl = (int)rnd(2);
  size_t k = put(buf, 0, cap, grbl ? "$208=1\n" : "$208=0\n");
  if (rnd(4) == 0)                            /* hard limits on: the switches 5 mm out trip */
    k = put(buf, k, cap, "$21=1\n");
  int lines = 5 + (int)rnd(25);
  char num[48];
  for (int l = 0; l < lines && k + 64 < cap; l++) {
    uint32_t kind = rnd(24);
    if (kind >= 20) {                         /* a cut, then maybe a pause and a hold */
      /* one in eight runs out to the switch 5 mm out on X (a hard limit with $21=1) */
      snprintf(num, sizeof num, "G1X%uY%u.%uF%uS%uM%c\n", rnd(8) ? rnd(3) : 6 + rnd(2), rnd(2), rnd(10),
               (5 + rnd(60)) * (grbl ? 60u : 1u), 1 + rnd(255), rnd(2) ? '3' : '4');
      k = put(buf, k, cap, num);
      if (rnd(2) && k + 2 < cap) {
        buf[k++] = BEAM_PANEL_ESCAPE;
        buf[k++] = (uint8_t)rnd(8);
      }
      if (rnd(3) == 0)
        k = put(buf, k, cap, rnd(2) ? "!" : "!?~");
      continue;
    }
    if (kind < 13) {                          /* a G-code line */
      int nw = 1 + (int)rnd(4);
      for (int w = 0; w < nw; w++) {
        uint32_t c = rnd(10);
        if (c < 3) {
          k = put(buf, k, cap, words[rnd(sizeof words / sizeof words[0])]);
        } else if (c < 6) {
          snprintf(num, sizeof num, "%c%d.%u", "XYZ"[rnd(2)], (int)rnd(8) - 2, rnd(10));
          k = put(buf, k, cap, num);
        } else if (c < 8) {
          snprintf(num, sizeof num, "S%u", rnd(4) ? rnd(1000) : 0u);
          k = put(buf, k, cap, num);
        } else if (c < 9) {
          snprintf(num, sizeof num, "F%u", grbl ? 300 + rnd(3000) : 5 + rnd(60));
          k = put(buf, k, cap, num);
        } else {
          snprintf(num, sizeof num, "%c%d", "IJR"[rnd(3)], (int)rnd(6) - 3);
          k = put(buf, k, cap, num);
        }
        if (rnd(3) == 0)
          k = put(buf, k, cap, " ");
      }
      if (rnd(6) == 0)
        k = put(buf, k, cap, text[rnd(sizeof text / sizeof text[0])]);
      k = put(buf, k, cap, rnd(4) ? "\n" : "\r\n");
    } else if (kind < 15) {
      k = put(buf, k, cap, system[rnd(sizeof system / sizeof system[0])]);
    } else if (kind < 17) {
      k = put(buf, k, cap, realtime[rnd(sizeof realtime / sizeof realtime[0])]);
    } else if (kind < 18) {
      k = put(buf, k, cap, text[rnd(sizeof text / sizeof text[0])]);
    } else if (kind < 19) {
      for (int p = 0, np = 1 + (int)rnd(5); p < np && k + 2 < cap; p++) {
        buf[k++] = BEAM_PANEL_ESCAPE;
        buf[k++] = panel[rnd(sizeof panel)];
      }
    } else {
      for (int r = 0, nr = 1 + (int)rnd(8); r < nr && k < cap; r++)
        buf[k++] = (uint8_t)rnd(256);
    }
  }
  return k;
}

/* ------------------------------------------------------------ the property can fail */

static void feed_text(const char *s) { beam_feed((const uint8_t *)s, strlen(s)); }

static int caught(const char *needle) {
  return violations > 0 && strstr(first_violation, needle) != NULL;
}

static void test_property_catches(void) {
  /* the beam switched on at rest, as the '²' bytes once did */
  violations = 0;
  beam_power_on();
  feed_text("G21\n");
  laser_output(10);
  CHECK(caught("no move running"));
  laser_off();

  /* in alarm */
  violations = 0;
  beam_power_on();
  protocol_alarm(2);
  laser_output(200);
  CHECK(caught("beam on in alarm"));
  laser_off();

  /* a block that burns after M5: the accepted program says it does not */
  violations = 0;
  beam_power_on();
  feed_text("G1 X1 F600\nM5\n");
  CHECK(violations == 0);
  plan_move_t mv;
  plan_block_t b;
  memset(&mv, 0, sizeof mv);
  mv.kind = PLAN_MOVE_LINE;
  mv.end_mm[0] = 2.0;
  mv.start_mm[0] = 1.0;
  mv.feed_mm_min = 600.0;
  mv.laser = 3;
  mv.power_mw = 500.0;
  mv.line = gc_state()->line;               /* the M5 line */
  CHECK(plan_prepare_move(&mv, &b) == STATUS_OK);
  plan_push_block(&b);
  plan_flush();
  for (int i = 0; i < 200 && violations == 0; i++)
    protocol_poll();
  CHECK(caught("does not burn on"));
  beam_end();

  violations = 0;
}

int main(int argc, char **argv) {
  const char *root = argc > 1 ? argv[1] : "..";
  beam_set_fail(count_violation);

  test_property_catches();

  /* the UTF-8 '²' case and the panel's deliberate sequence */
  violations = 0;
  beam_power_on();
  feed_text("G21 (mm\xc2\xb2 \xc2\xb2)\n");
  CHECK(beam_output_duty() == 0 && !menu_laser_is_on());
  beam_end();
  beam_power_on();
  static const uint8_t focus[] = {BEAM_PANEL_ESCAPE, PANEL_OK, BEAM_PANEL_ESCAPE, PANEL_CW,
                                  BEAM_PANEL_ESCAPE, PANEL_OK, BEAM_PANEL_ESCAPE, PANEL_OK};
  beam_feed(focus, sizeof focus);
  CHECK(menu_laser_is_on() && beam_output_duty() == MENU_FOCUS_DUTY);
  feed_text("?");
  CHECK(beam_output_duty() == MENU_FOCUS_DUTY);
  feed_text("M5\n");                         /* any host line ends it */
  CHECK(beam_output_duty() == 0);
  beam_end();
  CHECK(violations == 0);

  /* a homing cycle between two cuts (GRBL's $H on the hal's switches, BEAM_SWITCH_MM out):
     the beam is off in every tick of the cycle (beam_check: PROTO_HOME), the machine ends
     homed, one pull-off inside its switches, and the cut after it burns again */
  {
    beam_power_on();
    beam_stats_t before = *beam_stats();
    feed_text("$22=1\nG1 X2 F600 S500 M3\n");
    CHECK(beam_stats()->ticks_burning > before.ticks_burning);
    feed_text("$H\n");
    CHECK(protocol_state() == PROTO_IDLE);
    CHECK(beam_stats()->ticks_homing > before.ticks_homing + 1000);
    int32_t at[3];
    st_get_position(at);
    for (int a = 0; a < 3; a++)
      CHECK(at[a] == -(int32_t)lround(settings.homing_pulloff * plan_machine()->steps_per_mm[a]));
    uint64_t burned = beam_stats()->ticks_burning;
    feed_text("G1 X-4\n");                  /* M3 S500 still in effect */
    CHECK(beam_stats()->ticks_burning > burned);
    beam_end();
    CHECK(violations == 0);
    printf("test_beam: homing between two cuts, %llu ticks homing, beam dark throughout\n",
           (unsigned long long)(beam_stats()->ticks_homing - before.ticks_homing));
  }

  /* every corpus and regression file */
  const beam_stats_t *st = beam_stats();
  beam_stats_t zero = *st;
  int files = 0;
  static const char *const dirs[] = {"corpus_fuzz_line", "corpus_fuzz_protocol", "corpus_fuzz_beam",
                                     "regressions/fuzz_line", "regressions/fuzz_protocol",
                                     "regressions/fuzz_beam"};
  for (unsigned i = 0; i < sizeof dirs / sizeof dirs[0]; i++)
    CHECK(run_dir(root, dirs[i], &files) > 0);
  CHECK(violations == 0);
  printf("test_beam: %d corpus and regression files, %llu ticks (%llu burning), %u of %u lines "
         "burn\n", files, (unsigned long long)(st->ticks - zero.ticks),
         (unsigned long long)(st->ticks_burning - zero.ticks_burning),
         st->lines_burning - zero.lines_burning, st->lines_ok - zero.lines_ok);
  CHECK(st->ticks_burning > zero.ticks_burning);

  /* seeded random streams */
  static uint8_t stream[4096];
  const int streams = 3000;
  zero = *st;
  for (int i = 0; i < streams; i++) {
    size_t n = random_stream(stream, sizeof stream);
    int before = violations;
    run_bytes(stream, n);
    if (violations != before && before == 0) {
      fprintf(stderr, "random stream %d violates the beam property: %s\nstream:", i, first_violation);
      for (size_t k = 0; k < n; k++)
        fprintf(stderr, (stream[k] >= 0x20 && stream[k] < 0x7F) ? "%c" : "\\x%02x", stream[k]);
      fprintf(stderr, "\n");
    }
  }
  CHECK(violations == 0);
  printf("test_beam: %d random streams, %llu ticks (%llu burning), %u of %u lines burn, "
         "%u focus fires, %u holds while burning, %u resets, %u e-stops, %u hard-limit trips, "
         "%llu ticks homing\n",
         streams, (unsigned long long)(st->ticks - zero.ticks),
         (unsigned long long)(st->ticks_burning - zero.ticks_burning),
         st->lines_burning - zero.lines_burning, st->lines_ok - zero.lines_ok,
         st->focus_fires - zero.focus_fires, st->holds_burning - zero.holds_burning,
         st->resets - zero.resets, st->estops - zero.estops, st->hard_limits - zero.hard_limits,
         (unsigned long long)(st->ticks_homing - zero.ticks_homing));
  /* not vacuous: the streams burned, held burning cuts, fired the focus beam, reset, e-stopped */
  CHECK(st->ticks_burning - zero.ticks_burning > 10000);
  CHECK(st->holds_burning > zero.holds_burning);
  CHECK(st->focus_fires > zero.focus_fires);
  CHECK(st->estops > zero.estops);
  CHECK(st->hard_limits > zero.hard_limits);
  CHECK(st->ticks_homing > zero.ticks_homing);
  TEST_DONE("test_beam");
}
