/* fuzz_util.h - the shell's hal for the fuzzers, and their power-on. */
#ifndef LK_FUZZ_UTIL_H
#define LK_FUZZ_UTIL_H

/* Power-on for one input: RAM storage erased, clock at 0, then the whole
   firmware started (protocol_startup: serial, core, settings, menu, main
   loop state) and coarse steps set (100 steps/mm: the parser walks every
   arc once, and a fuzzed 4 m circle would otherwise cost seconds; the same
   code paths run). Nothing an earlier input did survives into the next.
   Stops the run with a message naming the step when a setup command is
   refused or the machine does not start at rest: that is a regression of
   the firmware, not a finding of the input. */
void fuzz_power_on(void);

/* The work of hal_poll() after the clock's 1 ms: by default a nearly full
   planner is emptied (hal_null's timer never ticks); NULL restores that. */
void fuzz_set_poll(void (*fn)(void));

/* Stop the run: "fuzz harness: <what>" on stderr, then abort(). */
void fuzz_fail(const char *what);

#endif
