/*
  beam_property.h - the beam-state property of issue 25, checked on the
  host simulator's core and shell for any input.

  The property: the beam (the duty on the laser output, seen in
  hal_laser_set) is on only where the program commands it:
    - a line or arc block (not a rapid, not a dwell) of M3 / M4 with S > 0 is
      executing: the stepper runs it (not holding, held or idle), the machine
      is not in alarm, check mode or a jog, and no hold is asked for;
    - that block's source line is a G-code line the parser accepted, and an
      independent reading of the accepted lines (G0-G3 / G80, M3 M4 M5 M2
      M30, S, in GRBL's order of execution) says that line burns: so never
      because of an error line, and never after M5 / M2 / M30 or a reset;
    - or the panel's focus beam, fired on the panel channel after a turn and
      two OKs, at its focus duty, on a machine at rest (idle, nothing queued,
      no alarm, check mode or hold).
  After a soft reset (0x18) or an e-stop the beam is off and nothing is
  queued; when a hard limit trips ($21=1: a step presses or releases a
  limit switch) the beam and the step timer are off as the limit pins'
  interrupt returns, and after the main loop's next pass the machine is in
  alarm with nothing queued. The core's own notion of the duty (laser_current_duty) always
  equals the output. It is checked at every change of the duty, after every
  step-timer tick and after every main-loop pass. Reports are not read: the
  beam is the hal's output, the state the core's.

  The hal here ticks like the simulator's (host/sim.c): up to 32 ticks per
  main-loop pass, the clock 1 ms per pass; storage is RAM, output is dropped.
  Each axis has a limit switch BEAM_SWITCH_MM on the + side of where the head
  was at power-on (the head counted from the step pulses), so that $H runs
  GRBL's homing cycle to the end (with $22=1); the beam is off while homing.
  A step that presses or releases one calls protocol_limit_pin_change()
  after the step interrupt, as the board's pin interrupt does (hard limits).
  Programs linking this file are built with
    -Wl,--wrap=gc_execute_line -Wl,--wrap=gc_init
  so that the property sees every line the shell hands the parser.

  Input format (beam_run): bytes go to the serial RX interrupt as a host
  sends them, a main-loop pass after every 8, except 0xFE followed by a
  byte b: b < 0x10 is a pause of the host, (b + 1) x 10 passes (1 ms each:
  30 quiet ms start what the look-ahead holds back); any other b goes to
  the panel channel (0xB0 turn clockwise, 0xB1 counter-clockwise, 0xB2 OK,
  0xB8 e-stop; other bytes are ignored as the simulator's --panel does).
*/
#ifndef LK_BEAM_PROPERTY_H
#define LK_BEAM_PROPERTY_H

#include <stddef.h>
#include <stdint.h>

#define BEAM_PANEL_ESCAPE 0xFEu

/* What a violation does: the default prints "beam property: <what>" and the
   state, then aborts (the fuzzer's finding); tests may count instead. */
typedef void (*beam_fail_fn)(const char *what);
void beam_set_fail(beam_fail_fn fn);

/* Erased storage, clock 0, firmware power-on, 100 steps/mm on every axis
   (as the fuzzers: the same code paths, cheap arcs); aborts with a message
   when the setup is refused. */
void beam_power_on(void);

/* Feed one input (format above) with main-loop passes in between, run the
   motion out (at most BEAM_MAX_TICKS step ticks, then a soft reset), end
   with a soft reset; the property is checked all along. */
#ifndef BEAM_MAX_TICKS
#define BEAM_MAX_TICKS 200000u       /* the fuzzer uses fewer (Makefile): more inputs per second */
#endif
void beam_run(const uint8_t *data, size_t size);
/* The two halves of beam_run: feed and run out; the final soft reset. */
void beam_feed(const uint8_t *data, size_t size);
void beam_end(void);

/* Check the property now (also called by the hal and beam_run). */
void beam_check(const char *where);

#define BEAM_SWITCH_MM 5.0

/* What the runs exercised, so a test can show it was not vacuous. */
typedef struct {
  uint64_t ticks, ticks_burning;     /* step ticks; ticks with the beam on */
  uint64_t ticks_homing;             /* step ticks of homing cycles ($H) */
  uint32_t lines_ok, lines_burning;  /* accepted lines; of them, lines that command burning */
  uint32_t focus_fires, resets, estops, holds_burning;   /* hold taken while burning */
  uint32_t hard_limits;              /* hard-limit trips ($21=1, a switch pressed or released) */
} beam_stats_t;
const beam_stats_t *beam_stats(void);

/* Test access: the simulated duty on the output. */
uint16_t beam_output_duty(void);

#endif
