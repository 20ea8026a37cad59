/*
  stepper.c - ticks prepared in the main loop, pulses in the step interrupt.

  st_prep_buffer() (main loop) evaluates each block's rate program tick by
  tick (labkit.motion.timer: f_k, the period register, the laser power),
  finds the tick's steps with the block's Bresenham line or octant arc walk
  (arc.c), and queues {period, steps, directions, duty}. st_tick()
  (interrupt) pulses the steps of the tick that ended, counts them into the
  position, pops the next tick and sets its directions, duty and period: no
  arithmetic beyond that, as grbl's stepper.c.
*/
#include "stepper.h"

#include <string.h>

#include "arc.h"
#include "config.h"
#include "hal.h"
#include "laser.h"
#include "planner.h"

#define TICK_NEW_BLOCK 0x01u
#define TICK_DWELL     0x02u

typedef struct {
  uint32_t period;         /* timer register of the tick's first period */
  uint32_t extra;          /* timer counts after it (a tick longer than the register) */
  uint32_t cycles;         /* the tick's clock cycles, (period + 1) x (prescaler + 1) */
  uint32_t rate;           /* step rate, Hz */
  uint16_t duty;
  uint8_t bits;            /* axes stepping at the end of the tick */
  uint8_t dir;             /* direction output during the tick (bit set: negative) */
  uint8_t flags;
  uint8_t slot;
} st_tick_t;

static st_tick_t tick_buf[ST_TICK_BUFFER_SIZE];
static volatile uint32_t tick_head, tick_tail;      /* head: main loop, tail: interrupt */
static st_block_info_t blk_buf[ST_BLOCK_BUFFER_SIZE];
static volatile uint32_t blk_head, blk_tail;        /* tail: the running block */

/* main loop: the block being prepared */
static struct {
  plan_block_t *b;
  uint32_t k;
  uint32_t slot;
  uint64_t dwell_left;     /* timer clock cycles */
  uint8_t law;
  uint32_t last_rate;
  uint8_t ramp;            /* resuming: rate limited to ramp_rate */
  uint32_t ramp_rate;
  uint32_t cycles;         /* clock cycles of the ticks prepared (mod 2^32) */
  uint8_t dir;             /* direction output after the last prepared tick */
  /* the block's walk: Bresenham of a line, or octant walk of an arc plus its helix axis */
  int32_t delta[3];        /* |steps| per axis (lines) */
  int32_t err[3];
  uint8_t a0, a1, lin;     /* arc plane axes */
  int32_t helix;           /* |steps| of the helix axis */
  uint8_t helix_neg;
  int32_t herr;
  arc_kept_t kept;         /* the arc's steps as the planner counted them, or len 0 */
  arc_walk_t arc;          /* else its walk */
  int32_t ax, ay;          /* arc position in its plane (steps) */
} prep;

/* interrupt state */
static struct {
  volatile uint8_t running;
  volatile uint8_t state;
  volatile uint8_t abort;
  uint8_t have_block, loaded_any;
  uint32_t slot;
  uint8_t dwell;
  uint8_t dir_out;
  uint8_t pending_bits;
  uint8_t pending;
  uint32_t extra_counts;   /* timer counts of the tick still to run after this period */
  uint32_t max_counts;     /* 2^timer_bits, capped */
  volatile uint32_t done_cycles;   /* clock cycles of the ticks loaded (mod 2^32) */
  volatile int32_t pos[3];
  volatile uint32_t rate;
  /* G38.x: while armed, the probe pin is read after every tick's steps (GRBL's
     probe_state_monitor in its step interrupt); the first read at probe_level keeps the
     position, so the touch is where the steps were, not where the main loop saw it */
  volatile uint8_t probe_armed, probe_tripped;
  uint8_t probe_level;
  int32_t probe_pos[3];
} sti;

static uint32_t block_seq;

void st_init(void)
{
  memset(&prep, 0, sizeof prep);
  memset(&sti, 0, sizeof sti);
  tick_head = tick_tail = 0;
  blk_head = blk_tail = 0;
  block_seq = 0;
  sti.state = ST_IDLE;
  hal_timer_stop();
  hal_set_dir(0);
}

/* ------------------------------------------------------------------ interrupt */

/* load the next prepared tick; 0 when there is none */
static int load_tick(void)
{
  if (tick_tail == tick_head) return 0;
  const st_tick_t *t = &tick_buf[tick_tail % ST_TICK_BUFFER_SIZE];
  if (t->flags & TICK_NEW_BLOCK) {
    if (sti.loaded_any) blk_tail++;   /* the previous block's slot is free now */
    sti.loaded_any = 1;
    sti.have_block = 1;
    sti.slot = t->slot;
    sti.dwell = (t->flags & TICK_DWELL) != 0;
  }
  if (t->dir != sti.dir_out) {
    sti.dir_out = t->dir;
    hal_set_dir(t->dir);
  }
  /* beam off from the moment a hold is taken: the deceleration is not a cut */
  laser_output(sti.state == ST_HOLDING ? 0 : t->duty);
  sti.rate = t->rate;
  sti.done_cycles += t->cycles;
  sti.extra_counts = t->extra;
  hal_timer_set_period(t->period);
  sti.pending_bits = t->bits;
  sti.pending = 1;
  tick_tail++;
  return 1;
}

void st_tick(void)
{
  if (!sti.running) return;
  if (sti.extra_counts) {
    uint32_t c = sti.extra_counts < sti.max_counts ? sti.extra_counts : sti.max_counts;
    sti.extra_counts -= c;
    hal_timer_set_period(c - 1u);
    return;
  }
  if (sti.pending) {
    uint8_t bits = sti.pending_bits, neg = sti.dir_out & bits;
    hal_step_pulse(bits);
    if (bits & 1u) sti.pos[0] += (neg & 1u) ? -1 : 1;
    if (bits & 2u) sti.pos[1] += (neg & 2u) ? -1 : 1;
    if (bits & 4u) sti.pos[2] += (neg & 4u) ? -1 : 1;
    sti.pending = 0;
  }
  if (sti.probe_armed && hal_probe_read() == sti.probe_level) {
    sti.probe_pos[0] = sti.pos[0];
    sti.probe_pos[1] = sti.pos[1];
    sti.probe_pos[2] = sti.pos[2];
    sti.probe_armed = 0;
    sti.probe_tripped = 1;
  }
  if (!load_tick()) {
    hal_timer_stop();
    laser_output(0);
    sti.running = 0;
    sti.rate = 0;
    if (sti.state == ST_HOLDING) {
      sti.state = ST_HELD;
      laser_off();
    } else if (sti.state != ST_HELD) {
      sti.state = ST_IDLE;
    }
  }
}

static void wake_up(void)
{
  if (sti.running || tick_tail == tick_head) return;
  {
    uint32_t bits = plan_machine()->timer_bits;
    sti.max_counts = bits >= 32 ? 0x80000000u : (1u << bits);
  }
  if (sti.state == ST_HELD || sti.state == ST_HOLDING) return;
  sti.running = 1;
  sti.state = ST_RUN;
  load_tick();
  hal_timer_start();
}

/* ------------------------------------------------------------------ main loop */

static void copy_block_info(st_block_info_t *in, const plan_block_t *b)
{
  memset(in, 0, sizeof *in);
  in->seq = ++block_seq;
  in->kind = b->kind;
  in->rapid = b->rapid;
  in->laser = b->laser;
  in->dir_bits = b->dir_bits;
  in->line = b->line;
  in->super_block = b->super_block;
  memcpy(in->start_steps, b->start_steps, sizeof in->start_steps);
  memcpy(in->end_steps, b->end_steps, sizeof in->end_steps);
  in->ticks = b->ticks;
  in->f_entry = b->f_entry;
  in->f_peak = b->f_peak;
  in->f_exit = b->f_exit;
  in->f_min = b->f_min;
  in->up = b->up;
  in->down = b->down;
  in->f_feed = b->f_feed;
  in->power_mw = b->power_mw;
  in->length_mm = b->length_mm;
  in->entry_mm_s = b->entry_mm_s;
  in->peak_mm_s = b->peak_mm_s;
  in->exit_mm_s = b->exit_mm_s;
  in->dwell_cycles = b->dwell_cycles;
}

/* the walk of block b from its first tick (labkit.motion.bresenham) */
static void start_walk(const plan_block_t *b)
{
  int32_t n = (int32_t)b->ticks;
  for (int a = 0; a < 3; a++) {
    int32_t d = b->end_steps[a] - b->start_steps[a];
    prep.delta[a] = d < 0 ? -d : d;
    prep.err[a] = 2 * prep.delta[a] - n;
  }
  if (b->kind == PLAN_BLOCK_ARC) {
    static const uint8_t axes[3][3] = {{0, 1, 2}, {2, 0, 1}, {1, 2, 0}};
    prep.a0 = axes[b->plane][0];
    prep.a1 = axes[b->plane][1];
    prep.lin = axes[b->plane][2];
    int32_t h = b->end_steps[prep.lin] - b->start_steps[prep.lin];
    prep.helix = h < 0 ? -h : h;
    prep.helix_neg = h < 0;
    prep.herr = 2 * prep.helix - n;
    prep.kept = b->kept;
    prep.arc = b->arc;
    prep.ax = b->start_steps[prep.a0];
    prep.ay = b->start_steps[prep.a1];
  }
}

/* the steps (bits) and their negative directions (bits) of the block's next tick */
static void walk_steps(const plan_block_t *b, uint8_t *bits, uint8_t *neg)
{
  uint8_t s = 0, ng = 0;
  const int32_t n2 = 2 * (int32_t)b->ticks;
  if (b->kind == PLAN_BLOCK_LINE) {
    for (int a = 0; a < 3; a++) {
      if (prep.err[a] >= 0) {
        s |= (uint8_t)(1u << a);
        prep.err[a] -= n2;
      }
      prep.err[a] += 2 * prep.delta[a];
    }
    ng = b->dir_bits & s;
  } else if (b->kind == PLAN_BLOCK_ARC && prep.kept.len) {
    uint8_t c = arc_kept_step(&prep.kept, prep.k);
    if (c & ARC_STEP_A0) s |= (uint8_t)(1u << prep.a0);
    if (c & ARC_NEG_A0) ng |= (uint8_t)(1u << prep.a0);
    if (c & ARC_STEP_A1) s |= (uint8_t)(1u << prep.a1);
    if (c & ARC_NEG_A1) ng |= (uint8_t)(1u << prep.a1);
  } else if (b->kind == PLAN_BLOCK_ARC) {
    int32_t x, y;
    if (arc_next(&prep.arc, &x, &y) == 1) {
      int32_t dx = x - prep.ax, dy = y - prep.ay;
      if (dx) {
        s |= (uint8_t)(1u << prep.a0);
        if (dx < 0) ng |= (uint8_t)(1u << prep.a0);
      }
      if (dy) {
        s |= (uint8_t)(1u << prep.a1);
        if (dy < 0) ng |= (uint8_t)(1u << prep.a1);
      }
      prep.ax = x;
      prep.ay = y;
    }
  }
  if (b->kind == PLAN_BLOCK_ARC) {   /* the helix axis, by the line rule */
    if (prep.herr >= 0) {
      s |= (uint8_t)(1u << prep.lin);
      if (prep.helix_neg) ng |= (uint8_t)(1u << prep.lin);
      prep.herr -= n2;
    }
    prep.herr += 2 * prep.helix;
  }
  *bits = s;
  *neg = ng;
}

static int start_block(void)
{
  plan_block_t *b = plan_get_current_block();
  if (!b) return 0;
  if (blk_head - blk_tail >= ST_BLOCK_BUFFER_SIZE) return 0;
  copy_block_info(&blk_buf[blk_head % ST_BLOCK_BUFFER_SIZE], b);
  start_walk(b);
  prep.b = b;
  prep.k = 0;
  prep.slot = blk_head;
  prep.law = plan_get_law();
  prep.dwell_left = b->kind == PLAN_BLOCK_DWELL ? b->dwell_cycles : 0;
  blk_head++;
  return 1;
}

static void end_block(void)
{
  if (prep.b->kind == PLAN_BLOCK_ARC) arc_keep_release(&prep.kept);
  plan_discard_current_block();
  prep.b = NULL;
}

/* the tick's period as the timer runs it: a tick longer than the period
   register runs as several periods, its step pulse at the end of the last */
static void set_tick_period(st_tick_t *t, uint32_t period, const lk_machine_t *m)
{
  uint32_t max_counts = m->timer_bits >= 32 ? 0x80000000u : (1u << m->timer_bits);
  uint32_t counts = period + 1u;
  if (counts == 0u || counts > max_counts) {
    t->period = max_counts - 1u;
    t->extra = period - (max_counts - 1u);
  } else {
    t->period = period;
    t->extra = 0;
  }
  t->cycles = (period + 1u) * (m->prescaler + 1u);
}

void st_prep_buffer(void)
{
  const lk_machine_t *m = plan_machine();
  const uint32_t lead_max = m->timer_clock_hz / 1000u * ST_PREP_LEAD_MS;
  if (tick_head == tick_tail) prep.cycles = sti.done_cycles;   /* nothing queued */
  for (;;) {
    if (sti.state == ST_HELD) break;
    if (tick_head - tick_tail >= ST_TICK_BUFFER_SIZE) break;
    if (prep.cycles - sti.done_cycles > lead_max) break;
    if (!prep.b && !start_block()) break;
    plan_block_t *b = prep.b;
    st_tick_t t;
    uint8_t bits = 0, neg = 0;
    t.slot = (uint8_t)(prep.slot % ST_BLOCK_BUFFER_SIZE);
    t.flags = prep.k == 0 ? TICK_NEW_BLOCK : 0;
    if (b->kind == PLAN_BLOCK_DWELL) {
      if (prep.dwell_left == 0) {
        /* a dwell of no time (G4 P0) queues no tick: the interrupt never loads it, so its slot
           of the stepper's block ring is given back here (else four of them filled the ring
           and no block could start again until a reset) */
        if (prep.k == 0) blk_head--;
        end_block();
        continue;
      }
      uint32_t per = m->prescaler + 1;
      uint64_t counts = (prep.dwell_left + per - 1) / per;
      uint64_t top = 1ull << m->timer_bits;
      if (counts > top) counts = top;
      set_tick_period(&t, (uint32_t)(counts - 1), m);
      t.rate = 0;
      t.duty = 0;
      t.flags |= TICK_DWELL;
      uint64_t used = counts * per;
      prep.dwell_left = used >= prep.dwell_left ? 0 : prep.dwell_left - used;
      prep.k++;
    } else {
      uint32_t f = plan_tick_rate(b, prep.k, prep.law);
      if (sti.state == ST_HOLDING) {
        /* one tick of the block's deceleration below the last rate */
        uint32_t lim;
        if (prep.law == PLAN_LAW_LINEAR) {
          lim = prep.last_rate > b->down ? prep.last_rate - b->down : 0;
        } else {
          uint64_t sq = (uint64_t)prep.last_rate * prep.last_rate;
          lim = sq > 2ull * b->down ? plan_isqrt(sq - 2ull * b->down) : 0;
        }
        if (lim <= b->f_min) break;   /* stopped: keep the rest for the resume */
        if (f > lim) f = lim;
      } else if (prep.ramp) {
        uint32_t lim = prep.law == PLAN_LAW_LINEAR
                           ? prep.ramp_rate + b->up
                           : plan_isqrt((uint64_t)prep.ramp_rate * prep.ramp_rate + 2ull * b->up);
        if (f > lim) {
          f = lim;
          prep.ramp_rate = lim;
        } else {
          prep.ramp = 0;
        }
      }
      prep.last_rate = f;
      t.rate = f;
      set_tick_period(&t, plan_timer_period(f), m);
      double p = laser_override_mw(
          laser_tick_power_mw(b->laser, b->power_mw, b->f_feed, f, m->laser_max_power_mw),
          m->laser_max_power_mw);
      t.duty = laser_duty_from_mw(p, m->laser_max_power_mw);
      walk_steps(b, &bits, &neg);
      prep.k++;
    }
    /* an axis that does not step keeps its direction pin (as the interrupt did) */
    prep.dir = (uint8_t)((prep.dir & (uint8_t)~bits) | neg);
    t.bits = bits;
    t.dir = prep.dir;
    tick_buf[tick_head % ST_TICK_BUFFER_SIZE] = t;
    prep.cycles += t.cycles;
    tick_head++;
    if (b->kind != PLAN_BLOCK_DWELL && prep.k >= b->ticks) end_block();
    else if (b->kind == PLAN_BLOCK_DWELL && prep.dwell_left == 0) end_block();
  }
  if (sti.state != ST_HOLDING) wake_up();
}

void st_feed_hold(void)
{
  if (sti.state == ST_RUN) sti.state = ST_HOLDING;
  /* momentarily idle with work queued: hold it before it starts */
  if (sti.state == ST_IDLE && (!plan_is_empty() || tick_head != tick_tail)) sti.state = ST_HOLDING;
  if (!sti.running && sti.state == ST_HOLDING) {
    sti.state = ST_HELD;
    laser_off();
  }
}

void st_resume(void)
{
  if (sti.state != ST_HELD && sti.state != ST_HOLDING) return;
  sti.state = ST_RUN;
  if (prep.b && prep.b->kind != PLAN_BLOCK_DWELL) {   /* ramp up from where the hold left */
    prep.ramp = 1;
    prep.ramp_rate = prep.last_rate > prep.b->f_min ? prep.last_rate : prep.b->f_min;
  }
  st_prep_buffer();
}

void st_reset(void)
{
  hal_irq_disable();
  hal_timer_stop();
  laser_off();
  tick_head = tick_tail = 0;
  blk_head = blk_tail = 0;
  prep.b = NULL;
  prep.ramp = 0;
  prep.cycles = sti.done_cycles;
  prep.dir = sti.dir_out;   /* the pins as the last tick left them */
  sti.running = 0;
  sti.pending = 0;
  sti.extra_counts = 0;
  sti.have_block = 0;
  sti.loaded_any = 0;
  sti.rate = 0;
  sti.state = ST_IDLE;
  sti.abort = 1;
  sti.probe_armed = 0;     /* a trip already seen stays for st_probe_tripped() */
  block_seq = 0;
  plan_reset();
  int32_t p[3] = {sti.pos[0], sti.pos[1], sti.pos[2]};
  plan_sync_position(p);
  hal_irq_enable();
}

void st_probe_arm(uint8_t pin_level)
{
  hal_irq_disable();
  sti.probe_level = pin_level ? 1u : 0u;
  sti.probe_tripped = 0;
  sti.probe_armed = 1;
  hal_irq_enable();
}

void st_probe_disarm(void)
{
  sti.probe_armed = 0;
  sti.probe_tripped = 0;
}

uint8_t st_probe_tripped(int32_t steps[3])
{
  if (!sti.probe_tripped) return 0;
  for (int a = 0; a < 3; a++) steps[a] = sti.probe_pos[a];
  sti.probe_tripped = 0;
  return 1;
}

uint8_t st_take_abort(void)
{
  uint8_t a = sti.abort;
  sti.abort = 0;
  return a;
}

uint8_t st_state(void)
{
  if (sti.state == ST_RUN && sti.have_block && sti.dwell) return ST_DWELL;
  return sti.state;
}

uint8_t st_is_idle(void) { return !sti.running && sti.state == ST_IDLE; }

void st_get_position(int32_t steps[3])
{
  for (int a = 0; a < 3; a++) steps[a] = sti.pos[a];
}

void st_set_position(const int32_t steps[3])
{
  hal_irq_disable();
  for (int a = 0; a < 3; a++) sti.pos[a] = steps[a];
  hal_irq_enable();
}

void st_get_position_mm(float mm[3])
{
  const lk_machine_t *m = plan_machine();
  for (int a = 0; a < 3; a++) mm[a] = (float)((double)sti.pos[a] / m->steps_per_mm[a]);
}

uint32_t st_current_rate_hz(void) { return sti.running ? sti.rate : 0; }

const st_block_info_t *st_running_block(void)
{
  if (!sti.have_block) return NULL;
  return &blk_buf[sti.slot % ST_BLOCK_BUFFER_SIZE];
}

uint32_t st_current_line(void)
{
  const st_block_info_t *b = st_running_block();
  return b ? b->line : 0;
}

double st_current_power_mw(void)
{
  const st_block_info_t *b = st_running_block();
  if (!b || b->kind == PLAN_BLOCK_DWELL || sti.state == ST_HOLDING || sti.state == ST_HELD) return 0.0;
  double max_mw = plan_machine()->laser_max_power_mw;
  return laser_override_mw(laser_tick_power_mw(b->laser, b->power_mw, b->f_feed, sti.rate, max_mw),
                           max_mw);
}
