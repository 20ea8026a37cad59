/*
  settings.h - the machine and controller settings, their storage and the
  `$` commands that read and change them.

  One struct (settings_t) with a magic number, its size and a checksum is
  kept in a storage area the hal provides (hal_storage_read/write: flash or
  battery RAM on the board, a file or memory in the simulator). A missing,
  resized or corrupt copy is replaced by the defaults (defaults.h) and the
  host is told ([MSG:settings restored]).

  Numbers ($N=value) and types are GRBL 1.1h's ($0-$6, $10-$13, $20-$27,
  $30-$32, $100-$132: whole numbers kept in 8 bits, flags, floats; an
  unknown number is error 3, $0 below 3 error 6, $20=1 without homing
  error 10). Kept and listed, used by the core where it has the concept:
    $0 step pulse us      $10 status mask     $11 junction deviation mm
    $12 arc tolerance mm  $13 report inches   $20 soft limits
    $30 S of full power (grbl)   $31 S min (kept)   $32 laser mode
    $100-102 steps/mm   $110-112 max rate mm/min   $120-122 accel mm/s^2
    $130-132 travel mm; $1-$6, $21-$27 are kept for GRBL senders only
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

/* flags */
#define SET_FLAG_STEP_ENABLE_INVERT 0x01u   /* $4 */
#define SET_FLAG_LIMIT_INVERT       0x02u   /* $5 */
#define SET_FLAG_PROBE_INVERT       0x04u   /* $6 */
#define SET_FLAG_REPORT_INCHES      0x08u   /* $13 */
#define SET_FLAG_HARD_LIMITS        0x10u   /* $21 */
#define SET_FLAG_HOMING             0x20u   /* $22 */

#define SET_N_COORD   6     /* G54 .. G59 */
#define SET_N_STARTUP 2     /* $N0 $N1, as GRBL's N_STARTUP_LINE */
#define SET_LINE_SIZE 80    /* a stored line (GRBL's EEPROM_LINE_SIZE), NUL included */

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
  uint8_t step_idle_delay;       /* $1 ms (kept: GRBL's; the board's drivers stay on) */
  uint8_t step_invert;           /* $2 port mask (kept) */
  uint8_t dir_invert;            /* $3 port mask (kept) */
  uint8_t flags;                 /* SET_FLAG_*: $4 $5 $6 $13 $21 $22 */
  uint8_t homing_dir;            /* $23 mask */
  uint8_t homing_debounce_ms;    /* $26 (GRBL 1.1h keeps 8 bits of it) */
  uint8_t pad[2];
  double homing_feed;            /* $24 mm/min */
  double homing_seek;            /* $25 mm/min */
  double homing_pulloff;         /* $27 mm */
  /* GRBL's EEPROM data: G54..G59 offsets, G28 and G30 positions (machine
     coordinates, mm), the $N start-up lines and the $I= build text. */
  double coord[SET_N_COORD][3];
  double home_pos[2][3];         /* [0] G28, [1] G30 */
  char startup[SET_N_STARTUP][SET_LINE_SIZE];
  char build_info[SET_LINE_SIZE];
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
   S max). Returns STATUS_OK or the core's status when it refuses the machine
   (it then keeps the machine it had, and the rest is applied); only while
   idle. In the grbl dialect $N= stores any value GRBL stores ($100=0, $12=0)
   even when the core cannot run on it: $$ shows it, the core keeps running
   on the last machine it could use. */
uint8_t settings_apply(void);
/* The planner mode the settings ask for (PLAN_MODE_*). */
uint8_t settings_plan_mode(void);

/* `$N=value`; line is the text after '$'. Returns a status. */
uint8_t settings_store_setting(const char *line);
/* `$RST=$` (settings), `$RST=#` (G54-G59, G28, G30), `$RST=*` (all). */
uint8_t settings_restore(char what);
void settings_report(void);                        /* `$$` */
/* Store the offsets of G54..G59 (index 0..5) or G28 / G30 (6, 7). */
void settings_store_coord(uint8_t index, const double mm[3]);

/* Decimal number parser shared by $ commands and the menu: [+-]digits[.digits].
   Returns the characters read (0: not a number). */
uint8_t settings_read_number(const char *s, double *out);

/* Storage area provided by the hal (board: a RAM page that survives reset,
   simulator: memory or --eeprom FILE). Return 1 on success. */
uint8_t hal_storage_read(void *buf, uint32_t len);
uint8_t hal_storage_write(const void *buf, uint32_t len);

#endif /* LK_SETTINGS_H */
