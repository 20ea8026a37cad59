/*
  homing.h - GRBL 1.1h's homing cycle ($H) on the limit switches (limits.h).

  The axes home in GRBL's default order: Z first (to clear the work), then X
  and Y together. For each group: a search towards the switches at the seek
  rate ($25) over 1.5 x the longest travel ($13x), each axis stopping at its
  switch; a pull-off ($27) at the seek rate; a slow search at the feed rate
  ($24) over 10 x the pull-off; the pull-off again. Each stop is followed by
  the debounce time ($26 ms). $23 bit i sends axis i towards its negative end.
  The machine position then is GRBL's: 0 at the switch side of the travel,
  the axis one pull-off inside it (-$27 when homing towards +, -$13x + $27
  towards -). While an axis searches, its position counts from the start of
  that search (as GRBL's does), so a failed cycle leaves such positions.

  The beam stays off: homing moves never carry power.
*/
#ifndef LK_HOMING_H
#define LK_HOMING_H

#include <stdint.h>

#define HOMING_OK 0

/* Run the whole cycle, blocking (the main loop's pass runs inside it: the
   hal's polling, tick preparation). Returns HOMING_OK, or the GRBL alarm
   that ended it: 6 a reset (the reset request is left for the caller), 8 a
   switch still pressed after a pull-off, 9 a switch not found. Motion is
   stopped in every case. */
uint8_t homing_cycle(void);

#endif /* LK_HOMING_H */
