/*
  sim.c - the labkit firmware on the host: the same core and shell, with a
  hal whose step timer advances a simulated clock.

    labkit-fw-sim [--pty] [--dialect grbl|labkit-fw] [--trace FILE]
                  [--eeprom FILE] [--panel PATH] [--beam-log PATH] [--stats]
                  [--realtime] [--switches SPEC] [--probe SPEC]
                  [--baud N [--parse-us US] [--starvation-log FILE] [--expect FILE]]

  Serial: stdin/stdout by default; --pty creates a pseudo-terminal and
  prints its path on stderr ("labkit-fw-sim: pty /dev/pts/N"); open it with
  pyserial (any baud rate). The banner is written at start; a host that
  opened the pty later asks for one with Ctrl-X (0x18), as for GRBL. Bytes
  above 0x7F that are not GRBL real-time commands are dropped (serial.c).

  Time: every step-timer tick adds (period + 1) x (prescaler + 1) timer
  cycles to the simulated clock and calls st_tick(), as the timer interrupt
  does; the clock stands still while the timer does. Nothing depends on the
  host's speed except when the look-ahead is flushed because the input went
  quiet (30 ms of wall time, protocol.c). The simulation runs as fast as the
  host allows; with --realtime the simulated clock never runs ahead of the
  wall clock (counted from each start of the step timer), so a sender sees
  a move take as long as on the machine (Run, holds and resets mid-move).

  Trace (--trace FILE): one CSV row per tick, the columns of
  `labkit steps` (labkit.motion.timer.StepTrace.to_dataframe):
    time_s,cycle,block,line,x,y,z,dir,period,power_mw
  x y z are -1/0/+1 steps, time_s the step pulse at the end of the tick;
  dwell ticks are left out (labkit's trace has none).

  Beam log (--beam-log PATH): a CSV with the header
    time_s,duty,state,line
  and one row, flushed at once, every time the laser output's duty changes
  (hal_laser_set with a new value; the duty is 0 at start and gets no row):
  time_s the simulated time in seconds, duty the raw value written to the
  output (0 .. LK_LASER_PWM_TOP, 0 = beam off), state the machine state as
  the status report names it without its sub-state (Idle, Run, Hold, Jog,
  Alarm, Check), line the source line of the running block or 0.

  Control panel (menu.c) and e-stop (--panel PATH): a file or a FIFO whose
  bytes are panel events: 0xB0 encoder clockwise, 0xB1 counter-clockwise,
  0xB2 OK, 0xB8 e-stop; other bytes are ignored. Panel events never come from
  the serial input. A FIFO stays open for later writers; a file is read to
  its end. Firing the focus beam takes Laser, a turn to On, OK and OK again
  (menu.h). `$LCD` prints the LCD's four lines.

  Limit switches (--switches SPEC): "X:+5,Y:+5,Z:-3" puts the switch of
  each named axis that many mm from the power-up position, on the side its
  sign names; it reads pressed at or beyond that point (counted from the
  step pulses, whatever the core believes its position to be). "X:stuck" is
  a switch that is always pressed; an axis not named has none. The same
  spec is what grbl-sim was given for the homing and hard-limit transcripts
  (tests/vectors/grbl/README.md). Without the option no switch is wired.
  A step that presses or releases a switch is the limit pins' change
  interrupt (protocol_limit_pin_change): with $21=1, hard limits.

  Probe input (--probe SPEC), in the same form: "Z:-2" touches at 2 mm below
  the power-up position and beyond (grbl-sim's GRBL_SIM_PROBE, with which
  the probe transcript was recorded). Without the option it never touches.

  Paced link (--baud N): the bytes the host writes reach the controller as
  over a UART at N baud, 8N1: one byte every 10/N s of SIMULATED time, each
  byte no earlier than the simulated moment the host wrote it (so a pty
  shows where a real link would leave the planner dry). The host is taken
  to answer at once: after an "ok"/"error" the simulated clock waits (up to
  0.25 s of wall time) for the host's next line whenever the host still has
  room for one by GRBL's character counting (128-byte buffer) and nothing
  is on the wire (a status poll, '?', does not count as the host's activity).
  A host later than that while blocks are queued (a loaded machine) makes the
  clock run on without it: at exit the simulator prints on stderr how many
  times the host's line then came before another answer ("the host was late
  N times"); stops from such a moment on may be the host's, not the link's.
  --expect FILE (with --baud) gives the simulator the line bytes the host
  will write, in order (real-time bytes such as '?' left out): it then knows
  the host's next line instead of guessing it from the last one, holds the
  clock whenever a counting host has room for it and waits for it up to 10 s
  of wall time instead of 0.25 s, so a loaded host machine does not make
  starvations the link would not, while a link too slow for the job still
  does (its bytes arrive at the baud rate's pace whatever the host does).
  Nothing is waited for once the host has written the whole file. A host
  byte that differs from the file ends this at that byte (the guess and the
  0.25 s apply from there) and is reported on stderr at exit. Without
  --expect the next line is guessed as long as the longest of the last 8.
  A wait that ran out while the host had room is not begun again by the
  answers after it (the host is silent) until the host writes.
  The firmware's main loop runs between ticks as on the board, where it runs
  beside the step interrupt: an answer goes out at the simulated moment the
  core wrote it, and no tick is taken while the main loop makes progress (it
  took received bytes, which its parser reads 8 a pass, or a planner slot
  came free).
  A byte due during a tick is read at its arrival, not at the tick's end.
  While the motors stand, the clock jumps to the next byte's
  arrival; with nothing on the wire it follows the wall clock. The
  firmware's millisecond clock (hal_millis: the quiet-input flush) is the
  simulated clock. --parse-us US charges each received line US microseconds
  of parsing before it reaches the parser (lines are parsed one after the
  other); default 0.

  Starvation log (--starvation-log FILE, with --baud): a CSV with the header
    time_s,line,duration_s
  and one row, flushed at once, every time the motors stood still between
  two blocks while the job had lines left: line bytes were on the wire
  (--parse-us included) or in the RX buffer when they stopped, or arrived
  while they stood. time_s is when they stopped, line the source line of
  the block they resumed with, duration_s how long they stood. The wait for
  the first block and the final quiet-input flush (nothing left to arrive)
  are not starvations, nor a stop where a line waits for the moves before it
  (GRBL's planner sync: M3/M5, S alone, G92 ...; the program's stop, as
  labkit.motion.stall plans it). labkit.motion.stall reads it (Starvation records).

  At the end of stdin (stdin mode) the look-ahead is flushed, the job runs
  out and the simulator exits; SIGINT/SIGTERM end it at once. --stats
  prints blocks, ticks, simulated and host time on stderr at exit.
*/
#define _XOPEN_SOURCE 700
#define _DEFAULT_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "config.h"
#include "gcode.h"
#include "hal.h"
#include "laser.h"
#include "planner.h"
#include "menu.h"
#include "protocol.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "storage_ram.h"

static int fd_in = 0, fd_out = 1, pty_slave = -1, fd_panel = -1;
static int input_eof;
static volatile sig_atomic_t stop_now;

/* simulated hardware */
static uint8_t dir_bits;
static int32_t pos_steps[3];
static uint32_t period_reg;
static int timer_on;
static uint64_t tick_end;         /* paced: when the tick in progress ends (0: none started) */
static int realtime;              /* --realtime: ticks wait for the wall clock */
static double rt_host_s;          /* wall time and simulated cycles when the timer last started */
static uint64_t rt_cycles;
static uint16_t laser_duty;
static uint64_t cycles;           /* simulated timer clock cycles since start */
static uint64_t ticks;
static uint32_t blocks_seen;
static FILE *trace, *beam_log;
static uint16_t beam_logged;      /* the duty of the beam log's last row */
static uint32_t tick_block, tick_line;
static double tick_power_mw;
static uint8_t tick_dwell;

/* limit switches (--switches) */
static uint8_t switch_wired, switch_stuck;
static double switch_mm[3];
static uint8_t switch_seen;       /* the pins as the last step left them */
static uint8_t switch_changed;    /* a step changed them: the pin-change interrupt is pending */
/* probe input (--probe): the same form, read by hal_probe_read() */
static uint8_t probe_wired, probe_stuck;
static double probe_mm[3];

/* paced link (--baud) */
static uint32_t baud;             /* 0: bytes reach the core as soon as they are read */
static uint64_t byte_cycles;      /* timer cycles per byte on the wire (10 bits) */
static uint64_t parse_cycles;     /* --parse-us per line, in timer cycles */
#define WIRE_SIZE 8192u           /* bytes read from the host and still on the wire */
static uint8_t wire[WIRE_SIZE];
static uint64_t wire_due[WIRE_SIZE];
static size_t wire_head, wire_tail;   /* ever-increasing; index % WIRE_SIZE */
static uint64_t wire_last_due;        /* arrival of the last byte put on the wire */
static uint64_t parse_done;
static int wire_after_cr;             /* the last line byte on the wire was '\r' */           /* the end of the last line's parsing (--parse-us) */
static uint64_t line_bytes_delivered; /* non-real-time bytes that reached the core */
static uint64_t line_bytes_wired;     /* non-real-time bytes put on the wire */
/* GRBL's character counting as the simulator sees it: lines received and not yet answered */
#define OWED_SIZE 1024u
static uint16_t owed_len[OWED_SIZE];
static size_t owed_head, owed_tail;
static uint32_t owed_bytes, rx_line_len;
#define RECENT_LINES 8u
static uint32_t recent_len[RECENT_LINES];   /* the last lines' lengths: the next one's guess */
static size_t recent_at;
static int host_turn;                 /* an answer went out; the host may send a line */
static double host_turn_since;
#define HOST_ANSWER_S 0.25
#define HOST_EXPECT_S 10.0            /* the wait when the host's bytes are known (--expect) */
static uint8_t *expect_buf;           /* --expect: the host's line bytes, in order */
static size_t expect_len;
static int expect_on;                 /* the host has written what the file says so far */
static uint64_t expect_off_at;        /* the first host byte that differed (with !expect_on) */
static int host_waited_out;           /* the wait for the host's line ran out while moving */
static unsigned long host_late;       /* ... and its line came before another answer */
static char tx_line[8];               /* the start of the line being written to the host */
static size_t tx_line_len;
static double idle_wall_s;            /* wall time when the idle clock last advanced */
/* starvations (--starvation-log) */
static FILE *starve_log;
static int stop_by_program;     /* the motors stopped where a line waits for them (a sync) */
static int motors_stopped;            /* stopped after having run */
static int stop_lines_pending;        /* line bytes were on the wire or in the RX ring at the stop */
static uint64_t stop_cycles, stop_line_bytes;

/* ------------------------------------------------------------ core hal */

void hal_set_dir(uint8_t bits) { dir_bits = bits; }

void hal_step_pulse(uint8_t step_bits) {
  int s[3];
  for (int i = 0; i < 3; i++) {
    s[i] = 0;
    if (step_bits & (1u << i)) {
      s[i] = (dir_bits & (1u << i)) ? -1 : 1;
      pos_steps[i] += s[i];
    }
  }
  if (switch_wired & step_bits) {
    /* the step that pressed or released a switch: the pins' change interrupt follows the step
       interrupt (hal_poll), as on the board where both have the same priority */
    uint8_t pins = hal_limits_read();
    if (pins != switch_seen) {
      switch_seen = pins;
      switch_changed = 1;
    }
  }
  if (trace && !tick_dwell) {    /* a dwell has no ticks in labkit's step trace */
    const lk_machine_t *m = plan_machine();
    fprintf(trace, "%.9f,%llu,%u,%u,%d,%d,%d,%u,%u,%.6f\n",
            (double)cycles / (double)m->timer_clock_hz, (unsigned long long)cycles, tick_block,
            tick_line, s[0], s[1], s[2], (unsigned)(dir_bits & step_bits), period_reg,
            tick_power_mw);
  }
}

void hal_timer_set_period(uint32_t p) {
  period_reg = p;
  const st_block_info_t *b = st_running_block();
  tick_block = b ? b->seq - 1u : 0u;
  tick_line = b ? b->line : 0u;
  tick_power_mw = st_current_power_mw();
  tick_dwell = b && b->kind == PLAN_BLOCK_DWELL;
  if (b && b->seq > blocks_seen)
    blocks_seen = b->seq;
}
static double host_seconds(void);
void hal_timer_start(void) {
  if (!timer_on && motors_stopped) {
    /* a starvation when the job had lines left: line bytes were on the wire or waiting in
       the RX ring when the motors stopped, or arrived while they stood */
    if (starve_log && !stop_by_program &&
        (stop_lines_pending || line_bytes_delivered != stop_line_bytes) && cycles > stop_cycles) {
      double hz = (double)plan_machine()->timer_clock_hz;
      fprintf(starve_log, "%.9f,%u,%.9f\n", (double)stop_cycles / hz, (unsigned)tick_line,
              (double)(cycles - stop_cycles) / hz);
      fflush(starve_log);
    }
    motors_stopped = 0;
  }
  if (!timer_on)
    tick_end = 0;
  if (!timer_on && realtime) {
    rt_host_s = host_seconds();
    rt_cycles = cycles;
  }
  timer_on = 1;
}

/* --realtime: the simulated clock has caught up with the wall clock. */
static int ahead_of_wall_clock(void) {
  if (!realtime)
    return 0;
  double allowed = (host_seconds() - rt_host_s) * (double)plan_machine()->timer_clock_hz;
  return (double)(cycles - rt_cycles) >= allowed;
}
void hal_timer_stop(void) {
  if (timer_on && baud) {
    motors_stopped = 1;
    stop_cycles = cycles;
    stop_line_bytes = line_bytes_delivered;
    stop_lines_pending = line_bytes_wired != line_bytes_delivered || serial_rx_count() > 0;
    stop_by_program = gc_waiting_for_idle();   /* a planner sync (M3/M5, S alone, G92 ...) */
  }
  timer_on = 0;
}
static void log_beam(uint16_t duty) {
  char state[16];
  const char *name = report_state_name();
  size_t n = strcspn(name, ":");            /* "Hold:0" -> "Hold" */
  if (n >= sizeof state)
    n = sizeof state - 1;
  memcpy(state, name, n);
  state[n] = 0;
  fprintf(beam_log, "%.9f,%u,%s,%u\n", (double)cycles / (double)plan_machine()->timer_clock_hz,
          (unsigned)duty, state, (unsigned)st_current_line());
  fflush(beam_log);
  beam_logged = duty;
}

void hal_laser_set(uint16_t duty) {
  laser_duty = duty;
  if (beam_log && duty != beam_logged)
    log_beam(duty);
}
void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille) { (void)pwm_hz; (void)on_permille; }
void hal_air_set(uint8_t bits) { (void)bits; }
void hal_irq_disable(void) {}
void hal_irq_enable(void) {}

/* the axes whose contact (a switch, the probe) the head is at or beyond, from the step count */
static uint8_t contacts_pressed(uint8_t wired, uint8_t stuck, const double at_mm[3]) {
  const lk_machine_t *m = plan_machine();
  uint8_t pressed = stuck;
  for (int a = 0; a < 3; a++) {
    if (!(wired & (1u << a)) || (stuck & (1u << a)))
      continue;
    double mm = (double)pos_steps[a] / m->steps_per_mm[a];
    if (at_mm[a] >= 0 ? mm >= at_mm[a] : mm <= at_mm[a])
      pressed |= (uint8_t)(1u << a);
  }
  return pressed;
}

uint8_t hal_limits_read(void) { return contacts_pressed(switch_wired, switch_stuck, switch_mm); }

uint8_t hal_probe_read(void) { return contacts_pressed(probe_wired, probe_stuck, probe_mm) != 0; }

/* "X:+5,Y:+5,Z:stuck" (see the head of this file) into wired/stuck/at_mm; 0 when malformed */
static int parse_contacts(const char *spec, uint8_t *wired, uint8_t *stuck, double at_mm[3]) {
  while (*spec) {
    int a = spec[0] == 'X' ? 0 : spec[0] == 'Y' ? 1 : spec[0] == 'Z' ? 2 : -1;
    if (a < 0 || spec[1] != ':')
      return 0;
    spec += 2;
    *wired |= (uint8_t)(1u << a);
    if (!strncmp(spec, "stuck", 5)) {
      *stuck |= (uint8_t)(1u << a);
      spec += 5;
    } else {
      char *end;
      at_mm[a] = strtod(spec, &end);
      if (end == spec)
        return 0;
      spec = end;
    }
    if (*spec == ',')
      spec++;
    else if (*spec)
      return 0;
  }
  return 1;
}

/* ------------------------------------------------------------ shell hal */

uint32_t hal_millis(void) {
  if (baud)   /* the paced link runs on simulated time: so does the firmware's clock */
    return (uint32_t)(cycles * 1000u / plan_machine()->timer_clock_hz);
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint32_t)((uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u);
}

static double host_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static uint8_t txbuf[4096];
static size_t txlen;

/* The answers ("ok", "error:N") in what goes to the host: each settles the
   oldest line received, as a counting sender counts. */
static void tx_watch(const uint8_t *p, size_t n) {
  for (size_t i = 0; i < n; i++) {
    if (p[i] == '\n') {
      if ((tx_line_len >= 2 && !memcmp(tx_line, "ok", 2)) ||
          (tx_line_len >= 5 && !memcmp(tx_line, "error", 5))) {
        if (owed_tail < owed_head)
          owed_bytes -= owed_len[owed_tail++ % OWED_SIZE];
        if (!host_waited_out) {
          /* a new answer: the host may have the room it lacked. Not after a wait that ran
             out while it had room (its next line known, --expect, or guessed long): it is
             silent, and waiting again at every answer would hold the clock for it as long
             as lines are left to answer */
          host_turn = 1;
          host_waited_out = 0;
          host_turn_since = host_seconds();
        }
      }
      tx_line_len = 0;
    } else if (tx_line_len < sizeof tx_line) {
      tx_line[tx_line_len++] = (char)p[i];
    }
  }
}

static void tx_flush(int block) {
  int c;
  while (txlen < sizeof txbuf && (c = serial_tx_pop()) >= 0)
    txbuf[txlen++] = (uint8_t)c;
  while (txlen) {
    ssize_t n = write(fd_out, txbuf, txlen);
    if (n > 0) {
      if (baud)
        tx_watch(txbuf, (size_t)n);
      memmove(txbuf, txbuf + n, txlen - (size_t)n);
      txlen -= (size_t)n;
      while (txlen < sizeof txbuf && (c = serial_tx_pop()) >= 0)
        txbuf[txlen++] = (uint8_t)c;
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR) && block && !stop_now) {
      fd_set w;
      FD_ZERO(&w);
      FD_SET(fd_out, &w);
      struct timeval tv = {0, 20000};
      select(fd_out + 1, 0, &w, 0, &tv);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR)
      txlen = 0;                 /* output gone: drop */
    return;
  }
}

void hal_serial_tx_kick(void) {
  if (serial_tx_count() > SERIAL_TX_SIZE / 2)
    tx_flush(0);
}
void hal_serial_tx_wait(void) { tx_flush(1); }

/* Input bytes read but not yet delivered (the RX ring was full). */
static uint8_t inbuf[512];
static size_t in_len, in_pos;

/* Bytes the RX handler takes without using the ring: real-time commands and
   every byte above 0x7F (dropped there). */
static int is_rt(uint8_t b) {
  return b == '?' || b == '!' || b == '~' || b == 0x18 || b > 0x7F;
}

static void deliver(void) {
  while (in_pos < in_len) {
    uint8_t b = inbuf[in_pos];
    if (!is_rt(b) && serial_rx_count() >= SERIAL_RX_SIZE) {
      /* ring full: real-time bytes further on still go through at once */
      for (size_t k = in_pos + 1; k < in_len; k++) {
        if (is_rt(inbuf[k])) {
          serial_rx_isr(inbuf[k]);
          memmove(inbuf + k, inbuf + k + 1, in_len - k - 1);
          in_len--;
          k--;
        }
      }
      return;
    }
    serial_rx_isr(b);
    in_pos++;
  }
  in_len = in_pos = 0;
}

/* The panel channel: one event per main-loop pass, as a person turns and
   presses (the menu's queue holds eight). */
static uint8_t panel_buf[64];
static size_t panel_len, panel_pos;
static int panel_fifo;

/* Nothing more will come from a panel file (a FIFO may always bring more). */
static int panel_done(void) { return panel_pos == panel_len && (fd_panel < 0 || panel_fifo); }

static void open_panel(const char *path) {
  struct stat st;
  /* a FIFO is opened for writing too, so that it never reads as ended
     between two writers */
  panel_fifo = stat(path, &st) == 0 && S_ISFIFO(st.st_mode);
  fd_panel = open(path, (panel_fifo ? O_RDWR : O_RDONLY) | O_NONBLOCK);
  if (fd_panel < 0) {
    perror(path);
    exit(1);
  }
}

static void poll_panel(void) {
  static uint32_t last_read_ms;
  /* a hand is slow: look at the channel once per millisecond, not per pass */
  if (panel_pos == panel_len && fd_panel >= 0 && hal_millis() != last_read_ms) {
    last_read_ms = hal_millis();
    ssize_t n = read(fd_panel, panel_buf, sizeof panel_buf);
    if (n > 0) {
      panel_len = (size_t)n;
      panel_pos = 0;
    } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
      close(fd_panel);           /* a file read to its end */
      fd_panel = -1;
    }
  }
  if (panel_pos < panel_len) {
    uint8_t b = panel_buf[panel_pos++];
    if (b == PANEL_ESTOP)
      protocol_estop();          /* the input pin's interrupt: motion and beam off now */
    else if (b == PANEL_CW || b == PANEL_CCW || b == PANEL_OK)
      serial_panel_event(b);
  }
}

/* ---- paced link (--baud) */

/* Put bytes the host wrote on the wire at the simulated time now. */
static void wire_put(const uint8_t *p, size_t n) {
  for (size_t i = 0; i < n; i++) {
    uint8_t b = p[i];
    uint64_t due = (wire_last_due > cycles ? wire_last_due : cycles) + byte_cycles;
    wire_last_due = due;
    if (!is_rt(b)) {
      if (expect_on && (line_bytes_wired >= expect_len || expect_buf[line_bytes_wired] != b)) {
        expect_on = 0;
        expect_off_at = line_bytes_wired + 1;
      }
      line_bytes_wired++;
      /* line ends as the core's line assembler counts them: '\r' and '\n' each end a
         line, but in the labkit-fw dialect the '\n' of an empty "\r\n" does not */
      int crlf_tail = b == '\n' && wire_after_cr && rx_line_len == 0 &&
                      settings.dialect != GC_DIALECT_GRBL;
      wire_after_cr = b == '\r';
      if (!crlf_tail)
        rx_line_len++;
      if ((b == '\n' || b == '\r') && !crlf_tail) {
        if (parse_cycles) {   /* the line reaches the parser once the one before is parsed */
          due = (due > parse_done ? due : parse_done) + parse_cycles;
          parse_done = due;
        }
        if (owed_head - owed_tail < OWED_SIZE) {
          owed_len[owed_head++ % OWED_SIZE] = (uint16_t)(rx_line_len > 65535 ? 65535 : rx_line_len);
          owed_bytes += rx_line_len;
        }
        recent_len[recent_at++ % RECENT_LINES] = rx_line_len;
        rx_line_len = 0;
      }
    }
    wire[wire_head % WIRE_SIZE] = b;
    wire_due[wire_head % WIRE_SIZE] = due;
    wire_head++;
  }
}

/* Hand the core every byte that has arrived by now, in order. */
static void wire_deliver(void) {
  while (wire_tail < wire_head && wire_due[wire_tail % WIRE_SIZE] <= cycles) {
    uint8_t b = wire[wire_tail % WIRE_SIZE];
    if (!is_rt(b) && serial_rx_count() >= SERIAL_RX_SIZE)
      return;                    /* ring full (a sender that does not count): wait */
    serial_rx_isr(b);
    if (!is_rt(b))
      line_bytes_delivered++;
    wire_tail++;
  }
}

/* The bytes of the host's next line still to write, as --expect gives them: through
   the next '\n' (0 once it has written the whole file). */
static size_t expected_line_rest(void) {
  static size_t from = (size_t)-1, rest;
  if (line_bytes_wired != from) {
    from = (size_t)line_bytes_wired;
    const uint8_t *nl = from < expect_len ? memchr(expect_buf + from, '\n', expect_len - from) : 0;
    rest = from >= expect_len ? 0 : nl ? (size_t)(nl - expect_buf) - from + 1 : expect_len - from;
  }
  return rest;
}

/* Without --expect, the host's next line is taken to be as long as the longest of the last
   few: a guess too short would have the simulator wait for a line the host has no room for. */
static uint32_t guessed_line_len(void) {
  uint32_t n = 0;
  for (size_t k = 0; k < RECENT_LINES; k++)
    n = recent_len[k] > n ? recent_len[k] : n;
  return n;
}

/* The host owes a line: it has been answered since it last fell silent, it has
   room for its next line by GRBL's character counting (stream.py: fewer than
   127 bytes in flight with it), and nothing it sent is still on the wire. The
   next line is known with --expect, else guessed (guessed_line_len).
   Silence for HOST_ANSWER_S of wall time (HOST_EXPECT_S with --expect) ends the
   wait until the next answer (the job has ended, or its next line is longer). */
static int waiting_for_host(void) {
  if (!host_turn || wire_tail < wire_head || input_eof)
    return 0;
  if (expect_on) {
    size_t rest = expected_line_rest();
    /* a line begun is finished; a new one needs room */
    if (rest == 0 || (rx_line_len == 0 && owed_bytes + rest >= 127u))
      return 0;
  } else if (owed_bytes + guessed_line_len() >= 127u) {
    return 0;
  }
  if (host_seconds() - host_turn_since > (expect_on ? HOST_EXPECT_S : HOST_ANSWER_S)) {
    host_turn = 0;
    host_waited_out = !plan_is_empty() || !st_is_idle();
    return 0;
  }
  return 1;
}

static void poll_paced(int wait_ms) {
  wire_deliver();
  size_t room = WIRE_SIZE - (wire_head - wire_tail);
  int owed = waiting_for_host();
  fd_set r;
  FD_ZERO(&r);
  FD_SET(fd_in, &r);
  struct timeval tv = {0, (owed ? 1000 : wait_ms * 1000)};
  if (!input_eof && room > 0 && select(fd_in + 1, &r, 0, 0, &tv) > 0) {
    uint8_t buf[512];
    ssize_t n = read(fd_in, buf, room < sizeof buf ? room : sizeof buf);
    if (n > 0) {
      for (ssize_t k = 0; k < n; k++)
        if (!is_rt(buf[k])) {
          /* the host sends lines: keep waiting for it (a status poll alone, '?', is not a
             line on its way and must not hold the clock) */
          host_turn_since = host_seconds();
          if (host_waited_out) {
            /* it could have sent this line before the wait ran out: the simulated clock ran
               on meanwhile, so stops from here on may be the host's, not the link's */
            host_late++;
            host_waited_out = 0;
          }
          break;
        }
      wire_put(buf, (size_t)n);
      wire_deliver();
    } else if (n == 0 || (errno != EAGAIN && errno != EINTR && errno != EIO)) {
      if (fd_in == 0)
        input_eof = 1;
    }
  }
  /* the motors stand: the clock goes on to the next arrival, or with the wall clock */
  double now = host_seconds();
  if (!timer_on && !waiting_for_host()) {
    if (wire_tail < wire_head) {
      uint64_t due = wire_due[wire_tail % WIRE_SIZE];
      if (due > cycles && serial_rx_count() == 0)
        cycles = due;
    } else if (serial_rx_count() == 0 && idle_wall_s > 0) {
      cycles += (uint64_t)((now - idle_wall_s) * (double)plan_machine()->timer_clock_hz);
    }
  }
  idle_wall_s = now;
  wire_deliver();
}

static void poll_input(int wait_ms) {
  if (baud) {
    poll_paced(wait_ms);
    return;
  }
  if (in_len || input_eof) {
    deliver();
    if (!(input_eof && wait_ms > 0))
      return;
  }
  fd_set r;
  FD_ZERO(&r);
  FD_SET(fd_in, &r);
  struct timeval tv = {0, wait_ms * 1000};
  if (input_eof) {
    if (wait_ms > 0)
      select(0, 0, 0, 0, &tv);
    return;
  }
  if (select(fd_in + 1, &r, 0, 0, &tv) <= 0)
    return;
  ssize_t n = read(fd_in, inbuf, sizeof inbuf);
  if (n > 0) {
    in_len = (size_t)n;
    in_pos = 0;
    deliver();
  } else if (n == 0 || (errno != EAGAIN && errno != EINTR && errno != EIO)) {
    if (fd_in == 0)
      input_eof = 1;             /* end of stdin: the stream has ended */
  }
}

#define TICKS_PER_POLL 32

void hal_poll(void) {
  const lk_machine_t *m = plan_machine();
  int idle = !timer_on && serial_tx_count() == 0 && txlen == 0 && serial_rx_count() == 0;
  poll_panel();
  int waiting = timer_on && ahead_of_wall_clock();
  if (baud && (serial_tx_count() || txlen))
    tx_flush(0);                 /* an answer goes out at the moment the core wrote it */
  poll_input(panel_pos == panel_len ? (idle ? 2 : waiting ? 1 : 0) : 0);
  /* paced: no tick while the host owes a line; none past the next byte's arrival */
  int hold_clock = baud && waiting_for_host();
  uint64_t next_due = baud && wire_tail < wire_head ? wire_due[wire_tail % WIRE_SIZE] : UINT64_MAX;
  /* paced: while the main loop makes progress (it took received bytes, which it reads a few
     a pass, or its st_prep_buffer freed a planner slot) it goes on before the clock moves, as
     on the board, where it runs beside the step interrupt: else a line's end read in the
     next pass, or a line waiting for that slot, would wait for the batch of ticks below */
  static uint8_t free_slots;
  static size_t rx_left;
  int busy = baud && (plan_free_slots() > free_slots ||
                      (serial_rx_count() > 0 && serial_rx_count() < rx_left));
  free_slots = plan_free_slots();
  for (int i = 0; i < TICKS_PER_POLL && timer_on && !hold_clock && !busy && !ahead_of_wall_clock() &&
                  cycles < next_due; i++) {
    if (!tick_end)
      tick_end = cycles + ((uint64_t)period_reg + 1u) * ((uint64_t)m->prescaler + 1u);
    if (tick_end > next_due) {
      /* a byte arrives during this tick (a slow tick can span many bytes): the clock goes
         to its arrival and the main loop reads it, as the RX interrupt lets it on a board */
      cycles = next_due;
      break;
    }
    cycles = tick_end;
    tick_end = 0;
    ticks++;
    st_tick();
    if (switch_changed) {        /* the limit pins' change interrupt (hard limits) */
      switch_changed = 0;
      protocol_limit_pin_change();
    }
    /* the main loop keeps up with the interrupt (it must refill within
       ST_PREP_LEAD_MS): top the ticks up while the stepper runs */
    if ((i & 3) == 3 && timer_on)
      st_prep_buffer();
    /* paced: a planner slot freed is back to the main loop at once (a line waiting for it
       is planned and answered then, as on the board, not after the rest of the batch) */
    if (baud && plan_free_slots() != free_slots)
      break;
  }
  free_slots = plan_free_slots();
  rx_left = serial_rx_count();
  if (serial_tx_count() || txlen)
    tx_flush(0);
}

/* ------------------------------------------------------------ main */

static void on_signal(int sig) {
  (void)sig;
  stop_now = 1;
}

static int open_pty(void) {
  int m = posix_openpt(O_RDWR | O_NOCTTY);
  if (m < 0 || grantpt(m) || unlockpt(m))
    return -1;
  const char *name = ptsname(m);
  if (!name)
    return -1;
  pty_slave = open(name, O_RDWR | O_NOCTTY);   /* held open: no EIO while no host is attached */
  if (pty_slave >= 0) {
    struct termios t;
    if (tcgetattr(pty_slave, &t) == 0) {
      cfmakeraw(&t);
      tcsetattr(pty_slave, TCSANOW, &t);
    }
  }
  fcntl(m, F_SETFL, fcntl(m, F_GETFL) | O_NONBLOCK);
  fprintf(stderr, "labkit-fw-sim: pty %s\n", name);
  fflush(stderr);
  return m;
}

/* --expect FILE: the whole file, the host's line bytes in order. */
static int read_expect(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    perror(path);
    return 0;
  }
  size_t cap = 1 << 16;
  expect_buf = malloc(cap);
  size_t n;
  while (expect_buf && (n = fread(expect_buf + expect_len, 1, cap - expect_len, f)) > 0) {
    expect_len += n;
    if (expect_len == cap) {
      uint8_t *more = realloc(expect_buf, cap * 2);
      if (!more)
        break;
      expect_buf = more;
      cap *= 2;
    }
  }
  int full = expect_buf && expect_len == cap;   /* realloc failed: not all of it read */
  int bad = ferror(f) || !expect_buf || full;
  fclose(f);
  if (bad) {
    fprintf(stderr, "labkit-fw-sim: --expect: cannot read %s\n", path);
    return 0;
  }
  expect_on = 1;
  return 1;
}

static void usage(void) {
  fprintf(stderr, "usage: labkit-fw-sim [--pty] [--dialect grbl|labkit-fw] [--trace FILE] "
                  "[--eeprom FILE] [--panel PATH] [--beam-log PATH] [--stats] [--realtime] "
                  "[--switches SPEC] [--probe SPEC] [--baud N [--parse-us US] [--starvation-log FILE] "
                  "[--expect FILE]]\n");
  exit(2);
}

/* A CSV file opened for writing, its header line written: with a buffer of `buffer` bytes (the
   per-tick trace), else the stream's own and the header flushed at once (the logs a reader
   follows while the simulation runs). 0, after perror, when it cannot be opened. */
static FILE *open_csv(const char *path, const char *header, size_t buffer) {
  FILE *f = fopen(path, "w");
  if (!f) {
    perror(path);
    return 0;
  }
  if (buffer)
    setvbuf(f, 0, _IOFBF, buffer);
  fputs(header, f);
  if (!buffer)
    fflush(f);
  return f;
}

int main(int argc, char **argv) {
  int use_pty = 0, stats = 0, dialect = -1;
  const char *trace_path = 0, *beam_log_path = 0, *panel_path = 0, *starve_path = 0;
  const char *expect_path = 0;
  double parse_us = 0.0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--pty"))
      use_pty = 1;
    else if (!strcmp(argv[i], "--stats"))
      stats = 1;
    else if (!strcmp(argv[i], "--realtime"))
      realtime = 1;
    else if (!strcmp(argv[i], "--trace") && i + 1 < argc)
      trace_path = argv[++i];
    else if (!strcmp(argv[i], "--baud") && i + 1 < argc) {
      char *end;
      long v = strtol(argv[++i], &end, 10);
      if (*end || v < 300 || v > 10000000) {
        fprintf(stderr, "labkit-fw-sim: --baud: expected a whole number of baud, 300 to 10000000, "
                        "got '%s'\n", argv[i]);
        return 2;
      }
      baud = (uint32_t)v;
    } else if (!strcmp(argv[i], "--parse-us") && i + 1 < argc) {
      char *end;
      parse_us = strtod(argv[++i], &end);
      if (*end || !(parse_us >= 0.0 && parse_us <= 1e6)) {
        fprintf(stderr, "labkit-fw-sim: --parse-us: expected microseconds per line, 0 to 1000000, "
                        "got '%s'\n", argv[i]);
        return 2;
      }
    } else if (!strcmp(argv[i], "--starvation-log") && i + 1 < argc)
      starve_path = argv[++i];
    else if (!strcmp(argv[i], "--expect") && i + 1 < argc)
      expect_path = argv[++i];
    else if (!strcmp(argv[i], "--beam-log") && i + 1 < argc)
      beam_log_path = argv[++i];
    else if (!strcmp(argv[i], "--panel") && i + 1 < argc)
      panel_path = argv[++i];
    else if ((!strcmp(argv[i], "--switches") || !strcmp(argv[i], "--probe")) && i + 1 < argc) {
      int sw = !strcmp(argv[i], "--switches");
      const char *opt = argv[i];
      if (!(sw ? parse_contacts(argv[++i], &switch_wired, &switch_stuck, switch_mm)
               : parse_contacts(argv[++i], &probe_wired, &probe_stuck, probe_mm))) {
        fprintf(stderr, "labkit-fw-sim: %s: expected AXIS:MM or AXIS:stuck, comma separated "
                        "(X:+5,Y:+5,Z:stuck), got '%s'\n", opt, argv[i]);
        return 2;
      }
    } else if (!strcmp(argv[i], "--eeprom") && i + 1 < argc)
      storage_file(argv[++i]);
    else if (!strcmp(argv[i], "--dialect") && i + 1 < argc) {
      i++;
      if (!strcmp(argv[i], "grbl"))
        dialect = GC_DIALECT_GRBL;
      else if (!strcmp(argv[i], "labkit-fw"))
        dialect = GC_DIALECT_LABKIT;
      else
        usage();
    } else
      usage();
  }
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  signal(SIGPIPE, SIG_IGN);
  if (use_pty) {
    int m = open_pty();
    if (m < 0) {
      perror("labkit-fw-sim: pty");
      return 1;
    }
    fd_in = fd_out = m;
  }
  if (trace_path &&
      !(trace = open_csv(trace_path, "time_s,cycle,block,line,x,y,z,dir,period,power_mw\n", 1 << 20)))
    return 1;
  if (beam_log_path && !(beam_log = open_csv(beam_log_path, "time_s,duty,state,line\n", 0)))
    return 1;
  if (panel_path)
    open_panel(panel_path);
  if ((starve_path || parse_us > 0 || expect_path) && !baud) {
    fprintf(stderr, "labkit-fw-sim: --starvation-log, --parse-us and --expect need --baud\n");
    return 2;
  }
  if (expect_path && !read_expect(expect_path))
    return 1;
  if (baud && realtime) {
    fprintf(stderr, "labkit-fw-sim: --baud runs on simulated time; leave out --realtime\n");
    return 2;
  }
  if (starve_path && !(starve_log = open_csv(starve_path, "time_s,line,duration_s\n", 0)))
    return 1;
  double t0 = host_seconds();
  if (dialect >= 0) {
    /* choose the dialect before the banner: as if $208 had been stored */
    settings_t s;
    if (!hal_storage_read(&s, sizeof s) || s.magic != SETTINGS_MAGIC || s.size != sizeof s ||
        s.checksum != settings_checksum(&s))
      settings_defaults(&s);
    s.dialect = (uint8_t)dialect;
    s.checksum = settings_checksum(&s);
    hal_storage_write(&s, sizeof s);
  }
  protocol_startup();
  switch_seen = hal_limits_read();
  if (baud) {
    double hz = (double)plan_machine()->timer_clock_hz;
    byte_cycles = (uint64_t)(hz * 10.0 / baud + 0.5);
    parse_cycles = (uint64_t)(hz * parse_us * 1e-6 + 0.5);
  }
  while (!stop_now) {
    protocol_poll();
    if (input_eof && in_len == 0 && wire_tail == wire_head && serial_rx_count() == 0 &&
        panel_done()) {
      /* end of the stream: run out the look-ahead, then stop */
      plan_flush();
      while (!stop_now && (!st_is_idle() || !plan_is_empty())) {
        protocol_poll();
        if (st_is_idle() && !plan_is_empty())
          plan_flush();
      }
      protocol_poll();
      break;
    }
  }
  tx_flush(1);
  if (trace)
    fclose(trace);
  if (beam_log)
    fclose(beam_log);
  if (starve_log)
    fclose(starve_log);
  if (expect_path && !expect_on)
    fprintf(stderr, "labkit-fw-sim: --expect: the host's line byte %llu differs from %s (or the "
                    "file has fewer bytes); the host's next line was guessed from there\n",
            (unsigned long long)expect_off_at, expect_path);
  free(expect_buf);
  if (baud && host_late)
    fprintf(stderr, "labkit-fw-sim: the host was late %lu times (a line it had room for came more "
                    "than %.2f s of wall time after its answer)\n", host_late, HOST_ANSWER_S);
  if (stats) {
    double host = host_seconds() - t0;
    double sim = (double)cycles / (double)plan_machine()->timer_clock_hz;
    int32_t st[3];
    st_get_position(st);
    fprintf(stderr,
            "labkit-fw-sim: %u blocks, %llu ticks, %.3f s simulated in %.3f s host time "
            "(%.0f blocks/s, %.0f ticks/s, x%.1f real time); position %d %d %d steps; laser duty %u\n",
            blocks_seen, (unsigned long long)ticks, sim, host, host > 0 ? blocks_seen / host : 0.0,
            host > 0 ? ticks / host : 0.0, host > 0 ? sim / host : 0.0, st[0], st[1], st[2],
            laser_duty);
  }
  return 0;
}
