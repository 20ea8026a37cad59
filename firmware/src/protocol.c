/*
  protocol.c - line assembly, `$` commands and the four state machines of
  the main loop (see protocol.h).
*/
#include "protocol.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "gcode.h"
#include "homing.h"
#include "hal.h"
#include "laser.h"
#include "limits.h"
#include "menu.h"
#include "planner.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "status_codes.h"
#include "stepper.h"

/* Quiet time on the RX line after which the look-ahead is flushed (the
   stream has ended or paused: the held-back blocks must run). */
#define FLUSH_QUIET_MS 30u

/* A $ command that has written its whole reply itself. */
#define REPLY_DONE 0xFFu

volatile uint8_t protocol_events;

static line_asm_t rx_line;
static char pending[LINE_BUFFER_SIZE];
static uint8_t have_pending;
static uint8_t state = PROTO_IDLE;
static uint8_t jog_cancel;
static uint8_t flushed = 1;
static uint32_t last_rx_ms;
static uint8_t empty_slots;
/* A feed hold the host asked for. st_feed_hold() only acts on a running
   stepper; when the stepper is momentarily idle with blocks queued (starved,
   or waiting for look-ahead) the runner must not start it again until '~'. */
static uint8_t hold_req;
/* M0 (grbl dialect): its ok waits for the cycle start '~' and no line is read
   meanwhile; once the moves before it have ended the machine reports Hold:0. */
static uint8_t program_pause;

/* GRBL answers a line that synchronises (G4, M2/M30, an offset or EEPROM
   write) only when every move before it has ended; no line is read meanwhile. */
static uint8_t sync_ok;

/* A line's ok is owed (grbl dialect): it comes when the line's wait ends (sync_ok: the moves
   before it have ended; M0: '~') or, at the latest, at the reset that cuts the wait short,
   after the reset's ALARM:3 and before its banner, as GRBL answers a line whose wait a reset
   ended. Also the line that hit a soft limit and a line a hard limit caught waiting: their
   ok comes with the reset. */
static uint8_t ok_owed;

/* The main loop's work runs inside a line's wait in gc_execute_line (a probe line waiting for
   rest, the second block of a G28/G30): there a reset stops the motion at once and is
   finished (banner, start-up lines) only after the line's reply, as GRBL's is. */
static uint8_t in_wait;
static uint8_t reset_pending;

/* GRBL ends a program (M2, M30) once the moves before it have ended, or a reset has cut them
   short: the modal state resets, the overrides go back to 100 % and "[MSG:Pgm End]" comes
   before the line's ok. */
static uint8_t program_end;

static void end_program(void) {
  if (!program_end)
    return;
  program_end = 0;
  gc_end_program();               /* its new WCO shows in the next report, */
  report_overrides_next();        /* and its laser and coolant stop force Ov: after it */
  plan_set_overrides(100, 100);
  laser_set_override(100);
  report_feedback(MSG_PROGRAM_END);
}

uint8_t protocol_program_paused(void) { return program_pause; }

/* A G38.x probe move (grbl dialect): 2..5 while it runs (its ok waits with
   sync_ok), and whether and where the probe switched. The step interrupt reads
   the input after every tick (st_probe_arm) and keeps the position of the
   touch; the main loop then stops the head within one pass. */
static uint8_t probe_cycle;
static uint8_t was_held;          /* the last pass saw a hold that had stopped the head */
static uint8_t probe_hit;
static double probe_hit_mm[3];

/* G38.4 / G38.5 move until the probe stops touching. */
static uint8_t probe_reached(uint8_t kind) { return limits_probe_touching() != (kind >= 4); }

/* GRBL's critical events (a soft or hard limit, grbl dialect): after "ALARM:2" or "ALARM:1"
   and "[MSG:Reset to continue]" nothing is read or reported until a reset; a line that was
   waiting (the one that hit the soft limit, one a hard limit caught) gets its ok then. */
static uint8_t critical;

static void critical_alarm(uint8_t alarm) {
  protocol_alarm(alarm);
  if (settings.dialect == GC_DIALECT_GRBL) {
    report_feedback(MSG_RESET_TO_CONTINUE);
    critical = 1;
  }
}

/* Hard limits ($21=1): the hal's limit pin-change interrupt (protocol_limit_pin_change) stops
   the step timer and the beam at once and leaves the rest to the main loop (ALARM:1). */
static volatile uint8_t limit_tripped;

uint8_t protocol_hold_requested(void) { return hold_req; }

uint8_t protocol_state(void) { return state; }
uint8_t protocol_planner_blocks(void) { return empty_slots; }

/* ---------------------------------------------------------------- lines */

void line_asm_reset(line_asm_t *a) {
  uint8_t crlf = a->crlf_one, grbl = a->grbl;
  memset(a, 0, sizeof *a);
  a->crlf_one = crlf;
  a->grbl = grbl;
}

void line_asm_set_dialect(line_asm_t *a, uint8_t dialect) {
  a->crlf_one = dialect == GC_DIALECT_LABKIT;
  a->grbl = dialect == GC_DIALECT_GRBL;
}

static int line_end(line_asm_t *a) {
  int st = STATUS_OK;
  if (a->overflow)
    st = STATUS_LINE_OVERFLOW;
  else if (a->bad || (a->paren && !a->grbl))   /* GRBL: a comment ends with its line */
    st = STATUS_BAD_DELIMITER;
  else if (a->star && (a->ck_digits == 0 || a->ck > 255 || a->ck != a->xor_raw))
    st = STATUS_BAD_CHECKSUM;
  a->buf[st == STATUS_OK ? a->len : 0] = 0;
  uint8_t crlf = a->crlf_one;
  a->len = a->raw = 0;
  a->paren = a->semi = a->star = a->sys = a->overflow = a->bad = 0;
  a->xor_raw = 0;
  a->ck = 0;
  a->ck_digits = 0;
  a->crlf_one = crlf;
  return st;
}

int line_asm_push(line_asm_t *a, uint8_t c) {
  if (c == '\n' && a->after_cr) {
    a->after_cr = 0;
    if (a->crlf_one && a->raw == 0)
      return -1;           /* the '\n' of "\r\n" */
  }
  if (c == '\r' || c == '\n') {
    int st = line_end(a);
    a->after_cr = c == '\r';
    return st;
  }
  a->after_cr = 0;
  if (a->raw < 0xFFFFu)
    a->raw++;
  if (a->semi)
    return -1;
  if (a->star) {           /* checksum digits; spaces allowed after them */
    if (c >= '0' && c <= '9' && a->ck_digits < 4) {
      a->ck = (uint16_t)(a->ck * 10u + (c - '0'));
      a->ck_digits++;
    } else if (c != ' ' && c != '\t') {
      if (c == ';')
        a->semi = 1;
      else
        a->bad = 1;        /* anything else after the checksum: reject */
    }
    return -1;
  }
  if (a->paren) {
    if (c == ')')
      a->paren = 0;
    a->xor_raw ^= c;
    return -1;
  }
  if (c == '*' && !a->sys && !a->grbl) {   /* GRBL has no checksums: '*' is a character */
    a->star = 1;
    return -1;
  }
  a->xor_raw ^= c;
  if (c == '(') {
    a->paren = 1;
    return -1;
  }
  if (c == ';') {
    a->semi = 1;
    return -1;
  }
  if (c == ' ' || c == '\t')
    return -1;
  if (c == '/' && a->grbl)
    return -1;             /* GRBL ignores the block-delete character wherever it is */
  if (c == ')' || c < 0x20 || c > 0x7E) {
    a->bad = 1;
    return -1;
  }
  if (c >= 'a' && c <= 'z')
    c = (uint8_t)(c - 'a' + 'A');
  if (a->len == 0 && c == '$')
    a->sys = 1;
  if (a->len >= (a->grbl ? GRBL_LINE_MAX : LINE_BUFFER_SIZE - 1)) {
    a->overflow = 1;
    return -1;
  }
  a->buf[a->len++] = (char)c;
  return -1;
}

/* ------------------------------------------------------------- helpers */

static void sync_positions(void) {
  int32_t steps[3];
  st_get_position(steps);
  plan_sync_position(steps);
  gc_sync_position();
}

/* Stop everything now: motion, laser, queued blocks. Inside a line's wait the stepper's
   abort is left for that wait to take: it gives the line up (gc_execute_line). */
static void stop_all(void) {
  hold_req = 0;
  program_pause = 0;
  st_reset();
  laser_off();
  menu_focus_off();
  plan_reset();
  if (!in_wait)
    (void)st_take_abort();
  sync_positions();
}

void protocol_alarm(uint8_t alarm) {
  stop_all();
  /* what the host sent before the alarm never runs after it (GRBL resets and
     drops its input): a '$X' already in the ring would unlock the machine */
  serial_rx_flush();
  line_asm_reset(&rx_line);
  have_pending = 0;
  jog_cancel = 0;
  state = PROTO_ALARM;
  report_alarm(alarm);
}

void protocol_estop(void) {
  /* Any context: step timer and beam off now; the main loop then resets
     the stepper and planner (st_reset is main-loop only) and reports. */
  hal_timer_stop();
  laser_off();
  serial_rt_flags |= RT_ESTOP;
  protocol_events |= EV_SYSTEM;
}

void protocol_limit_pin_change(void) {
  /* GRBL's limit pin-change interrupt: any change, a press or a release, with hard limits on
     ($21=1), except in an alarm (the machine is stopped and locked already) or while homing
     (the cycle reads the switches itself, GRBL disables the interrupt for it) */
  if (!(settings.flags & SET_FLAG_HARD_LIMITS) || state == PROTO_ALARM || state == PROTO_HOME ||
      limit_tripped)
    return;
  hal_timer_stop();
  laser_off();
  limit_tripped = 1;
  protocol_events |= EV_SYSTEM;
}

/* The soft-limit envelope in machine coordinates: GRBL's machine space is
   -$13x .. 0 (homing sets 0 at the switch end, whichever side $23 homes to);
   labkit-fw's is 0 .. travel. */
static uint8_t outside_envelope(const double mm[3]) {
  const lk_machine_t *m = plan_machine();
  uint8_t grbl = settings.dialect == GC_DIALECT_GRBL;
  for (int i = 0; i < 3; i++) {
    double lo = grbl ? -m->travel_mm[i] : 0.0, hi = grbl ? 0.0 : m->travel_mm[i];
    if (mm[i] < lo - 1e-6 || mm[i] > hi + 1e-6)
      return 1;
  }
  return 0;
}

static uint8_t jog(const char *p);
static void startup_checks(void);

/* A start-up line as GRBL runs it: its G-code parser takes a line that begins with '$' for a
   jog and reads it from the fourth character on ("$J=G91X1F100": G91X1F100), whatever the
   two before; a shorter one is error 1 there (the parser reads the '=' or a digit of "$Nn="
   that GRBL's line buffer still holds past the shifted line's end). */
static uint8_t startup_line_execute(char *line) {
  if (line[0] != '$')
    return gc_execute_line(line);
  return strlen(line) < 3 ? STATUS_EXPECTED_LETTER : jog(line + 3);
}

/* GRBL runs the $N lines after a reset into Idle (never into an alarm) and
   echoes each with its verdict: ">G20G91:ok". */
static void run_startup_lines(void) {
  for (uint8_t i = 0; i < SET_N_STARTUP; i++) {
    if (!settings.startup[i][0])
      continue;
    char line[LINE_BUFFER_SIZE];
    strcpy(line, settings.startup[i]);
    uint8_t st = startup_line_execute(line);
    serial_putc('>');
    serial_write(settings.startup[i]);
    serial_putc(':');
    report_status_message(st);
    protocol_events |= EV_RUNNER;
  }
}

/* Does a reset now cut a motion short (GRBL's ALARM:3)? Not in a finished hold (no position
   is lost), nor in a dwell of the grbl dialect: GRBL dwells with its planner empty, in Idle. */
static uint8_t reset_cuts_motion(void) {
  if (st_state() == ST_HELD || (hold_req && st_is_idle()))
    return 0;
  if (settings.dialect == GC_DIALECT_GRBL && st_state() == ST_DWELL)
    return 0;
  return !st_is_idle() || !plan_is_empty();
}

/* The line GRBL would hold in its hands (grbl dialect): a G-code line that waits only for a
   free planner slot. GRBL's parser has checked it and waits in mc_line for the slot; a reset
   or a hard limit ends that wait, and the line is answered then. */
static uint8_t pending_in_hand(void) {
  return have_pending && !in_wait && settings.dialect == GC_DIALECT_GRBL && pending[0] != '$' &&
         (state == PROTO_IDLE || state == PROTO_CHECK) && !sync_ok && !program_pause && !critical;
}

/* That line's verdict, taken on the stopped machine (GRBL's parser checked it before its wait;
   what it queues never runs). */
static uint8_t pending_verdict(char *line) {
  have_pending = 0;
  uint8_t st = gc_execute_line(line);
  stop_all();
  return st;
}

/* The first half of a reset (GRBL's mc_reset and what its main loop reports before the line
   in hand is answered): ALARM:3 when a motion is cut short, motion and beam stopped at once,
   the input dropped. The line waiting for a planner slot is answered now. */
static uint8_t reset_was_moving;

static void reset_stop(void) {
  reset_was_moving = reset_cuts_motion();
  if (reset_was_moving)
    report_alarm(ALARM_ABORT_CYCLE);
  char held[LINE_BUFFER_SIZE];
  uint8_t in_hand = pending_in_hand();
  if (in_hand)
    memcpy(held, pending, LINE_BUFFER_SIZE);
  probe_cycle = 0;
  st_probe_disarm();
  stop_all();
  serial_rx_flush();
  line_asm_reset(&rx_line);
  have_pending = 0;
  if (in_hand) {
    ok_owed = 0;
    report_status_message(pending_verdict(held));
  }
}

/* The second half: the reply still owed (GRBL: the line whose wait the reset ended, M0, a
   soft limit's line), then a fresh machine, the banner and the start-up lines. */
static void reset_finish(void) {
  uint8_t was_moving = reset_was_moving;
  reset_pending = 0;
  end_program();
  if (ok_owed)
    report_status_message(STATUS_OK);
  ok_owed = 0;
  sync_ok = 0;
  critical = 0;
  limit_tripped = 0;
  stop_all();
  serial_rx_flush();
  line_asm_reset(&rx_line);
  have_pending = 0;
  jog_cancel = 0;
  serial_overrides_t dropped;
  serial_take_overrides(&dropped);
  plan_set_overrides(100, 100);   /* GRBL: a reset restores every override */
  double origin[3] = {0.0, 0.0, 0.0};
  limits_set_probe_result(origin, 0);   /* GRBL: a reset clears the probe position */
  laser_set_override(100);
  gc_init();
  (void)settings_apply();
  line_asm_set_dialect(&rx_line, settings.dialect);
  sync_positions();
  state = was_moving || state == PROTO_ALARM || state == PROTO_SLEEP ? PROTO_ALARM : PROTO_IDLE;
  flushed = 1;
  report_banner();
  startup_checks();
}

static void soft_reset(void) {
  reset_stop();
  reset_finish();
}

/* ------------------------------------------------------- $ commands */

uint8_t protocol_jog(const char *words);

/* $J=...: a straight move with the beam off, planned directly; the parser's
   modal state is not touched. Words: G20 G21 G90 G91 G53 X Y Z F. */
static uint8_t jog(const char *p) {
  const gc_state_t *g = gc_state();
  uint8_t inches = g->inches, absolute = g->absolute, have_f = 0, have_axis = 0, machine = 0;
  uint8_t invalid = 0;          /* a word a jog cannot take: GRBL says so after the F check */
  double target[3], f = 0, v;
  uint8_t seen[3] = {0, 0, 0};
  for (int i = 0; i < 3; i++)
    target[i] = g->pos_mm[i];
  double word[3] = {0, 0, 0};
  while (*p) {
    char letter = *p++;
    uint8_t k = settings_read_number(p, &v);
    if (!k)
      return letter >= 'A' && letter <= 'Z' ? STATUS_BAD_NUMBER : STATUS_EXPECTED_LETTER;
    p += k;
    if (letter == 'G') {
      if (v == 20) inches = 1;
      else if (v == 21) inches = 0;
      else if (v == 90) absolute = 1;
      else if (v == 91) absolute = 0;
      else if (v == 53) machine = 1;
      else invalid = 1;
    } else if (letter == 'F') {
      if (have_f) return STATUS_REPEATED_WORD;
      if (v <= 0) return STATUS_NEGATIVE_VALUE;
      f = v;
      have_f = 1;
    } else if (letter >= 'X' && letter <= 'Z') {
      int ax = letter - 'X';
      if (seen[ax]) return STATUS_REPEATED_WORD;
      seen[ax] = 1;
      word[ax] = v;
      have_axis = 1;
    } else {
      invalid = 1;
    }
  }
  if (!have_f)
    return STATUS_UNDEFINED_FEED;
  if (invalid)
    return STATUS_INVALID_JOG;
  if (!have_axis)
    return STATUS_MISSING_AXIS_WORDS;
  double unit = inches ? 25.4 : 1.0, wco[3];
  gc_wco(wco);
  for (int i = 0; i < 3; i++)
    if (seen[i])
      target[i] = machine ? word[i] * unit
                  : absolute ? word[i] * unit + wco[i] : target[i] + word[i] * unit;
  if (settings.soft_limits && outside_envelope(target))
    return settings.dialect == GC_DIALECT_GRBL ? STATUS_TRAVEL_EXCEEDED : STATUS_OUT_OF_BOUNDS;
  double feed_mm_min = f * unit * (gc_get_dialect() == GC_DIALECT_LABKIT ? 60.0 : 1.0);
  plan_move_t mv;
  plan_block_t b;
  memset(&mv, 0, sizeof mv);
  mv.kind = PLAN_MOVE_LINE;
  for (int i = 0; i < 3; i++) {
    mv.start_mm[i] = g->pos_mm[i];
    mv.end_mm[i] = target[i];
  }
  mv.feed_mm_min = feed_mm_min;
  mv.line = g->line;
  uint8_t st = plan_prepare_move(&mv, &b);
  if (st != STATUS_OK)
    return st;
  if (b.ticks) {
    plan_push_block(&b);
    plan_flush();
    state = PROTO_JOG;
  }
  return STATUS_OK;
}

uint8_t protocol_jog(const char *words) {
  if (state == PROTO_ALARM)
    return STATUS_GCODE_LOCKED;
  if (state == PROTO_CHECK || !plan_is_empty() || (state != PROTO_JOG && !st_is_idle()))
    return STATUS_UNSUPPORTED_COMMAND;   /* the panel jogs an idle machine only */
  return jog(words);
}

/* The reply of a $ command that ends in a reset: message, ok, then the
   reset's banner (GRBL's order). */
static uint8_t answer_then_reset(const char *msg) {
  report_feedback(msg);
  report_status_message(STATUS_OK);
  if (state == PROTO_CHECK || state == PROTO_SLEEP)
    state = PROTO_IDLE;
  soft_reset();
  return REPLY_DONE;
}

/* $Nx=line: GRBL checks (and runs) the line before keeping it. */
static uint8_t store_startup_line(const char *p) {
  double index;
  uint8_t k = settings_read_number(p, &index);
  if (!k)
    return STATUS_BAD_NUMBER;
  if (p[k] != '=')
    return STATUS_INVALID_STATEMENT;
  char text[LINE_BUFFER_SIZE];
  strncpy(text, p + k + 1, sizeof text - 1);
  text[sizeof text - 1] = 0;
  if (strlen(text) + 1 > SET_LINE_SIZE)
    return STATUS_LINE_OVERFLOW;
  if (text[0]) {
    char run[LINE_BUFFER_SIZE];
    strcpy(run, text);
    uint8_t st = startup_line_execute(run);   /* a jog moves now, as GRBL's does */
    if (st != STATUS_OK)
      return st;
  }
  /* GRBL writes its EEPROM only once the moves have ended (FORCE_BUFFER_SYNC_DURING_EEPROM_WRITE):
     after a start-up jog the ok comes when the jog has ended */
  uint8_t after_jog = state == PROTO_JOG && settings.dialect == GC_DIALECT_GRBL;
  /* GRBL accepts (and loses) a higher or a negative index; compared as a double, since a
     cast of a negative or huge one to an unsigned integer is undefined */
  double n = trunc(index);
  if (n >= 0.0 && n < SET_N_STARTUP) {
    strcpy(settings.startup[(unsigned)n], text);
    settings_store();
  } else if (n == SET_N_STARTUP && settings.dialect == GC_DIALECT_GRBL) {
    /* GRBL 1.1h writes a third start-up line over its $I= text, which then fails its
       checksum and reads empty (tests/vectors/grbl/dollar_commands.json, $N2= then $I) */
    settings.build_info[0] = 0;
    settings_store();
  }
  if (after_jog) {
    sync_ok = 1;
    ok_owed = 1;
    return REPLY_DONE;
  }
  return STATUS_OK;
}

/* $H: GRBL's homing cycle (homing.c). Done: the start-up lines run, then the ok; a '?' that
   came during the cycle is answered first, still in Home. A failure or a reset during the
   cycle: its ALARM, the ok, and the reset GRBL then makes (banner, locked in Alarm). */
static uint8_t home(void) {
  state = PROTO_HOME;
  menu_focus_off();
  laser_off();
  uint8_t alarm = homing_cycle();
  (void)st_take_abort();
  if (serial_take_flags(RT_STATUS))
    report_status_report();
  if (alarm != HOMING_OK) {
    (void)serial_take_flags(RT_RESET);
    state = PROTO_ALARM;
    report_alarm(alarm);
    report_status_message(STATUS_OK);
    soft_reset();
    return REPLY_DONE;
  }
  state = PROTO_IDLE;
  sync_positions();
  run_startup_lines();
  return STATUS_OK;
}

static uint8_t system_command(char *line) {
  char *p = line + 1;           /* after '$' */
  /* GRBL's cycle: moves queued or running (labkit-fw waits for idle before a $ line) */
  uint8_t cycle = state == PROTO_IDLE &&
                  (!plan_is_empty() || !st_is_idle() || hold_req || program_pause || sync_ok);
  switch (p[0]) {
  case 0:
    report_help();
    return STATUS_OK;
  case 'J':
    if (state == PROTO_ALARM)
      return STATUS_GCODE_LOCKED;
    if (p[1] != '=')
      return STATUS_INVALID_STATEMENT;
    if (state == PROTO_CHECK)
      return STATUS_OK;
    if (state != PROTO_JOG && (!plan_is_empty() || !st_is_idle()))
      return STATUS_NOT_IDLE;
    return jog(p + 2);
  case '$': case 'G': case 'C': case 'X':
    if (p[1] != 0)
      return STATUS_INVALID_STATEMENT;
    if (p[0] == '$') {
      if (cycle)
        return STATUS_NOT_IDLE;          /* GRBL: too long to print during a cycle */
      settings_report();
    } else if (p[0] == 'G') {
      report_gcode_modes();
    } else if (p[0] == 'C') {
      if (state == PROTO_CHECK)
        return answer_then_reset(MSG_DISABLED);   /* GRBL: leaving check mode resets */
      if (state != PROTO_IDLE || cycle)
        return STATUS_NOT_IDLE;
      state = PROTO_CHECK;
      report_feedback(MSG_ENABLED);
    } else if (state == PROTO_ALARM) {
      report_feedback(MSG_ALARM_UNLOCK);
      state = PROTO_IDLE;
    }
    return STATUS_OK;
  default:
    break;
  }
  if (!strcmp(p, "LCD")) {
    menu_report_lcd();
    return STATUS_OK;
  }
  /* the rest need an idle machine or an alarm (GRBL: EEPROM and homing) */
  if ((state != PROTO_IDLE && state != PROTO_ALARM) || cycle)
    return STATUS_NOT_IDLE;
  switch (p[0]) {
  case '#':
    if (p[1] != 0)
      return STATUS_INVALID_STATEMENT;
    report_offsets();
    return STATUS_OK;
  case 'H':
    if (!(settings.flags & SET_FLAG_HOMING))
      return STATUS_SETTING_DISABLED;     /* $22=0 */
    if (p[1] != 0)
      return STATUS_INVALID_STATEMENT;
    return home();
  case 'S':
    if (strcmp(p, "SLP"))
      return STATUS_INVALID_STATEMENT;
    stop_all();
    state = PROTO_SLEEP;
    report_status_message(STATUS_OK);
    report_feedback(MSG_SLEEPING);
    return REPLY_DONE;
  case 'I':
    if (p[1] == 0) {
      report_build_info();
      return STATUS_OK;
    }
    if (p[1] != '=')
      return STATUS_INVALID_STATEMENT;
    strncpy(settings.build_info, p + 2, SET_LINE_SIZE - 1);
    settings.build_info[SET_LINE_SIZE - 1] = 0;
    settings_store();
    return STATUS_OK;
  case 'R': {
    if (strncmp(p, "RST=", 4) || !p[4] || p[5])
      return STATUS_INVALID_STATEMENT;
    uint8_t st = settings_restore(p[4]);
    line_asm_set_dialect(&rx_line, settings.dialect);
    if (st != STATUS_OK)
      return st;
    gc_load_offsets();
    return answer_then_reset(MSG_RESTORING_DEFAULTS);
  }
  case 'N':
    if (p[1] == 0) {
      for (uint8_t i = 0; i < SET_N_STARTUP; i++) {
        serial_write("$N");
        report_uint(i);
        serial_putc('=');
        serial_write(settings.startup[i]);
        serial_write("\r\n");
      }
      return STATUS_OK;
    }
    if (state != PROTO_IDLE || cycle)
      return STATUS_NOT_IDLE;
    return store_startup_line(p + 1);
  default: {
    uint8_t st = settings_store_setting(p);
    line_asm_set_dialect(&rx_line, settings.dialect);
    return st;
  }
  }
}

static void steps_to_mm(const int32_t steps[3], double mm[3]) {
  for (int a = 0; a < 3; a++)
    mm[a] = (double)steps[a] / plan_machine()->steps_per_mm[a];
}

static void machine_position_mm(double mm[3]) {
  int32_t steps[3];
  st_get_position(steps);
  steps_to_mm(steps, mm);
}

/* GRBL's probe cycle: a probe already where the move should take it is
   ALARM:4 and nothing moves; else the move runs and its ok waits for the end
   (finish_probe). The machine was idle before the line (needs_idle). */
static void start_probe(uint8_t kind) {
  if (probe_reached(kind)) {
    stop_all();                   /* the queued probe move never runs */
    state = PROTO_ALARM;
    report_alarm(ALARM_PROBE_FAIL_INITIAL);
    report_status_message(STATUS_OK);
    return;
  }
  probe_cycle = kind;
  probe_hit = 0;
  st_probe_arm(limits_probe_pin_at(kind < 4));   /* G38.4 / G38.5 wait for the touch to end */
  plan_flush();
  sync_ok = 1;
  ok_owed = 1;
}

/* The probe move has ended (touched and stopped, or run out): GRBL's alarm
   for G38.2 / G38.4 without a touch, then [PRB:...]; the ok follows. */
static void finish_probe(void) {
  double mm[3];
  uint8_t touched;
  if (probe_hit) {
    limits_set_probe_result(probe_hit_mm, 1);
  } else if (probe_cycle == 3 || probe_cycle == 5) {
    machine_position_mm(mm);
    limits_set_probe_result(mm, 0);
  } else {
    limits_probe_result(mm, &touched);
    limits_set_probe_result(mm, 0);   /* the position of the last touch stays */
    state = PROTO_ALARM;
    report_alarm(ALARM_PROBE_FAIL_CONTACT);
  }
  st_probe_disarm();
  probe_cycle = 0;                /* the parser's position: where the head stopped after a touch
                                     (stop_all), else the move's target, as GRBL keeps it */
  report_probe();
}

/* Does the line need an idle machine (empty planner, stopped stepper)? */
static uint8_t needs_idle(const char *line) {
  if (line[0] != '$')            /* labkit-fw: G-code waits for a jog to end (GRBL refuses it; a
                                     probe line is checked at once and waits for rest in
                                     gc_execute_line, as GRBL's) */
    return state == PROTO_JOG && settings.dialect != GC_DIALECT_GRBL;
  if (settings.dialect == GC_DIALECT_GRBL)
    return 0;                     /* GRBL answers at once: error:8 when not idle */
  const char *p = line + 1;
  if (p[0] == 'J' && p[1] == '=')
    return 0;                     /* jogs queue behind a running jog only */
  return (p[0] >= '0' && p[0] <= '9') || !strncmp(p, "RST", 3) || (p[0] == 'C' && !p[1]) ||
         (p[0] == 'X' && !p[1]);
}

void protocol_execute_line(char *line) {
  uint8_t st;
  menu_focus_off();               /* the host has taken over: no panel beam */
  if (line[0] == 0) {
    /* blank or comment-only: the parser still counts it, so that block
       line numbers are source line numbers (Ln:, traces) */
    st = state == PROTO_ALARM ? STATUS_OK : gc_execute_line(line);
  } else if (line[0] == '$') {
    st = system_command(line);
    if (st == REPLY_DONE)
      return;
  } else if (state == PROTO_ALARM || (state == PROTO_JOG && settings.dialect == GC_DIALECT_GRBL)) {
    st = STATUS_GCODE_LOCKED;     /* GRBL refuses G-code during a jog too */
  } else if (state == PROTO_CHECK) {
    st = gc_execute_line(line);
    plan_reset();                 /* checked, never run */
    (void)st_take_abort();
    if (st == STATUS_OK && gc_state()->stop_now == GC_FLOW_END) {
      gc_end_program();
      report_feedback(MSG_PROGRAM_END);
    }
  } else {
    st = gc_execute_line(line);
    if (reset_pending) {          /* a reset ended the line's wait: its reply, then the banner */
      report_status_message(st);
      return;
    }
    if (critical) {               /* a hard limit ended the wait: the ok comes with the reset */
      ok_owed = 1;
      return;
    }
    if (st == STATUS_OK) {
      const gc_state_t *g = gc_state();
      if (settings.soft_limits && outside_envelope(g->pos_mm)) {
        if (settings.dialect != GC_DIALECT_GRBL)
          report_status_message(STATUS_OUT_OF_BOUNDS);
        critical_alarm(ALARM_SOFT_LIMIT);
        ok_owed = critical;         /* GRBL: the line's ok comes with the reset */
        return;
      }
      if (g->probe_now && settings.dialect == GC_DIALECT_GRBL) {
        program_end = g->stop_now == GC_FLOW_END;   /* M2 / M30 on the probe line: after it */
        start_probe(g->probe_now);
        return;
      }
      if (g->stop_now == GC_FLOW_END) {
        plan_flush();
        program_end = settings.dialect == GC_DIALECT_GRBL;   /* once the moves have ended */
      }
      protocol_events |= EV_RUNNER;
      if (g->stop_now == GC_FLOW_PAUSED && settings.dialect == GC_DIALECT_GRBL) {
        plan_flush();
        program_pause = 1;          /* the ok comes with '~' */
        ok_owed = 1;
        return;
      }
      if (g->sync_now && settings.dialect == GC_DIALECT_GRBL) {
        plan_flush();
        sync_ok = 1;                /* the ok comes when the moves have ended */
        ok_owed = 1;
        return;
      }
    }
  }
  report_status_message(st);
}

/* ------------------------------------------------- the four machines */

/* GRBL 1.1's override bytes: 0x90 feed 100 %, 0x91/0x92 +-10 %, 0x93/0x94
   +-1 % (10 .. 200 %); 0x95..0x97 rapid 100/50/25 %; 0x99 laser power 100 %,
   0x9A/0x9B +-10 %, 0x9C/0x9D +-1 % (10 .. 200 %). */
static void apply_override_bytes(void) {
  serial_overrides_t o;
  serial_take_overrides(&o);
  uint8_t feed, rapid;
  plan_get_overrides(&feed, &rapid);
  int f = (o.feed_reset ? 100 : feed) + o.feed_delta;
  int p = (o.power_reset ? 100 : laser_get_override()) + o.power_delta;
  f = f < 10 ? 10 : f > 200 ? 200 : f;
  p = p < 10 ? 10 : p > 200 ? 200 : p;
  plan_set_overrides((uint8_t)f, o.rapid ? o.rapid : rapid);
  laser_set_override((uint8_t)p);
}

/* A hard limit tripped (protocol_limit_pin_change has stopped the timer and the beam): GRBL's
   critical alarm. A line GRBL would hold in its hands gets its verdict, an ok with the reset. */
static void hard_limit_alarm(void) {
  char held[LINE_BUFFER_SIZE];
  uint8_t in_hand = pending_in_hand();
  if (in_hand)
    memcpy(held, pending, LINE_BUFFER_SIZE);
  critical_alarm(ALARM_HARD_LIMIT);
  limit_tripped = 0;                /* the alarm state keeps further changes out */
  if (in_hand) {
    uint8_t st = pending_verdict(held);
    if (st == STATUS_OK)
      ok_owed = 1;
    else
      report_status_message(st);
  }
}

static void system_task(void) {
  if (reset_pending && !in_wait)
    reset_finish();               /* the reply of the line whose wait the reset ended has gone */
  uint16_t f = serial_take_flags(RT_RESET | RT_ESTOP | RT_HOLD | RT_DOOR | RT_RESUME |
                                 RT_JOG_CANCEL | RT_STATUS | RT_OVERRIDE);
  if (limit_tripped)
    hard_limit_alarm();
  if (f & RT_ESTOP) {
    report_feedback("E-stop");
    protocol_alarm(ALARM_ABORT_CYCLE);
    if (ok_owed && !sync_ok && !critical) {
      ok_owed = 0;                /* the M0 it ended */
      report_status_message(STATUS_OK);
    }
  }
  if (f & RT_RESET) {
    if (critical)
      f &= (uint16_t)~RT_STATUS;  /* GRBL's critical wait answers no '?': its reset drops it */
    if (in_wait) {
      reset_stop();               /* the waiting line is answered first, then the banner */
      reset_pending = 1;
    } else {
      soft_reset();
    }
    f &= RT_STATUS;
  }
  if (f & RT_OVERRIDE)           /* before a status report asked for in the same pass */
    apply_override_bytes();
  if (f & (RT_HOLD | RT_DOOR)) {
    menu_focus_off();            /* a hold means "beam off" even at rest */
    if (!st_is_idle() || !plan_is_empty()) {
      if (state == PROTO_JOG)
        jog_cancel = 1;          /* GRBL: a hold during a jog cancels it */
      else
        hold_req = 1;
      st_feed_hold();
      laser_off();
    } else if (state == PROTO_IDLE && settings.dialect == GC_DIALECT_GRBL) {
      hold_req = 1;              /* GRBL holds at rest too: Hold:0 until '~' */
    }
  }
  int32_t touch_steps[3];
  if (probe_cycle && !probe_hit && st_probe_tripped(touch_steps)) {
    steps_to_mm(touch_steps, probe_hit_mm);
    probe_hit = 1;
    stop_all();                   /* the rest of the probe move is dropped */
  }
  /* GRBL in laser mode switches the beam's output off once a hold has stopped the head, and
     setting the spindle output makes its next report show Ov: */
  uint8_t held = hold_req && (st_state() == ST_HELD || st_is_idle());
  if (held && !was_held && settings.dialect == GC_DIALECT_GRBL && settings.laser_mode &&
      gc_state()->laser)
    report_overrides_next();
  was_held = held;
  if (sync_ok && !critical && st_is_idle() && plan_is_empty() && !hold_req) {
    sync_ok = 0;
    ok_owed = 0;
    if (probe_cycle)
      finish_probe();
    end_program();
    report_status_message(STATUS_OK);
  }
  if ((f & RT_RESUME) && program_pause && st_is_idle() && plan_is_empty()) {
    program_pause = 0;            /* M0 ends: its ok, then the next lines */
    ok_owed = 0;
    report_status_message(STATUS_OK);
    f &= (uint16_t)~RT_RESUME;
  }
  /* GRBL takes a cycle start only once a hold has come to rest (Hold:0): one while it still
     brakes (Hold:1) is dropped, the hold completes, and a later '~' resumes (planner_sync #57) */
  if ((f & RT_RESUME) && settings.dialect == GC_DIALECT_GRBL && st_state() == ST_HOLDING)
    f &= (uint16_t)~RT_RESUME;
  if (f & RT_RESUME) {
    uint8_t s = st_state();
    if (hold_req && settings.dialect == GC_DIALECT_GRBL && gc_state()->laser)
      report_feedback(MSG_RESTORING_SPINDLE);
    hold_req = 0;
    if (s == ST_HELD || s == ST_HOLDING)
      st_resume();
  }
  if ((f & RT_JOG_CANCEL) && state == PROTO_JOG) {
    st_feed_hold();
    jog_cancel = 1;
  }
  if (jog_cancel && (st_state() == ST_HELD || st_is_idle())) {
    stop_all();
    jog_cancel = 0;
    state = PROTO_IDLE;
  }
  if (state == PROTO_JOG && st_is_idle() && plan_is_empty()) {
    gc_sync_position();
    state = PROTO_IDLE;
  }
  /* labkit-fw also watches the head while it moves; GRBL checks each line's target only
     (a move from outside the envelope back into it runs) */
  if (state != PROTO_ALARM && settings.soft_limits && !st_is_idle() &&
      settings.dialect != GC_DIALECT_GRBL) {
    float mm[3];
    double d[3];
    st_get_position_mm(mm);
    for (int i = 0; i < 3; i++)
      d[i] = mm[i];
    if (outside_envelope(d))
      critical_alarm(ALARM_SOFT_LIMIT);
  }
  if ((f & RT_STATUS) && !critical)
    report_status_report();
}

static void parser_task(void) {
  for (uint8_t n = 0; n < 8; n++) {     /* a few lines per pass, then let the others run */
    if (state == PROTO_SLEEP || program_pause || critical || sync_ok || reset_pending ||
        (hold_req && settings.dialect == GC_DIALECT_GRBL))
      return;                     /* asleep until a reset; M0 and GRBL's holds: until '~' */
    if (have_pending) {
      if (needs_idle(pending) && (!plan_is_empty() || !st_is_idle())) {
        if (!flushed) {
          plan_flush();
          flushed = 1;
        }
        return;
      }
      if (pending[0] != '$' && state != PROTO_ALARM && plan_free_slots() < 1)
        return;
      have_pending = 0;
      protocol_execute_line(pending);
      continue;
    }
    int b = serial_read();
    if (b < 0)
      return;
    last_rx_ms = hal_millis();
    flushed = 0;
    int st = line_asm_push(&rx_line, (uint8_t)b);
    if (st < 0)
      continue;
    if (st != STATUS_OK) {
      report_status_message((uint8_t)st);
      continue;
    }
    memcpy(pending, rx_line.buf, LINE_BUFFER_SIZE);
    have_pending = 1;
  }
}

static void runner_task(void) {
  if (hold_req && st_state() == ST_IDLE)
    return;                       /* held before it could start: wait for '~' */
  st_prep_buffer();
  if (!flushed && !have_pending && rx_line.raw == 0 && serial_rx_count() == 0 &&
      (uint32_t)(hal_millis() - last_rx_ms) >= FLUSH_QUIET_MS) {
    plan_flush();                 /* the stream is quiet: run what look-ahead holds back */
    flushed = 1;
    st_prep_buffer();
  }
}

static void wait_hook(void) {
  hal_poll();
  in_wait = 1;
  system_task();
  in_wait = 0;
}

void protocol_init(void) {
  line_asm_reset(&rx_line);
  line_asm_set_dialect(&rx_line, settings.dialect);
  have_pending = 0;
  state = PROTO_IDLE;
  jog_cancel = 0;
  hold_req = 0;
  program_pause = 0;
  sync_ok = 0;
  ok_owed = 0;
  program_end = 0;
  critical = 0;
  limit_tripped = 0;
  reset_pending = 0;
  in_wait = 0;
  probe_cycle = 0;
  flushed = 1;
  last_rx_ms = hal_millis();
  empty_slots = plan_free_slots();
  gc_set_wait_hook(wait_hook);
  protocol_events = EV_SYSTEM | EV_PARSER | EV_RUNNER | EV_MENU;
}

/* After the banner (power-up and reset): GRBL's CHECK_LIMITS_AT_INIT (hard limits on and a
   switch pressed: locked, "[MSG:Check Limits]"), then the alarm lock's message, or the
   start-up lines. */
static void startup_checks(void) {
  if ((settings.flags & SET_FLAG_HARD_LIMITS) && limits_pressed()) {
    state = PROTO_ALARM;
    report_feedback(MSG_CHECK_LIMITS);
  }
  if (state == PROTO_ALARM)
    report_feedback(MSG_ALARM_LOCK);
  else
    run_startup_lines();
}

void protocol_startup(void) {
  serial_init();
  plan_init();
  st_init();
  laser_init();
  gc_init();
  uint8_t good = settings_init();
  if (settings_apply() != STATUS_OK) {       /* stored values the core refuses */
    settings_defaults(&settings);
    (void)settings_apply();
    good = 0;
  }
  menu_init();
  protocol_init();
  report_banner();                           /* readiness: the host waits for it */
  if (!good)
    report_feedback("settings restored");
  /* GRBL (HOMING_INIT_LOCK): at power-up with homing on the position is unknown until $H (or $X) */
  if (settings.dialect == GC_DIALECT_GRBL && (settings.flags & SET_FLAG_HOMING))
    state = PROTO_ALARM;
  startup_checks();
}

void protocol_poll(void) {
  hal_poll();
  if (serial_rt_flags & (RT_LINE | RT_MENU | RT_STATUS | RT_HOLD | RT_RESUME | RT_RESET |
                         RT_ESTOP | RT_JOG_CANCEL | RT_DOOR | RT_OVERRIDE))
    protocol_events |= EV_SYSTEM | EV_PARSER | EV_MENU;
  if (serial_rx_count() || have_pending)
    protocol_events |= EV_PARSER;
  uint8_t ev = protocol_events;
  protocol_events = 0;
  /* system control runs every pass: it also watches the envelope while moving */
  system_task();
  if (ev & EV_PARSER) {
    (void)serial_take_flags(RT_LINE);
    parser_task();
  }
  runner_task();                 /* cheap when idle; must run while the stepper does */
  static uint32_t last_lcd_ms;
  if (serial_take_flags(RT_MENU) || (ev & EV_MENU) ||
      (uint32_t)(hal_millis() - last_lcd_ms) >= 200u) {   /* the LCD follows the machine */
    last_lcd_ms = hal_millis();
    menu_task();
  }
}

void protocol_main_loop(void) {
  for (;;)
    protocol_poll();
}
