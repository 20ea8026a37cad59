/*
  limits.h - the machine's inputs as GRBL 1.1h reads them: the limit switch
  of each axis and the probe, with the $5 and $6 inversions applied, and the
  result of the last probe cycle (the [PRB:...] of $# and of a G38.x line).

  The pins themselves come from the hal (hal.h: hal_limits_read,
  hal_probe_read). A hal that has no such input (a board whose pins are not
  wired yet, the test hals) gets the defaults here: nothing connected,
  nothing pressed.
*/
#ifndef LK_LIMITS_H
#define LK_LIMITS_H

#include <stdint.h>

/* Bit i set: the limit switch of axis i is pressed ($5 inverts the pins). */
uint8_t limits_pressed(void);

/* 1 when the probe touches ($6 inverts the pin). */
uint8_t limits_probe_touching(void);

/* The level hal_probe_read() has when the probe is touching (1) or not (0), $6 applied:
   what the step interrupt compares the pin with (st_probe_arm). */
uint8_t limits_probe_pin_at(uint8_t touching);

/* The last probe cycle: machine position (mm) where it touched, or where a
   G38.3 / G38.5 ended without touching; touched = 1 when the probe switched. */
void limits_set_probe_result(const double mm[3], uint8_t touched);
void limits_probe_result(double mm[3], uint8_t *touched);

#endif /* LK_LIMITS_H */
