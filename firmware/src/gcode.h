/*
  gcode.h - G-code parser and executor of the labkit firmware.

  gc_execute_line() reads one line (no line end), checks it completely and
  only then executes it: a rejected line changes nothing. It returns
  STATUS_OK or the status number of labkit/status_codes.csv, the same number
  labkit.gcode (reader.py / _kernel.py) gives the same line in the same
  dialect.

  Dialects (gc_set_dialect):
    GC_DIALECT_LABKIT  F mm/s, S 0..255, G4 P ms, G5 P look-ahead depth,
                       G90.1 absolute arc centres, full circles without an
                       end point, a bare G0/G1 is error 26, R arcs short of
                       half the chord by <= 0.0005 mm become half circles.
    GC_DIALECT_GRBL    F mm/min, S 0..$30 (gc_set_s_max), G4 P s, letters
                       L and T, G80; G90.1, G5 and M7 are error 20.
  Words the firmware runs: G0 G1 G2 G3 G4 (G5) G17 G18 G19 G20 G21 G40 G49
  G54 G61 (G80) G90 G91 (G90.1) G91.1 G94, M0 M1 M2 M30 M3 M4 M5 (M7) M8 M9,
  F S P I J K R N X Y Z (T L). In the grbl dialect also GRBL's offsets and
  homes, as GRBL 1.1h runs them: G10 L2/L20, G28 G30 (.1), G53, G54-G59,
  G92 (.1), G43.1 G49, G93 (offsets of G54-G59, G28 and G30 are kept in the
  settings storage like GRBL's EEPROM), and probing G38.2-G38.5 (the move;
  protocol.c watches the probe input and reports). GRBL checks each G and M
  word as it reads it, and its F N P S T words for sign as they come.
*/
#ifndef LK_GCODE_H
#define LK_GCODE_H

#include <stdint.h>

#define GC_DIALECT_LABKIT 0
#define GC_DIALECT_GRBL   1

/* Program flow after M0 M1 M2 M30 (gc_state()->program_flow). */
#define GC_FLOW_RUNNING        0
#define GC_FLOW_PAUSED         1   /* M0 */
#define GC_FLOW_OPTIONAL_PAUSE 2   /* M1 */
#define GC_FLOW_END            3   /* M2 / M30 */

/* G38.2 .. G38.5 (grbl dialect) are the motion modes GC_MOTION_PROBE + 2 .. + 5. */
#define GC_MOTION_PROBE 100
/* GRBL 1.1h's largest N (a fraction is cut off first). */
#define GC_GRBL_MAX_LINE_NUMBER 10000000.0

typedef struct {
  uint8_t motion;        /* 0 1 2 3, 80 (G80), GC_MOTION_PROBE + 2..5 (G38.2..5) */
  uint8_t plane;         /* 0 G17 (XY), 1 G18 (ZX), 2 G19 (YZ) */
  uint8_t inches;        /* G20 */
  uint8_t absolute;      /* G90 */
  uint8_t arc_absolute;  /* G90.1 */
  uint8_t laser;         /* 0 M5, 3 M3, 4 M4 */
  uint8_t air;           /* bit 0 M7, bit 1 M8 */
  uint8_t program_flow;  /* GC_FLOW_* of the last M0 M1 M2 M30 */
  double feed_mm_min;    /* 0 = no feed yet */
  float s_word;         /* S word (float32, as labkit.gcode keeps it) */
  double pos_mm[3];      /* where the last accepted move ends */
  uint32_t line;         /* N number of the last line, else lines counted */
  uint32_t lookahead;    /* last G5 P */
  /* GRBL's work coordinates (grbl dialect): work = machine - (coord + g92 + tlo on Z) */
  uint8_t coord_select;  /* 0..5: G54..G59 */
  uint8_t inverse_time;  /* G93 */
  uint8_t stop_now;      /* GC_FLOW_* of an M0 M1 M2 M30 in the line just run, else 0 */
  uint8_t end_owed;      /* an M2 / M30 whose modal reset waits for the moves (grbl) */
  uint8_t probe_now;     /* 2..5: the line just run is a G38.x probe move, else 0 */
  uint8_t sync_now;      /* the line just run is answered once the moves before it have
                            ended (GRBL: G4, M2, M30, G43.1, G49; G10, G92, G54-G59 wait
                            before their commit) */
  double coord[3];       /* offset of the selected system (stored, settings.coord) */
  double g92[3];         /* G92 offset (not stored: a reset clears it, as in GRBL) */
  double tlo;            /* G43.1 tool length offset, Z, mm */
  uint32_t wco_changes;  /* counts changes of the offsets (the status report shows WCO then) */
  uint32_t power_syncs;  /* counts the laser/coolant switches GRBL syncs on (grbl dialect: the
                            status report shows Ov: then) */
} gc_state_t;

void gc_init(void);                          /* power-on modal state, labkit dialect */
uint8_t gc_execute_line(char *line);         /* STATUS_OK or an error status */
void gc_set_dialect(uint8_t dialect);
uint8_t gc_get_dialect(void);
void gc_set_s_max(double s_max);             /* grbl $30 (> 0) */
double gc_get_s_max(void);                   /* S of full power in the current dialect */
void gc_sync_position(void);                 /* parser position := stepper position */
void gc_load_offsets(void);                  /* the selected system's offset from the settings */
void gc_end_program(void);                   /* an owed M2 / M30 modal reset, now */
void gc_wco(double out[3]);                  /* work coordinate offset, mm: machine - work */
const gc_state_t *gc_state(void);
uint8_t gc_waiting_for_idle(void);           /* a line waits for the moves before it to end */
uint32_t gc_current_line(void);

/* Called while gc_execute_line waits for room in the planner buffer (after
   st_prep_buffer()). The shell runs its real-time work there; a host
   simulator without a timer thread runs ticks there. NULL: just spin. */
void gc_set_wait_hook(void (*hook)(void));

#endif /* LK_GCODE_H */
