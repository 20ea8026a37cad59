/*
  report.h - everything the firmware writes to the host, in both dialects.

  Every reply is written to the TX ring as soon as it exists (never held
  back for a later line).

    labkit-fw dialect   ok | er:N            (N: labkit/status_codes.csv)
    GRBL dialect        ok | error:N
    both                ALARM:N, <status>, [MSG:..], [OPT:..], $N=V

  Alarm numbers are GRBL's (labkit/machine/grbl_codes.csv), which the host
  reads in both dialects.
*/
#ifndef LK_REPORT_H
#define LK_REPORT_H

#include <stdint.h>

#include "status_codes.h"

#define LK_FW_VERSION "0.1"

/* Alarms (GRBL numbering). */
#define ALARM_HARD_LIMIT  1
#define ALARM_SOFT_LIMIT  2   /* a move would leave / left the machine envelope */
#define ALARM_ABORT_CYCLE 3   /* reset or emergency stop while moving */
#define ALARM_PROBE_FAIL_INITIAL 4   /* G38.x: the probe was already where the cycle should take it */
#define ALARM_PROBE_FAIL_CONTACT 5   /* G38.2 / G38.4: the move ended and the probe never switched */
#define ALARM_HOMING_FAIL_RESET   6  /* a reset during the homing cycle */
#define ALARM_HOMING_FAIL_PULLOFF 8  /* the pull-off did not clear the switch */
#define ALARM_HOMING_FAIL_APPROACH 9 /* no switch within the search distance */

/* GRBL's error 9 (G-code locked out during an alarm) is not a status of the
   shared table (labkit/status_codes.csv): the table lists what a line can
   be wrong about, the lock is a machine state. It is answered with GRBL's
   own number, which labkit.machine.grbl (grbl_codes.csv) names. */
#define REPLY_LOCKED 9
/* GRBL's error 8 ('$' command only allowed while idle): a jog asked for
   while a job runs is refused, never queued behind the job. */
#define REPLY_NOT_IDLE 8

void report_status_message(uint8_t status);   /* ok / er:N / error:N */
void report_alarm(uint8_t alarm);             /* ALARM:N */
void report_banner(void);                     /* grbl: GRBL's; labkit-fw: says so */
void report_counters_reset(void);             /* a reset: WCO: and Ov: in the next reports */
void report_overrides_next(void);             /* Ov: in the next report (GRBL: the spindle was set) */
void report_feedback(const char *msg);        /* [MSG:msg] */
void report_status_report(void);
const char *report_state_name(void);          /* Idle, Run, Hold:0, Hold:1, Jog, Alarm, Check */
double report_feed_mm_min(void);   /* the FS: feed, mm/min, of the running block now */              /* <Idle|MPos:..|FS:..|Bf:..|Ov:..> */
void report_build_info(void);                 /* $I */
void report_help(void);                       /* $ */
void report_gcode_modes(void);                /* $G */
void report_offsets(void);                    /* $# */
void report_probe(void);                      /* [PRB:x,y,z:touched] of the last probe cycle */

/* Formatting helpers (no printf: keeps the ARM image small). */
void report_uint(uint32_t v);
void report_int(int32_t v);
void report_float(double v, uint8_t decimals);
/* Into a buffer; returns the characters written (NUL-terminated, at most n-1). */
uint16_t fmt_float(char *out, uint16_t n, double v, uint8_t decimals);

#endif /* LK_REPORT_H */
