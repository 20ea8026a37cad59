/*
  report.h - everything the firmware writes to the host, in both dialects.

  Every reply is written to the TX ring as soon as it exists (never held
  back for a later line).

    labkit-fw dialect   ok | er:N            (N: labkit/status_codes.csv)
    GRBL dialect        ok | error:N
    both                ALARM:N, <status>, [MSG:..], [OPT:..], $N=V

  Alarm numbers are GRBL's (labkit/status_codes.csv, kind alarm), which the
  host reads in both dialects.
*/
#ifndef LK_REPORT_H
#define LK_REPORT_H

#include <stdint.h>

#include "status_codes.h"

#define LK_FW_VERSION "0.1"

/* The alarms (ALARM_*, GRBL's numbers), the feedback texts (MSG_*, sent as
   [MSG:...]) and the line statuses (STATUS_*, among them GRBL's 8 "not idle"
   and 9 "locked in an alarm") all come from labkit/status_codes.csv through
   the generated status_codes.h: one table for the firmware and the host. */

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
