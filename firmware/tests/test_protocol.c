/*
  test_protocol.c - line assembly, replies in both dialects, real-time
  bytes, $ commands, check mode, alarms, reset.
*/
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "gcode.h"
#include "hal.h"
#include "laser.h"
#include "planner.h"
#include "stepper.h"
#include "protocol.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "shell_test.h"
#include "shell_util.h"
#include "status_codes.h"

static uint8_t switch_seen;         /* the limit switch as the tests last saw it (below) */
uint8_t hal_limits_read(void);

static const char *run(const char *bytes) {
  shell_out_clear();
  shell_send(bytes);
  switch_seen = hal_limits_read();   /* run() plays no pin interrupt: moves here trip nothing */
  return shell_out();
}

static void test_line_asm(void) {
  line_asm_t a;
  memset(&a, 0, sizeof a);
  const char *s = "g1 x1.5 (comment) y2 ; tail\n";
  int st = -1;
  for (const char *p = s; *p; p++)
    st = line_asm_push(&a, (uint8_t)*p);
  CHECK(st == STATUS_OK);
  CHECK(!strcmp(a.buf, "G1X1.5Y2"));
  /* checksum: XOR of every byte before '*' */
  const char *body = "N7 G0 X1";
  uint8_t x = 0;
  for (const char *p = body; *p; p++) x ^= (uint8_t)*p;
  char line[64];
  snprintf(line, sizeof line, "%s*%u\n", body, x);
  for (const char *p = line; *p; p++) st = line_asm_push(&a, (uint8_t)*p);
  CHECK(st == STATUS_OK);
  CHECK(!strcmp(a.buf, "N7G0X1"));
  snprintf(line, sizeof line, "%s*%u\n", body, (x + 1u) & 255u);
  for (const char *p = line; *p; p++) st = line_asm_push(&a, (uint8_t)*p);
  CHECK(st == STATUS_BAD_CHECKSUM);
  /* '*' in a $ line is a character */
  for (const char *p = "$RST=*\n"; *p; p++) st = line_asm_push(&a, (uint8_t)*p);
  CHECK(st == STATUS_OK && !strcmp(a.buf, "$RST=*"));
  /* unbalanced comment */
  for (const char *p = "G0 (X1\n"; *p; p++) st = line_asm_push(&a, (uint8_t)*p);
  CHECK(st == STATUS_BAD_DELIMITER);
  /* over-long: rejected, not cut; the next line is whole */
  for (int i = 0; i < 300; i++) st = line_asm_push(&a, (uint8_t)(i ? '1' : 'X'));
  st = line_asm_push(&a, '\n');
  CHECK(st == STATUS_LINE_OVERFLOW);
  for (const char *p = "G0X2\n"; *p; p++) st = line_asm_push(&a, (uint8_t)*p);
  CHECK(st == STATUS_OK && !strcmp(a.buf, "G0X2"));
  /* exactly LINE_BUFFER_SIZE - 1 characters fit */
  for (int i = 0; i < LINE_BUFFER_SIZE - 1; i++) st = line_asm_push(&a, (uint8_t)(i ? '0' : 'N'));
  st = line_asm_push(&a, '\n');
  CHECK(st == STATUS_OK && strlen(a.buf) == LINE_BUFFER_SIZE - 1);
}

/* Stream one line and run it to the end, recording the highest feed (mm/min,
   as the status report computes it) and laser duty seen on the way. */
static void run_sampled(const char *line, double *max_feed, uint16_t *max_duty) {
  for (long i = 0; i < 5000000 && !st_is_idle(); i++) protocol_poll();   /* what came before ends */
  shell_out_clear();
  for (const char *p = line; *p; p++)
    serial_rx_isr((uint8_t)*p);
  for (int i = 0; i < 20; i++) protocol_poll();
  shell_advance_ms(100);                    /* quiet: the look-ahead is flushed */
  *max_feed = 0.0;
  *max_duty = 0;
  for (long i = 0; i < 2000000 && !(st_is_idle() && i > 30); i++) {
    protocol_poll();
    double f = report_feed_mm_min();
    if (f > *max_feed) *max_feed = f;
    if (laser_current_duty() > *max_duty) *max_duty = laser_current_duty();
  }
}

/* The probe input of these tests: touching once X is at or below probe_touch_x steps. */
static int32_t probe_touch_x = INT32_MIN;
uint8_t hal_probe_read(void) {
  int32_t p[3];
  st_get_position(p);
  return p[0] <= probe_touch_x;
}

/* Poll until the moves queued have run out. */
static void finish_moves(void) {
  for (long i = 0; i < 5000000 && !(st_is_idle() && plan_is_empty()); i++) {
    protocol_poll();
    if ((i & 255) == 255) shell_advance_ms(50);   /* quiet host: the look-ahead is flushed */
  }
  for (int i = 0; i < 20; i++) protocol_poll();
}

/* G38.2 in the grbl dialect, from X = 5 mm. */
static void test_probe(void) {
  /* a wrong probe line is answered at once, while the move before it still runs: GRBL checks
     the whole line before its probe cycle waits for rest */
  const char *lines = "G90 G1 X0 F600\nG38.2 F100\n";
  shell_out_clear();
  for (const char *p = lines; *p; p++)
    serial_rx_isr((uint8_t)*p);
  for (int i = 0; i < 40; i++) protocol_poll();
  CHECK(!strcmp(shell_out(), "ok\r\nerror:26\r\n"));
  CHECK(!plan_is_empty() || !st_is_idle());
  run("G1 X10\n");
  finish_moves();
  int32_t at[3];
  st_get_position(at);
  CHECK(at[0] == (int32_t)lround(10.0 * plan_machine()->steps_per_mm[0]));

  /* a good one waits for the moves before it, then runs; the step interrupt keeps the
     position of the touch (the main loop, 128 ticks later here, would see the head past it) */
  const double steps_per_mm = plan_machine()->steps_per_mm[0];
  probe_touch_x = (int32_t)(7.0 * steps_per_mm);
  char want[64] = "[PRB:";
  uint16_t n = fmt_float(want + 5, 20, (double)probe_touch_x / steps_per_mm, 3);
  strcpy(want + 5 + n, ",0.000,0.000:1]\r\nok\r\n");
  shell_out_clear();
  shell_send("G1 X12\nG38.2 X0 F100\n");
  finish_moves();
  const char *o = shell_out();
  CHECK_HAS(o, want);
  st_get_position(at);
  CHECK(at[0] < probe_touch_x);             /* the head went on a little before it stopped */
  /* the probe already touching: ALARM:4, nothing moves */
  shell_out_clear();
  shell_send("G38.2 X0 F100\n");
  finish_moves();
  o = shell_out();
  CHECK_HAS(o, "ALARM:4\r\nok\r\n");
  int32_t after[3];
  st_get_position(after);
  CHECK(after[0] == at[0]);
  probe_touch_x = INT32_MIN;
  o = run("$X\n");
  CHECK_HAS(o, "ok");
}

/* The limit switch of these tests: pressed once X is at or beyond switch_x steps; passes()
   plays the limit pins' change interrupt after each pass (the test hal ticks 128 a pass). */
static int32_t switch_x = INT32_MAX;
uint8_t hal_limits_read(void) {
  int32_t p[3];
  st_get_position(p);
  return p[0] >= switch_x ? HAL_AXIS_X : 0u;
}
static void passes(int n) {
  for (int i = 0; i < n; i++) {
    protocol_poll();
    uint8_t now = hal_limits_read();
    if (now != switch_seen) {
      switch_seen = now;
      protocol_limit_pin_change();
    }
  }
}
/* Bytes as a host sends them (passes while the RX ring fills), then n passes after the host
   has gone quiet (the look-ahead is flushed). */
static const char *feed(const char *bytes, int n) {
  shell_out_clear();
  for (const char *p = bytes; *p; p++) {
    serial_rx_isr((uint8_t)*p);
    if (serial_rx_count() > 100)
      passes(4);
  }
  passes(20);                       /* the parser takes 8 bytes a pass */
  shell_advance_ms(100);
  passes(n);
  return shell_out();
}

#define BANNER "\r\nGrbl 1.1h ['$' for help]\r\n"
#define LOCKED "[MSG:'$H'|'$X' to unlock]\r\n"

/* The host's Ctrl-X once the head has passed X 5 mm (a shell_poll_hook). */
static void reset_at_x5(void) {
  int32_t p[3];
  st_get_position(p);
  if (p[0] >= (int32_t)lround(5.0 * plan_machine()->steps_per_mm[0])) {
    serial_rx_isr(0x18);
    shell_poll_hook = NULL;
  }
}

/* GRBL answers a line whose wait a reset ends: ALARM:3 when the reset cut a move short, the
   line's reply, then the banner (tests/vectors/grbl/reset_wait.json). */
static void test_reset_while_waiting(void) {
  run("$X\nG90 G0 X0 Y0\nG4 P0\n");
  /* a dwell from rest: GRBL dwells in Idle, with its planner empty; the reset loses nothing */
  const char *o = feed("G4 P100\n", 20);
  CHECK(!strcmp(o, ""));
  CHECK(st_state() == ST_DWELL);
  o = feed("?", 2);
  CHECK_HAS(o, "<Idle|");
  o = feed("\x18", 2);
  CHECK(!strcmp(o, "ok\r\n" BANNER));
  CHECK(protocol_state() == PROTO_IDLE);
  /* a G4, an M2, a probe behind a move */
  static const char *const behind[] = {"G4 P0\n", "M2\n", "G38.2 Z-5 F100\n"};
  static const char *const replies[] = {"ok\r\n", "[MSG:Pgm End]\r\nok\r\n", "ok\r\n"};
  for (int k = 0; k < 3; k++) {
    char line[64];
    snprintf(line, sizeof line, "G1 X%d F600\n%s", 20 + k, behind[k]);
    o = feed(line, 30);
    CHECK(!strcmp(o, "ok\r\n"));
    CHECK(!st_is_idle());
    o = feed("\x18", 2);
    char want[160];
    snprintf(want, sizeof want, "ALARM:3\r\n%s" BANNER LOCKED, replies[k]);
    CHECK(!strcmp(o, want));
    run("$X\nG90 G0 X0\nG4 P0\n");
    CHECK(st_is_idle() && plan_is_empty());
  }
  /* the reset while the probe line waits inside the parser (gc_execute_line's wait for rest):
     the wait gives the line up, its ok, then the banner; the probe never runs */
  int32_t at[3], z0;
  st_get_position(at);
  z0 = at[2];
  shell_poll_hook = reset_at_x5;
  o = feed("G1 X20 F600\nG38.2 Z-5 F100\n", 30);
  shell_poll_hook = NULL;
  CHECK(!strcmp(o, "ok\r\nALARM:3\r\nok\r\n" BANNER LOCKED));
  st_get_position(at);
  CHECK(at[2] == z0 && at[0] < (int32_t)lround(6.0 * plan_machine()->steps_per_mm[0]));
  CHECK(st_is_idle() && plan_is_empty());
  run("$X\nG90 G0 X0\nG4 P0\n");
  /* dwells of no time (a sender's sync) one after another: the machine still moves after them */
  o = run("G4 P0\nG4 P0\nG4 P0\nG4 P0\nG4 P0\nG4 P0\nG0 X1\nG4 P0\n");
  CHECK(count_of(o, "ok\r\n") == 8);
  st_get_position(at);
  CHECK(at[0] == (int32_t)lround(plan_machine()->steps_per_mm[0]));
  run("G0 X0\nG4 P0\n");
  /* a line waiting for a planner slot (GRBL's line in hand, waiting in mc_line): answered at
     the reset, its error if it has one, and nothing after it runs */
  for (int bad = 0; bad < 2; bad++) {
    shell_out_clear();
    int sent = 0;
    while (plan_free_slots() > 0 && sent < 3 * PLAN_BUFFER_SIZE) {
      feed(sent % 2 ? "G1X0\n" : "G1X10F600\n", 2);
      sent++;
    }
    CHECK(plan_free_slots() == 0);
    o = feed(bad ? "G1Q1\nG1X5\n" : "G1X5\nG1X6\n", 4);
    CHECK(!strcmp(o, ""));
    o = feed("\x18", 2);
    CHECK(!strcmp(o, bad ? "ALARM:3\r\nerror:20\r\n" BANNER LOCKED : "ALARM:3\r\nok\r\n" BANNER LOCKED));
    CHECK(st_is_idle() && plan_is_empty() && serial_rx_count() == 0);
    run("$X\nG90 G0 X0\nG4 P0\n");
  }
}

/* Hard limits ($21=1): a switch at X 5 mm (tests/vectors/grbl/hard_limits.json). */
static void test_hard_limits(void) {
  run("G90 G0 X0\nG4 P0\n");
  switch_x = (int32_t)lround(5.0 * plan_machine()->steps_per_mm[0]);
  switch_seen = hal_limits_read();
  CHECK(switch_seen == 0);
  run("$21=1\n");
  /* a cut into the switch: GRBL's critical alarm, the beam off, nothing read until a reset */
  const char *o = feed("G1 X10 F600 S500 M3\n", 20000);
  CHECK(!strcmp(o, "ok\r\nALARM:1\r\n[MSG:Reset to continue]\r\n"));
  CHECK(protocol_state() == PROTO_ALARM);
  CHECK(laser_current_duty() == 0 && st_is_idle() && plan_is_empty());
  int32_t at[3];
  st_get_position(at);
  CHECK(at[0] >= switch_x && at[0] < switch_x + 200);   /* stopped within a pass of the switch */
  o = feed("?G0 X0\n", 20);
  CHECK(!strcmp(o, ""));
  o = feed("?\x18", 2);                     /* the switch is still pressed: GRBL's check at reset;
                                               a '?' of the critical wait is never answered */
  CHECK(!strcmp(o, BANNER "[MSG:Check Limits]\r\n" LOCKED));
  o = feed("$X\n", 2);
  CHECK_HAS(o, "[MSG:Caution: Unlocked]");
  /* moving off the switch releases it: a change of the pin, an alarm too */
  o = feed("G0 X4\n", 20000);
  CHECK(!strcmp(o, "ok\r\nALARM:1\r\n[MSG:Reset to continue]\r\n"));
  o = feed("\x18", 2);
  CHECK(!strcmp(o, BANNER LOCKED));
  /* a G4 waiting for the move when the switch trips: its ok comes with the reset */
  run("$X\n$21=0\nG0 X0\nG4 P0\n$21=1\n");
  o = feed("G1 X10 F600\nG4 P0\n", 20000);
  CHECK(!strcmp(o, "ok\r\nALARM:1\r\n[MSG:Reset to continue]\r\n"));
  o = feed("\x18", 2);
  CHECK(!strcmp(o, "ok\r\n" BANNER "[MSG:Check Limits]\r\n" LOCKED));
  /* a jog into it; with $21=0 nothing trips */
  run("$X\n$21=0\nG0 X0\nG4 P0\n$21=1\n");
  o = feed("$J=G91 X10 F600\n", 20000);
  CHECK(!strcmp(o, "ok\r\nALARM:1\r\n[MSG:Reset to continue]\r\n"));
  feed("\x18", 2);
  run("$X\n$21=0\nG0 X0\nG4 P0\n");
  o = feed("G1 X10 F600\nG0 X0\nG4 P0\n", 40000);
  CHECK(!strcmp(o, "ok\r\nok\r\nok\r\n"));
  CHECK(protocol_state() == PROTO_IDLE);
  switch_x = INT32_MAX;
  switch_seen = 0;
}

/* A start-up line that is a jog, as GRBL takes it (tests/vectors/grbl/startup_jog.json), and
   G-code during a jog. */
static void test_startup_jog(void) {
  run("G90 G0 X0\nG4 P0\n");
  const double spm = plan_machine()->steps_per_mm[0];
  const char *o = feed("$N0=$J=G91X5F600\n", 0);
  CHECK(!strcmp(o, ""));                    /* GRBL writes its EEPROM once the jog has ended */
  CHECK(protocol_state() == PROTO_JOG);

  o = run("");
  CHECK(!strcmp(o, "ok\r\n"));
  int32_t at[3];
  st_get_position(at);
  CHECK(at[0] == (int32_t)lround(5.0 * spm));
  o = run("$N\n");
  CHECK_HAS(o, "$N0=$J=G91X5F600\r\n");
  o = run("\x18");                          /* run after the banner, as a jog */
  CHECK(!strcmp(o, BANNER ">$J=G91X5F600:ok\r\n"));
  st_get_position(at);
  CHECK(at[0] == 2 * (int32_t)lround(5.0 * spm));
  CHECK(!strcmp(run("$N1=$J=X1\n"), "error:22\r\n"));
  CHECK(!strcmp(run("$N1=$J\n"), "error:1\r\n"));   /* too short for GRBL's jog parser */
  CHECK(!strcmp(run("$N1=$X\n"), "error:1\r\n"));
  CHECK(!strcmp(run("$N0=\n"), "ok\r\n"));
  o = feed("$J=G91X-5F600\nG0X0\n$N0=\n", 0);  /* G-code during a jog: GRBL's error 9 */
  CHECK(!strcmp(o, "ok\r\nerror:9\r\nerror:8\r\n"));
  run("");
  CHECK(protocol_state() == PROTO_IDLE);
}

/* GRBL sends Ov: in at least one report of ten at rest: ask until it comes. */
static const char *status_with_ov(void) {
  const char *o = run("?");
  for (int i = 0; i < 11 && !strstr(o, "|Ov:"); i++)
    o = run("?");
  return o;
}

static void test_overrides(void) {
  const char *o = status_with_ov();
  CHECK_HAS(o, "|Ov:100,100,100>");
  o = run("\x91\x91\x93?");               /* feed +10 +10 +1 */
  CHECK_HAS(o, "|Ov:121,100,100>");
  o = run("\x96?");                        /* rapid 50 % */
  CHECK_HAS(o, "|Ov:121,50,100>");
  for (int i = 0; i < 25; i++) run("\x9B"); /* laser power -10 % each: stops at 10 % */
  o = run("\x92?");
  CHECK_HAS(o, "|Ov:111,50,10>");
  for (int i = 0; i < 25; i++) run("\x91"); /* feed stops at 200 % */
  o = status_with_ov();
  CHECK_HAS(o, "|Ov:200,50,10>");
  o = run("\x90\x95\x99?");               /* each back to 100 % */
  CHECK_HAS(o, "|Ov:100,100,100>");
  o = run("\x91\x97\x9A\x18");            /* a reset restores every override */
  o = status_with_ov();
  CHECK_HAS(o, "|Ov:100,100,100>");

  /* what they do (GRBL dialect): a 600 mm/min cut at 100 %, then with feed 50 % and power 50 % */
  double feed100, feed50;
  uint16_t duty100, duty50;
  run("G90 G0 X0\n");
  run_sampled("G1 X20 F600 S300 M3\n", &feed100, &duty100);
  CHECK(feed100 > 595.0 && feed100 < 605.0);
  run("\x92\x92\x92\x92\x92\x9B\x9B\x9B\x9B\x9B");
  run_sampled("G1 X0 F600 S300 M3\n", &feed50, &duty50);
  CHECK(feed50 > 297.0 && feed50 < 303.0);
  CHECK(duty50 > 0 && (duty50 == duty100 / 2 || duty50 == (duty100 + 1) / 2));
  CHECK(laser_current_duty() == 0);
  /* M4: the power follows the speed against the programmed feed, so at 50 %
     feed it halves as well (the energy per millimetre is kept) */
  run("\x99");
  uint16_t duty_m4;
  run_sampled("G1 X20 F600 S300 M4\n", &feed50, &duty_m4);
  CHECK(duty_m4 == duty50);
  run("\x90\x99");
}

int main(int argc, char **argv) {
  (void)argc; (void)argv;
  test_line_asm();

  shell_storage_clear();
  shell_out_clear();
  protocol_startup();
  const char *o = shell_out();
  CHECK_HAS(o, "\r\nGrbl 1.1h ['$' for help]\r\n");   /* the grbl dialect by default: GRBL's banner */
  CHECK_NOT(o, "labkit-fw");
  CHECK_HAS(o, "[MSG:settings restored]");        /* empty storage */
  o = run("$208=0\n");                            /* labkit-fw: its banner says so */
  CHECK(!strcmp(o, "ok\r\n"));
  o = run("\x18");
  CHECK_HAS(o, "\r\nlabkit-fw " LK_FW_VERSION " ['$' for help] [dialect:labkit-fw F mm/s");
  CHECK_NOT(o, "Grbl");

  /* labkit-fw replies */
  o = run("\n");
  CHECK(!strcmp(o, "ok\r\n"));
  o = run("G21 G90\n");
  CHECK(!strcmp(o, "ok\r\n"));
  o = run("G1 X1 F10 S100 M3\n");
  CHECK(!strcmp(o, "ok\r\n"));
  o = run("G1 Q5\n");
  CHECK_HAS(o, "er:");
  CHECK_NOT(o, "error:");
  o = run("G1 X2\r\n");                     /* "\r\n" is one line end in labkit-fw */
  CHECK(count_of(o, "ok") == 1);

  /* real-time bytes never enter a line */
  o = run("G0 X?3\n");
  CHECK_HAS(o, "<");
  CHECK_HAS(o, "|MPos:");
  CHECK_HAS(o, "|Bf:");
  CHECK_HAS(o, "|Ov:100,100,100>");
  CHECK_HAS(o, "ok\r\n");
  CHECK(serial_rx_count() == 0);

  /* over-long line: one error, nothing executed */
  char longline[400];
  memset(longline, 0, sizeof longline);
  strcpy(longline, "G0 X");
  memset(longline + 4, '1', 250);
  strcat(longline, "\n");
  o = run(longline);
  CHECK(!strcmp(o, "er:11\r\n"));

  /* $ commands */
  o = run("$I\n");
  CHECK_HAS(o, "[VER:1.1h");
  CHECK_HAS(o, ",128]");
  CHECK_HAS(o, "[OPT:VL,");
  o = run("$$\n");
  CHECK_HAS(o, "$32=1\r\n");
  CHECK_HAS(o, "$100=2133.333\r\n");
  CHECK_HAS(o, "$208=0\r\n");
  CHECK_HAS(o, "ok\r\n");
  o = run("$G\n");
  CHECK_HAS(o, "[GC:G");
  o = run("$\n");
  CHECK_HAS(o, "[HLP:");
  o = run("$FOO\n");
  CHECK(!strcmp(o, "er:2\r\n"));                /* GRBL's rule: not a setting number */

  /* GRBL dialect */
  o = run("$208=1\n");
  CHECK(!strcmp(o, "ok\r\n"));
  CHECK(gc_get_dialect() == GC_DIALECT_GRBL);
  o = run("G1 Q5\n");
  CHECK_HAS(o, "error:");
  o = run("G1 X3\r\n");                     /* GRBL: '\r' and '\n' each end a line */
  CHECK(count_of(o, "ok") == 2);
  o = run("\x18");
  CHECK_HAS(o, "\r\nGrbl 1.1h ['$' for help]\r\n");

  /* soft limit: a move out of the envelope raises ALARM:2 and locks */
  o = run("$X\n$20=1\n");
  CHECK_HAS(o, "error:10");                      /* GRBL: soft limits need homing */
  o = run("$22=1\n$20=1\nG90 G0 X5\n");          /* GRBL's machine space is -travel .. 0 */
  CHECK_HAS(o, "ok\r\nok\r\nALARM:2\r\n[MSG:Reset to continue]\r\n");   /* GRBL: no ok for the line */
  CHECK(protocol_state() == PROTO_ALARM);
  o = run("?G0 X1\n");                          /* GRBL's critical event: nothing until a reset */
  CHECK(!strcmp(o, ""));
  o = run("\x18");                               /* then the held ok, the banner, the lock */
  CHECK_HAS(o, "ok\r\n\r\nGrbl 1.1h ['$' for help]\r\n[MSG:'$H'|'$X' to unlock]\r\n");
  o = run("G0 X1\n");
  CHECK(!strcmp(o, "error:9\r\n"));
  o = run("?");
  CHECK_HAS(o, "<Alarm|");
  o = run("$X\n");
  CHECK_HAS(o, "[MSG:Caution: Unlocked]");
  CHECK_HAS(o, "ok");
  CHECK(protocol_state() == PROTO_IDLE);

  /* check mode: lines are checked, nothing is queued */
  o = run("$C\n");
  CHECK_HAS(o, "[MSG:Enabled]");
  o = run("G1 X10 F600\nG1 Q1\n");
  CHECK_HAS(o, "ok\r\n");
  CHECK_HAS(o, "error:20");
  o = run("?");
  CHECK_HAS(o, "<Check|");
  o = run("$C\n");
  CHECK_HAS(o, "[MSG:Disabled]");
  CHECK_HAS(o, "Grbl 1.1h");
  CHECK(protocol_state() == PROTO_IDLE);

  /* jog: errors by name */
  o = run("$J=G91 X1\n");
  CHECK(!strcmp(o, "error:22\r\n"));
  o = run("$J=G91 M3 X1 F100\n");
  CHECK(!strcmp(o, "error:16\r\n"));
  o = run("$J=G90 X1 F100\n");
  CHECK(!strcmp(o, "error:15\r\n"));             /* GRBL: a jog past the travel is refused */
  run("$20=0\n");                                 /* the moves below run in positive X */

  /* emergency stop input (the board's pin, the simulator's panel channel);
     its byte on the serial line is dropped like every byte above 0x7F
     that is not a real-time command */
  o = run("\xB8\xB2\xB0\xFF\n");
  CHECK(!strcmp(o, "ok\r\n"));
  CHECK(protocol_state() == PROTO_IDLE);
  o = run("G4 P1\xC2\xB2\n");
  CHECK(!strcmp(o, "ok\r\n"));
  shell_out_clear();
  protocol_estop();
  o = run("");
  CHECK_HAS(o, "[MSG:E-stop]");
  CHECK_HAS(o, "ALARM:3");
  o = run("$X\n");
  CHECK_HAS(o, "ok");

  /* feed hold mid-move: decelerates, beam off, Hold:0; resume finishes the move */
  {
    const char *line = "G90 G1 X5 F600 S500 M3\n";
    shell_out_clear();
    for (const char *p = line; *p; p++)
      serial_rx_isr((uint8_t)*p);
    for (int i = 0; i < 20; i++) protocol_poll();
    shell_advance_ms(100);                    /* quiet: the look-ahead is flushed */
    for (int i = 0; i < 24; i++) protocol_poll();
    CHECK(st_state() == ST_RUN);
    CHECK(laser_current_duty() > 0);
    serial_rx_isr('!');
    for (int i = 0; i < 100000 && st_state() != ST_HELD; i++) protocol_poll();
    CHECK(st_state() == ST_HELD || (st_state() == ST_IDLE && protocol_hold_requested()));
    o = run("$J=G91 X1 F100\n");            /* GRBL reads no line during a hold ... */
    CHECK(!strcmp(o, ""));
    CHECK(laser_current_duty() == 0);
    float mm[3];
    st_get_position_mm(mm);
    CHECK(mm[0] > 0.1f && mm[0] < 4.9f);
    o = run("?");
    CHECK_HAS(o, "<Hold:0|");
    o = run("~");
    CHECK_HAS(o, "[MSG:Restoring spindle]");
    CHECK_HAS(o, "error:8\r\n");             /* ... and refuses a jog while the job runs */
    st_get_position_mm(mm);
    CHECK(mm[0] > 4.9995f && mm[0] < 5.0005f);
    CHECK(st_is_idle());
    CHECK(laser_current_duty() == 0);
    o = run("?");
    CHECK_HAS(o, "<Idle|MPos:5.000,");
  }

  test_probe();

  test_overrides();

  test_reset_while_waiting();
  test_hard_limits();
  test_startup_jog();

  /* $RST=* restores the defaults (dialect included): GRBL's message, ok, then the reset */
  run("$208=0\n");
  o = run("$RST=*\n");
  CHECK_HAS(o, "[MSG:Restoring defaults]\r\nok\r\n\r\nGrbl 1.1h ['$' for help]\r\n");
  CHECK(gc_get_dialect() == GC_DIALECT_GRBL);

  TEST_DONE("test_protocol");
}
