/*
  limits.c - limit switches and probe as GRBL reads them (see limits.h).
*/
#include "limits.h"

#include "hal.h"
#include "settings.h"

/* Defaults for a hal without these inputs: nothing wired, nothing pressed.
   A hal that has the pins defines its own (the simulator does). */
__attribute__((weak)) uint8_t hal_limits_read(void) { return 0; }
__attribute__((weak)) uint8_t hal_probe_read(void) { return 0; }

static double probe_mm[3];
static uint8_t probe_touched;

uint8_t limits_pressed(void)
{
  uint8_t pins = hal_limits_read() & 0x07u;
  return (settings.flags & SET_FLAG_LIMIT_INVERT) ? (uint8_t)(pins ^ 0x07u) : pins;
}

uint8_t limits_probe_touching(void)
{
  return (hal_probe_read() ? 1u : 0u) == limits_probe_pin_at(1);
}

uint8_t limits_probe_pin_at(uint8_t touching)
{
  uint8_t invert = (settings.flags & SET_FLAG_PROBE_INVERT) ? 1u : 0u;
  return (uint8_t)((touching ? 1u : 0u) ^ invert);
}

void limits_set_probe_result(const double mm[3], uint8_t touched)
{
  for (int a = 0; a < 3; a++)
    probe_mm[a] = mm[a];
  probe_touched = touched;
}

void limits_probe_result(double mm[3], uint8_t *touched)
{
  for (int a = 0; a < 3; a++)
    mm[a] = probe_mm[a];
  *touched = probe_touched;
}
