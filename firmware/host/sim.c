/*
  sim.c - the labkit firmware on the host: the same core and shell, with a
  hal whose step timer advances a simulated clock.

    labkit-fw-sim [--pty] [--dialect grbl|labkit-fw] [--trace FILE]
                  [--eeprom FILE] [--panel PATH] [--beam-log PATH] [--stats]
                  [--realtime] [--switches SPEC]

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
  spec is what grbl-sim was given for the homing transcripts
  (tests/vectors/grbl/README.md). Without the option no switch is wired.

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

static int fd_in = 0, fd_out = 1, pty_slave = -1, fd_panel = -1;
static int input_eof;
static volatile sig_atomic_t stop_now;

/* simulated hardware */
static uint8_t dir_bits;
static int32_t pos_steps[3];
static uint32_t period_reg;
static int timer_on;
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

/* storage */
static const char *eeprom_path;
static uint8_t eeprom[4096];
static uint32_t eeprom_len;

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
void hal_timer_stop(void) { timer_on = 0; }
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

uint8_t hal_limits_read(void) {
  const lk_machine_t *m = plan_machine();
  uint8_t pressed = switch_stuck;
  for (int a = 0; a < 3; a++) {
    if (!(switch_wired & (1u << a)) || (switch_stuck & (1u << a)))
      continue;
    double mm = (double)pos_steps[a] / m->steps_per_mm[a];
    if (switch_mm[a] >= 0 ? mm >= switch_mm[a] : mm <= switch_mm[a])
      pressed |= (uint8_t)(1u << a);
  }
  return pressed;
}

/* "X:+5,Y:+5,Z:stuck" (see the head of this file); 0 when the spec is malformed */
static int parse_switches(const char *spec) {
  while (*spec) {
    int a = spec[0] == 'X' ? 0 : spec[0] == 'Y' ? 1 : spec[0] == 'Z' ? 2 : -1;
    if (a < 0 || spec[1] != ':')
      return 0;
    spec += 2;
    switch_wired |= (uint8_t)(1u << a);
    if (!strncmp(spec, "stuck", 5)) {
      switch_stuck |= (uint8_t)(1u << a);
      spec += 5;
    } else {
      char *end;
      switch_mm[a] = strtod(spec, &end);
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

static void tx_flush(int block) {
  int c;
  while (txlen < sizeof txbuf && (c = serial_tx_pop()) >= 0)
    txbuf[txlen++] = (uint8_t)c;
  while (txlen) {
    ssize_t n = write(fd_out, txbuf, txlen);
    if (n > 0) {
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

uint8_t hal_storage_read(void *buf, uint32_t len) {
  if (eeprom_path) {
    FILE *f = fopen(eeprom_path, "rb");
    if (f) {
      eeprom_len = (uint32_t)fread(eeprom, 1, sizeof eeprom, f);
      fclose(f);
    }
  }
  if (len > eeprom_len)
    return 0;
  memcpy(buf, eeprom, len);
  return 1;
}

uint8_t hal_storage_write(const void *buf, uint32_t len) {
  if (len > sizeof eeprom)
    return 0;
  memcpy(eeprom, buf, len);
  eeprom_len = len;
  if (eeprom_path) {
    FILE *f = fopen(eeprom_path, "wb");
    if (!f || fwrite(buf, 1, len, f) != len) {
      if (f)
        fclose(f);
      return 0;
    }
    fclose(f);
  }
  return 1;
}

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

static void poll_input(int wait_ms) {
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
  poll_input(panel_pos == panel_len ? (idle ? 2 : waiting ? 1 : 0) : 0);
  for (int i = 0; i < TICKS_PER_POLL && timer_on && !ahead_of_wall_clock(); i++) {
    cycles += ((uint64_t)period_reg + 1u) * ((uint64_t)m->prescaler + 1u);
    ticks++;
    st_tick();
    /* the main loop keeps up with the interrupt (it must refill within
       ST_PREP_LEAD_MS): top the ticks up while the stepper runs */
    if ((i & 3) == 3 && timer_on)
      st_prep_buffer();
  }
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

static void usage(void) {
  fprintf(stderr, "usage: labkit-fw-sim [--pty] [--dialect grbl|labkit-fw] [--trace FILE] "
                  "[--eeprom FILE] [--panel PATH] [--beam-log PATH] [--stats] [--realtime] "
                  "[--switches SPEC]\n");
  exit(2);
}

int main(int argc, char **argv) {
  int use_pty = 0, stats = 0, dialect = -1;
  const char *trace_path = 0, *beam_log_path = 0, *panel_path = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--pty"))
      use_pty = 1;
    else if (!strcmp(argv[i], "--stats"))
      stats = 1;
    else if (!strcmp(argv[i], "--realtime"))
      realtime = 1;
    else if (!strcmp(argv[i], "--trace") && i + 1 < argc)
      trace_path = argv[++i];
    else if (!strcmp(argv[i], "--beam-log") && i + 1 < argc)
      beam_log_path = argv[++i];
    else if (!strcmp(argv[i], "--panel") && i + 1 < argc)
      panel_path = argv[++i];
    else if (!strcmp(argv[i], "--switches") && i + 1 < argc) {
      if (!parse_switches(argv[++i])) {
        fprintf(stderr, "labkit-fw-sim: --switches: expected AXIS:MM or AXIS:stuck, comma separated "
                        "(X:+5,Y:+5,Z:stuck), got '%s'\n", argv[i]);
        return 2;
      }
    } else if (!strcmp(argv[i], "--eeprom") && i + 1 < argc)
      eeprom_path = argv[++i];
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
  if (trace_path) {
    trace = fopen(trace_path, "w");
    if (!trace) {
      perror(trace_path);
      return 1;
    }
    setvbuf(trace, 0, _IOFBF, 1 << 20);
    fprintf(trace, "time_s,cycle,block,line,x,y,z,dir,period,power_mw\n");
  }
  if (beam_log_path) {
    beam_log = fopen(beam_log_path, "w");
    if (!beam_log) {
      perror(beam_log_path);
      return 1;
    }
    fprintf(beam_log, "time_s,duty,state,line\n");
    fflush(beam_log);
  }
  if (panel_path)
    open_panel(panel_path);
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
  while (!stop_now) {
    protocol_poll();
    if (input_eof && in_len == 0 && serial_rx_count() == 0 && panel_done()) {
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
