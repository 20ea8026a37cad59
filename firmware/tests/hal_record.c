/* hal_record.c - the recording hal of the firmware tests (see hal_record.h). */
#include "hal_record.h"

#include <stdlib.h>
#include <string.h>

#include <stdio.h>

#include "gcode.h"
#include "hal.h"
#include "laser.h"
#include "planner.h"

rec_t rec;
static uint32_t rec_cap;

void hal_record_reset(void)
{
  free(rec.ticks);
  free(rec.blocks);
  memset(&rec, 0, sizeof rec);
  rec_cap = 0;
}

static void add_tick(uint32_t period)
{
  const lk_machine_t *m = plan_machine();
  if (rec.n_ticks == rec_cap) {   /* grow geometrically: jobs reach millions of ticks */
    rec_cap = rec_cap ? 2u * rec_cap : 4096u;
    rec.ticks = realloc(rec.ticks, rec_cap * sizeof *rec.ticks);
    if (!rec.ticks) abort();
  }
  rec_tick_t *t = &rec.ticks[rec.n_ticks++];
  memset(t, 0, sizeof *t);
  const st_block_info_t *b = st_running_block();
  if (b) {
    if (rec.n_blocks == 0 || rec.blocks[rec.n_blocks - 1].seq != b->seq) {
      if ((rec.n_blocks & 63u) == 0)
        rec.blocks = realloc(rec.blocks, (rec.n_blocks + 64u) * sizeof *rec.blocks);
      rec.blocks[rec.n_blocks++] = *b;
    }
    t->seq = b->seq;
  }
  t->period = period;
  t->rate = st_current_rate_hz();
  t->power_mw = st_current_power_mw();
  t->duty = rec.duty;
  rec.cycles += ((uint64_t)period + 1) * ((uint64_t)m->prescaler + 1);
  t->cycles_end = rec.cycles;
}

void hal_set_dir(uint8_t dir_bits) { rec.dir = dir_bits; }

void hal_step_pulse(uint8_t step_bits)
{
  if (rec.n_ticks == 0) {
    rec.stray_pulses++;
    return;
  }
  rec_tick_t *t = &rec.ticks[rec.n_ticks - 1];
  if (t->pulsed) rec.double_pulses++;
  t->pulsed = 1;
  for (int a = 0; a < 3; a++)
    t->step[a] = (int8_t)((step_bits & (1u << a)) ? ((rec.dir & (1u << a)) ? -1 : 1) : 0);
}

void hal_timer_set_period(uint32_t period_reg)
{
  rec.hal_periods++;
  if (period_reg > rec.max_hal_period) rec.max_hal_period = period_reg;
  if (rec.n_ticks > 0 && !rec.ticks[rec.n_ticks - 1].pulsed && !rec.after_stop) {
    /* the rest of a tick longer than the register */
    rec_tick_t *t = &rec.ticks[rec.n_ticks - 1];
    t->period += period_reg + 1u;
    rec.cycles += ((uint64_t)period_reg + 1) * ((uint64_t)plan_machine()->prescaler + 1);
    t->cycles_end = rec.cycles;
    return;
  }
  rec.after_stop = 0;
  add_tick(period_reg);
}
void hal_timer_start(void) { rec.running = 1; rec.starts++; }
void hal_timer_stop(void) { rec.running = 0; rec.stops++; rec.after_stop = 1; }
void hal_laser_set(uint16_t duty) { rec.duty = duty; }
void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille) { rec.gate_hz = pwm_hz; (void)on_permille; }
void hal_air_set(uint8_t bits) { rec.air = bits; }
void hal_irq_disable(void) {}
void hal_irq_enable(void) {}

void hal_record_run(void)
{
  while (rec.running) st_tick();
}

void hal_record_start_core(uint8_t dialect)
{
  st_init();
  laser_init();
  gc_init();
  gc_set_dialect(dialect);
  gc_set_wait_hook(hal_record_run);
}

uint8_t hal_record_line(const char *text)
{
  char buf[256];
  snprintf(buf, sizeof buf, "%s", text);
  return gc_execute_line(buf);
}

void hal_record_ticks(uint32_t n)
{
  for (uint32_t i = 0; i < n && rec.running; i++) {
    st_tick();
    st_prep_buffer();
  }
}

void hal_record_pump(void)
{
  for (int guard = 0; guard < 100000000; guard++) {
    st_prep_buffer();
    if (!rec.running) break;
    hal_record_run();
  }
}
