/*
  sim.c - the labkit firmware on the host: the same core and shell, with a
  hal whose step timer advances a simulated clock.

    labkit-fw-sim [--pty] [--dialect grbl|labkit-fw] [--trace FILE]
                  [--eeprom FILE] [--stats]

  Serial: stdin/stdout by default; --pty creates a pseudo-terminal and
  prints its path on stderr ("labkit-fw-sim: pty /dev/pts/N"); open it with
  pyserial (any baud rate). The banner is written at start; a host that
  opened the pty later asks for one with Ctrl-X (0x18), as for GRBL.

  Time: every step-timer tick adds (period + 1) x (prescaler + 1) timer
  cycles to the simulated clock and calls st_tick(), as the timer interrupt
  does. Nothing depends on the host's speed except when the look-ahead is
  flushed because the input went quiet (30 ms of wall time, protocol.c).
  The simulation runs as fast as the host allows.

  Trace (--trace FILE): one CSV row per tick, the columns of
  `labkit steps` (labkit.motion.timer.StepTrace.to_dataframe):
    time_s,cycle,block,line,x,y,z,dir,period,power_mw
  x y z are -1/0/+1 steps, time_s the step pulse at the end of the tick;
  dwell ticks are left out (labkit's trace has none).

  Control panel (menu.c) and e-stop as bytes in the input (serial.h):
    0xB0 encoder clockwise, 0xB1 counter-clockwise, 0xB2 OK, 0xB8 e-stop.
  `$LCD` prints the LCD's four lines.

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
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "config.h"
#include "gcode.h"
#include "hal.h"
#include "laser.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"

static int fd_in = 0, fd_out = 1, pty_slave = -1;
static int input_eof;
static volatile sig_atomic_t stop_now;

/* simulated hardware */
static uint8_t dir_bits;
static int32_t pos_steps[3];
static uint32_t period_reg;
static int timer_on;
static uint16_t laser_duty;
static uint64_t cycles;           /* simulated timer clock cycles since start */
static uint64_t ticks;
static uint32_t blocks_seen;
static FILE *trace;
static uint32_t tick_block, tick_line;
static double tick_power_mw;
static uint8_t tick_dwell;

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
void hal_timer_start(void) { timer_on = 1; }
void hal_timer_stop(void) { timer_on = 0; }
void hal_laser_set(uint16_t duty) { laser_duty = duty; }
void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille) { (void)pwm_hz; (void)on_permille; }
void hal_air_set(uint8_t bits) { (void)bits; }
void hal_irq_disable(void) {}
void hal_irq_enable(void) {}

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

static int is_rt(uint8_t b) {
  return b == '?' || b == '!' || b == '~' || b == 0x18 || b == 0x84 || b == 0x85 ||
         (b >= 0x90 && b <= 0x9D) || b == PANEL_CW || b == PANEL_CCW || b == PANEL_OK ||
         b == PANEL_ESTOP;
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
    if (b == PANEL_ESTOP)
      protocol_estop();          /* the input pin's interrupt: motion and beam off now */
    serial_rx_isr(b);
    in_pos++;
  }
  in_len = in_pos = 0;
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
  poll_input(idle ? 2 : 0);
  for (int i = 0; i < TICKS_PER_POLL && timer_on; i++) {
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
                  "[--eeprom FILE] [--stats]\n");
  exit(2);
}

int main(int argc, char **argv) {
  int use_pty = 0, stats = 0, dialect = -1;
  const char *trace_path = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--pty"))
      use_pty = 1;
    else if (!strcmp(argv[i], "--stats"))
      stats = 1;
    else if (!strcmp(argv[i], "--trace") && i + 1 < argc)
      trace_path = argv[++i];
    else if (!strcmp(argv[i], "--eeprom") && i + 1 < argc)
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
    if (input_eof && in_len == 0 && serial_rx_count() == 0) {
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
