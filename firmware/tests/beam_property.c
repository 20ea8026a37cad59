/*
  beam_property.c - the beam-state property (beam_property.h): a core hal
  whose step timer ticks and whose laser output is watched, an independent
  reading of the accepted G-code lines, and the checks.
*/
#include "beam_property.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "fuzz/fuzz_util.h"
#include "gcode.h"
#include "hal.h"
#include "laser.h"
#include "menu.h"
#include "planner.h"
#include "protocol.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "status_codes.h"
#include "stepper.h"

static beam_stats_t stats;
static void default_fail(const char *what);
static beam_fail_fn fail_fn = default_fail;

/* ------------------------------------------------------------ core hal */

static uint16_t out_duty;          /* what the laser output is driven to */
static int timer_on;
static uint32_t input_ticks;       /* ticks of the current input */
static uint8_t focus_fired;        /* the output went to the focus duty after turn, OK, OK */
static uint8_t panel_last[3];      /* the last three panel events, newest last */

/* The head as the motors move it, counted from the pulses (homing rewrites the core's
   counters, not the head), and a limit switch per axis BEAM_SWITCH_MM on its + side. */
static uint8_t dir_now;
static int32_t head_steps[3];
static uint8_t pins_seen;          /* the switches as the last step left them */
static uint8_t pins_changed;       /* the limit pins' change interrupt is pending */
void hal_set_dir(uint8_t bits) { dir_now = bits; }
void hal_step_pulse(uint8_t bits) {
  for (int a = 0; a < 3; a++)
    if (bits & (1u << a))
      head_steps[a] += (dir_now & (1u << a)) ? -1 : 1;
  uint8_t pins = hal_limits_read();
  if (pins != pins_seen) {
    pins_seen = pins;
    pins_changed = 1;
  }
}
uint8_t hal_limits_read(void) {
  uint8_t pressed = 0;
  for (int a = 0; a < 3; a++)
    if (head_steps[a] >= (int32_t)(BEAM_SWITCH_MM * plan_machine()->steps_per_mm[a]))
      pressed |= (uint8_t)(1u << a);
  return pressed;
}
void hal_timer_set_period(uint32_t p) { (void)p; }
void hal_timer_start(void) { timer_on = 1; }
void hal_timer_stop(void) { timer_on = 0; }
void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille) { (void)pwm_hz; (void)on_permille; }
void hal_air_set(uint8_t bits) { (void)bits; }
void hal_irq_disable(void) {}
void hal_irq_enable(void) {}

static int is_turn(uint8_t ev) { return ev == PANEL_CW || ev == PANEL_CCW; }

void hal_laser_set(uint16_t duty) {
  uint16_t before = out_duty;
  out_duty = duty;
  if (duty == 0) {
    focus_fired = 0;
  } else if (before == 0 && menu_laser_is_on()) {
    /* the panel fires the focus beam: it must have been the deliberate
       sequence, a turn to "On", OK, and OK on the confirm screen */
    if (!(is_turn(panel_last[0]) && panel_last[1] == PANEL_OK && panel_last[2] == PANEL_OK))
      fail_fn("focus beam fired without a turn, OK, OK on the panel channel");
    focus_fired = 1;
    stats.focus_fires++;
  }
  beam_check("laser output set");
}

uint16_t beam_output_duty(void) { return out_duty; }

/* The limit pins' change interrupt (after the step interrupt that moved the head, as on the
   board and in the simulator): with hard limits on ($21=1), outside an alarm and a homing
   cycle, the step timer and the beam are off when it returns; the main loop's next pass then
   finds the machine in alarm with nothing queued (beam_after_pass). */
static uint8_t hard_limit_tripped;
static void limit_pin_change(void) {
  pins_changed = 0;
  uint8_t armed = (settings.flags & SET_FLAG_HARD_LIMITS) && protocol_state() != PROTO_ALARM &&
                  protocol_state() != PROTO_HOME;
  protocol_limit_pin_change();
  if (!armed)
    return;
  stats.hard_limits++;
  hard_limit_tripped = 1;
  if (out_duty || timer_on)
    fail_fn("the beam or the step timer still on after a hard limit tripped");
}

/* The simulator's timer (host/sim.c): up to 32 ticks per pass, the
   buffer topped up as the main loop does; past the budget the host's
   Ctrl-X ends the input's motion (the parser's wait gives up with it). */
static uint32_t idle_polls;        /* polls in a row without a tick */
static void tick_work(void) {
  /* a line that waits for the moves before it (GRBL's planner syncs) while a hold keeps them
     from ending waits until '~' or Ctrl-X; the input's next bytes come only after it, so the
     host gives up as after BEAM_MAX_TICKS: Ctrl-X */
  idle_polls = timer_on ? 0 : idle_polls + 1;
  if (idle_polls > 1000000u) {
    idle_polls = 0;
    serial_rx_isr(0x18);
    return;
  }
  for (int i = 0; i < 32 && timer_on; i++) {
    if (input_ticks >= BEAM_MAX_TICKS) {
      serial_rx_isr(0x18);
      return;
    }
    input_ticks++;
    stats.ticks++;
    if (protocol_state() == PROTO_HOME)
      stats.ticks_homing++;
    st_tick();
    if (pins_changed)
      limit_pin_change();
    if (out_duty)
      stats.ticks_burning++;
    beam_check("step tick");
    if ((i & 3) == 3 && timer_on)
      st_prep_buffer();
  }
}

/* ---------------------------------------- the accepted lines, read again */

/* GRBL's order of execution within a line: S and M3 / M4 / M5 before the
   motion, M2 / M30 (which leave M5 and G1) after it. A line's block burns
   when its motion mode is G1-G3 and M3 / M4 with S > 0 is in effect. */
static struct {
  int motion;                      /* 0-3, 80 */
  int laser;                       /* 0, 3, 4 */
  double s;
} shadow;

#define LINE_SLOTS 4096u
static uint32_t line_key[LINE_SLOTS];   /* line number + 1; 0 = empty */
static uint8_t line_burns[LINE_SLOTS];
static uint32_t lines_kept;
static uint8_t lines_overflow;           /* then an unknown line is given the benefit of the doubt */

static void shadow_reset(void) {
  shadow.motion = 0;
  shadow.laser = 0;
  shadow.s = 0.0;
  memset(line_key, 0, sizeof line_key);
  lines_kept = 0;
  lines_overflow = 0;
}

static uint32_t slot_of(uint32_t line) { return (line * 2654435761u) & (LINE_SLOTS - 1u); }

/* A line number may be given twice (N words): it burns if either did. */
static void line_note(uint32_t line, uint8_t burns) {
  for (uint32_t k = 0, i = slot_of(line); k < LINE_SLOTS; k++, i = (i + 1u) & (LINE_SLOTS - 1u)) {
    if (line_key[i] == line + 1u) {
      line_burns[i] |= burns;
      return;
    }
    if (line_key[i] == 0) {
      if (lines_kept + 1u >= LINE_SLOTS / 2u) {
        lines_overflow = 1;
        return;
      }
      line_key[i] = line + 1u;
      line_burns[i] = burns;
      lines_kept++;
      return;
    }
  }
}

static int line_may_burn(uint32_t line) {
  for (uint32_t k = 0, i = slot_of(line); k < LINE_SLOTS; k++, i = (i + 1u) & (LINE_SLOTS - 1u)) {
    if (line_key[i] == line + 1u)
      return line_burns[i];
    if (line_key[i] == 0)
      return lines_overflow;
  }
  return lines_overflow;
}

/* [+-] digits [. digits]: the number after a word's letter. */
static const char *read_value(const char *p, double *v) {
  int neg = 0;
  double x = 0.0, scale = 1.0;
  if (*p == '+' || *p == '-')
    neg = *p++ == '-';
  while (*p >= '0' && *p <= '9')
    x = x * 10.0 + (*p++ - '0');
  if (*p == '.') {
    p++;
    while (*p >= '0' && *p <= '9') {
      scale /= 10.0;
      x += (*p++ - '0') * scale;
    }
  }
  *v = neg ? -x : x;
  return p;
}

static uint8_t shadow_line(const char *p) {
  int end = 0;
  while (*p && *p != ';' && *p != '*' && *p != '%') {
    char c = *p++;
    if (c == '(') {
      while (*p && *p != ')')
        p++;
      if (*p)
        p++;
      continue;
    }
    if (c < 'A' || c > 'Z')
      continue;
    double v;
    p = read_value(p, &v);
    if (c == 'S') {
      shadow.s = v;
    } else if (c == 'G') {
      long t10 = lround(v * 10.0);
      if (t10 % 10 == 0 && (t10 <= 30 || t10 == 800))
        shadow.motion = (int)(t10 / 10);
    } else if (c == 'M') {
      long m = lround(v);
      if (m == 3 || m == 4)
        shadow.laser = (int)m;
      else if (m == 5)
        shadow.laser = 0;
      else if (m == 2 || m == 30)
        end = 1;
    }
  }
  uint8_t burns = shadow.motion >= 1 && shadow.motion <= 3 && shadow.laser != 0 &&
                  (float)shadow.s > 0.0f;
  if (end) {
    shadow.laser = 0;
    shadow.motion = 1;
  }
  return burns;
}

uint8_t __real_gc_execute_line(char *line);
uint8_t __wrap_gc_execute_line(char *line);
void __real_gc_init(void);
void __wrap_gc_init(void);

uint8_t __wrap_gc_execute_line(char *line) {
  char text[LINE_BUFFER_SIZE + 1];
  strncpy(text, line, LINE_BUFFER_SIZE);
  text[LINE_BUFFER_SIZE] = 0;
  uint8_t st = __real_gc_execute_line(line);
  if (st == STATUS_OK) {      /* the line is the program's */
    uint8_t burns = shadow_line(text);
    line_note(gc_state()->line, burns);
    stats.lines_ok++;
    stats.lines_burning += burns;
  }
  return st;
}

void __wrap_gc_init(void) {    /* power-on and every soft reset: a new program */
  shadow_reset();
  __real_gc_init();
}

/* ---------------------------------------------------------------- checks */

static void default_fail(const char *what) {
  fprintf(stderr, "beam property: %s\n", what);
  abort();
}

void beam_set_fail(beam_fail_fn fn) { fail_fn = fn ? fn : default_fail; }
const beam_stats_t *beam_stats(void) { return &stats; }

static void failf(const char *where, const char *what) {
  char msg[256];
  const st_block_info_t *b = st_running_block();
  snprintf(msg, sizeof msg, "%s (at %s: duty %u, state %s, stepper %u, block line %u)", what,
           where, (unsigned)out_duty, report_state_name(), (unsigned)st_state(),
           b ? (unsigned)b->line : 0u);
  fail_fn(msg);
}

void beam_check(const char *where) {
  if (laser_current_duty() != out_duty)
    failf(where, "the core's laser duty differs from the output");
  if (out_duty == 0)
    return;
  if (menu_laser_is_on()) {
    if (!focus_fired)
      failf(where, "focus beam on without the panel's deliberate sequence");
    if (out_duty != MENU_FOCUS_DUTY)
      failf(where, "focus beam above its focus duty");
    if (protocol_state() != PROTO_IDLE || !st_is_idle() || !plan_is_empty() ||
        protocol_hold_requested())
      failf(where, "focus beam on a machine that is not at rest");
    return;
  }
  switch (protocol_state()) {
  case PROTO_ALARM: failf(where, "beam on in alarm"); return;
  case PROTO_CHECK: failf(where, "beam on in check mode"); return;
  case PROTO_JOG: failf(where, "beam on in a jog"); return;
  case PROTO_HOME: failf(where, "beam on while homing"); return;
  default: break;
  }
  uint8_t s = st_state();
  if (protocol_hold_requested() || s == ST_HOLDING || s == ST_HELD) {
    failf(where, "beam on while held");
    return;
  }
  if (s != ST_RUN) {
    failf(where, "beam on with no move running");
    return;
  }
  const st_block_info_t *b = st_running_block();
  if (!b || (b->kind != PLAN_BLOCK_LINE && b->kind != PLAN_BLOCK_ARC) || b->rapid) {
    failf(where, "beam on outside a line or arc block");
    return;
  }
  if ((b->laser != 3 && b->laser != 4) || !(b->power_mw > 0.0)) {
    failf(where, "beam on in a block without M3/M4 and S > 0");
    return;
  }
  const lk_machine_t *m = plan_machine();
  if (b->laser == 3) {
    /* ticks prepared before an override change keep their power (8 ms at
       most): the bound is the override's ceiling, 200 % */
    double p = b->power_mw * 2.0;
    if (p > m->laser_max_power_mw)
      p = m->laser_max_power_mw;
    if (out_duty > p / m->laser_max_power_mw * LK_LASER_PWM_TOP + 1.5)
      failf(where, "M3 beam above the block's power");
  } else if (out_duty > LK_LASER_PWM_TOP) {
    failf(where, "M4 beam above full scale");
  }
  if (!line_may_burn(b->line))
    failf(where, "beam on in the block of a line the accepted program does not burn on");
}

/* ------------------------------------------------------------------ runs */

void beam_power_on(void) {
  out_duty = 0;
  timer_on = 0;
  input_ticks = 0;
  idle_polls = 0;
  focus_fired = 0;
  dir_now = 0;
  memset(head_steps, 0, sizeof head_steps);
  pins_seen = 0;
  pins_changed = 0;
  hard_limit_tripped = 0;
  memset(panel_last, 0, sizeof panel_last);
  fuzz_set_poll(tick_work);
  fuzz_power_on();
  beam_check("power-on");
}

static void pass(const char *where) {
  protocol_poll();
  beam_check(where);
  if (hard_limit_tripped) {        /* the pass after a hard limit: alarm, nothing queued */
    hard_limit_tripped = 0;
    if (protocol_state() != PROTO_ALARM || !st_is_idle() || !plan_is_empty() || out_duty)
      failf("after a hard limit", "no alarm, motion queued or the beam on after a hard limit");
  }
}

/* After a soft reset the beam is off and nothing is queued. A hold is taken
   only while something moves (GRBL ignores '!' at rest, and the next line
   may start a cut in the same pass); once taken, beam_check holds it dark. */
static void after_realtime(uint8_t byte) {
  uint16_t was = out_duty;
  pass("after a real-time byte");
  if (byte == 0x18) {
    stats.resets++;
    if (out_duty || !st_is_idle() || !plan_is_empty() || menu_laser_is_on())
      failf("after a soft reset", "beam on or motion queued after a soft reset");
  } else if (was && (protocol_hold_requested() || st_state() == ST_HOLDING || st_state() == ST_HELD)) {
    stats.holds_burning++;
  }
}

static void panel_event(uint8_t ev) {
  if (ev == PANEL_ESTOP) {
    stats.estops++;
    protocol_estop();
    if (out_duty)
      failf("e-stop input", "beam on after the e-stop input");
    pass("after an e-stop");
    if (protocol_state() != PROTO_ALARM)
      failf("after an e-stop", "no alarm after the e-stop input");
    return;
  }
  if (ev != PANEL_CW && ev != PANEL_CCW && ev != PANEL_OK)
    return;
  panel_last[0] = panel_last[1];
  panel_last[1] = panel_last[2];
  panel_last[2] = ev;
  serial_panel_event(ev);
  pass("after a panel event");
}

void beam_feed(const uint8_t *data, size_t size) {
  size_t since_pass = 0;
  for (size_t i = 0; i < size && input_ticks < BEAM_MAX_TICKS; i++) {
    uint8_t b = data[i];
    if (b == BEAM_PANEL_ESCAPE && i + 1 < size) {
      uint8_t e = data[++i];
      if (e < 0x10)               /* the host pauses: (e + 1) x 10 passes, 1 ms each */
        for (int k = 0; k < (e + 1) * 10; k++)
          pass("host pause");
      else
        panel_event(e);
      continue;
    }
    if (b == 0x18 || b == '!' || b == 0x84) {
      pass("before a real-time byte");    /* a '~' still pending would undo the hold */
      serial_rx_isr(b);
      after_realtime(b);
      since_pass = 0;
      continue;
    }
    serial_rx_isr(b);
    if (++since_pass >= 8 || serial_rx_count() > 100) {
      pass("main loop");
      since_pass = 0;
    }
  }
  /* the host goes quiet: the look-ahead flushes (30 quiet passes) and the job
     runs out, or stays held; 50 passes without a tick end the input */
  for (int quiet = 0, k = 0; quiet < 50 && k < 1000000 && input_ticks < BEAM_MAX_TICKS; k++) {
    pass("running out");
    quiet = !timer_on && serial_rx_count() == 0 ? quiet + 1 : 0;
  }
}

void beam_end(void) {
  pass("before the final reset");
  serial_rx_isr(0x18);
  after_realtime(0x18);
}

void beam_run(const uint8_t *data, size_t size) {
  beam_feed(data, size);
  beam_end();
}
