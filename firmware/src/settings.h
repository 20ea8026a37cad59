/*
  settings.h - the machine and controller settings, their storage and the
  `$` commands that read and change them.

  One struct (settings_t) with a magic number, its size and a checksum is
  kept in a storage area the hal provides (hal_storage_read/write: flash or
  battery RAM on the board, a file or memory in the simulator). A missing,
  resized or corrupt copy is replaced by the defaults (defaults.h) and the
  host is told ([MSG:settings restored]).

  Numbers ($N=value) follow GRBL where GRBL has the setting:
    $0 step pulse us      $10 status mask     $11 junction deviation mm
    $12 arc tolerance mm  $20 soft limits      $30 S of full power (grbl)
    $31 S min (kept)      $32 laser mode       $100-102 steps/mm
    $110-112 max rate mm/min   $120-122 accel mm/s^2   $130-132 travel mm
  and labkit's own:
    $200 ramp up Hz/step  $201 ramp down Hz/step   $202 start rate Hz
    $203 laser maximum mW $204 planner (0 GRBL junction, 1 MBLA)
    $205 MBLA mode (0 fast, 1 normal, 2 HQ)   $206 ramp law (0 linear Hz/step,
    1 constant acceleration)   $207 look-ahead depth (blocks)
    $208 dialect (0 labkit-fw, 1 grbl)   $209 timer prescaler
*/
#ifndef LK_SETTINGS_H
#define LK_SETTINGS_H

#include <stdint.h>

#include "machine.h"

#define SETTINGS_MAGIC 0x4C4B5357u   /* "LKSW" */

#define SET_PLANNER_JUNCTION 0
#define SET_PLANNER_MBLA     1
#define SET_MBLA_FAST   0
#define SET_MBLA_NORMAL 1
#define SET_MBLA_HQ     2

typedef struct {
  uint32_t magic;
  uint32_t size;                 /* sizeof(settings_t): a layout change restores defaults */
  lk_machine_t machine;          /* the core's machine fields */
  double s_max;                  /* $30 */
  double s_min;                  /* $31 */
  uint8_t laser_mode;            /* $32 */
  uint8_t status_mask;           /* $10 */
  uint8_t soft_limits;           /* $20 */
  uint8_t planner;               /* $204 SET_PLANNER_* */
  uint8_t mbla_mode;             /* $205 SET_MBLA_* */
  uint8_t law;                   /* $206 PLAN_LAW_* */
  uint8_t dialect;               /* $208 GC_DIALECT_* */
  uint8_t pad;
  uint32_t checksum;             /* settings_checksum() of every byte before it */
} settings_t;

extern settings_t settings;

void settings_defaults(settings_t *s);
uint32_t settings_checksum(const settings_t *s);   /* Fletcher-32 over the bytes before checksum */
/* Load from storage; returns 1 when the stored copy was good, 0 when the
   defaults were restored (and written back). */
uint8_t settings_init(void);
void settings_store(void);
/* Push settings into the core (machine, planner mode, law, depth, dialect,
   S max). Returns STATUS_OK or the core's status; only while idle. */
uint8_t settings_apply(void);
/* The planner mode the settings ask for (PLAN_MODE_*). */
uint8_t settings_plan_mode(void);

/* `$N=value`; line is the text after '$'. Returns a status. */
uint8_t settings_store_setting(const char *line);
/* `$RST=$` (settings), `$RST=#` (offsets, none kept), `$RST=*` (all). */
uint8_t settings_restore(char what);
void settings_report(void);                        /* `$$` */

/* Decimal number parser shared by $ commands and the menu: [+-]digits[.digits].
   Returns the characters read (0: not a number). */
uint8_t settings_read_number(const char *s, double *out);

/* Storage area provided by the hal (board: a RAM page that survives reset,
   simulator: memory or --eeprom FILE). Return 1 on success. */
uint8_t hal_storage_read(void *buf, uint32_t len);
uint8_t hal_storage_write(const void *buf, uint32_t len);

#endif /* LK_SETTINGS_H */
