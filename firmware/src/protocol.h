/*
  protocol.h - line assembly, `$` system commands and the main loop.

  The main loop is four small state machines, each woken by event flags
  (seed 004 [CBR40] runs them as four FreeRTOS tasks with semaphores; here
  a flag is the semaphore and protocol_poll() the scheduler):

    system control  (cncSystemControlTask)  real-time flags: reset, e-stop,
                    feed hold / resume, jog cancel, status reports; alarms
                    and the soft-limit envelope; check mode
    parser/planner  (parser/planner task)   a complete line in the RX ring:
                    assemble, strip, answer ok / er:N / error:N at once,
                    blocks into the planner (only when it has room, so the
                    loop never blocks)
    runner          (runner task)           st_prep_buffer(): planned blocks
                    into ticks for the step interrupt; flushes the look-ahead
                    at the end of a stream
    menu            (menu task)             encoder / OK events: menu.c

  Line rules: '\r' or '\n' ends a line (labkit-fw: '\r\n' is one end);
  comments "( )" and ';' and white space are stripped and letters made
  upper case before the line is counted; a line longer than
  LINE_BUFFER_SIZE - 1 characters (grbl dialect: GRBL_LINE_MAX) is rejected
  whole (line_overflow), never cut; an empty line is answered ok; "*NN" (XOR of every byte before '*')
  is checked here and removed.
*/
#ifndef LK_PROTOCOL_H
#define LK_PROTOCOL_H

#include <stdint.h>

#define LINE_BUFFER_SIZE 128
/* GRBL 1.1h's line buffer holds 80 bytes: 79 characters after spaces and comments are removed. */
#define GRBL_LINE_MAX 79

/* Machine states (what '?' reports besides the stepper's). */
#define PROTO_IDLE  0
#define PROTO_ALARM 1
#define PROTO_CHECK 2
#define PROTO_JOG   3
#define PROTO_SLEEP 4   /* $SLP: everything off until a reset */
#define PROTO_HOME  5   /* $H: the homing cycle runs */

/* Wake flags of the four machines (protocol_events). */
#define EV_SYSTEM 0x01u
#define EV_PARSER 0x02u
#define EV_RUNNER 0x04u
#define EV_MENU   0x08u

/* Line assembler: bytes in, one stripped line out. */
typedef struct {
  char buf[LINE_BUFFER_SIZE];
  uint16_t len;        /* stripped characters kept */
  uint16_t raw;        /* bytes seen in this line */
  uint8_t paren;       /* inside ( ) */
  uint8_t semi;        /* after ';' */
  uint8_t star;        /* after '*' (checksum digits follow) */
  uint8_t sys;         /* line starts with '$': '*' is a character */
  uint8_t overflow;
  uint8_t bad;         /* a stray byte or ')' */
  uint8_t xor_raw;     /* XOR of the bytes before '*' */
  uint16_t ck;         /* checksum digits read */
  uint8_t ck_digits;
  uint8_t after_cr;    /* the last line ended with '\r' */
  uint8_t crlf_one;    /* '\r\n' is one line end (labkit-fw) */
  uint8_t grbl;        /* GRBL's line rules: 79 characters, a '(' open at the line end is closed */
} line_asm_t;

void line_asm_reset(line_asm_t *a);
void line_asm_set_dialect(line_asm_t *a, uint8_t dialect);   /* GC_DIALECT_* */
/* Feed one byte. Returns -1 while the line goes on, else the status of the
   line just ended (STATUS_OK: a->buf holds it, possibly empty). */
int line_asm_push(line_asm_t *a, uint8_t byte);

/* Power-on: serial, core, settings (from storage), menu, then the banner. */
void protocol_startup(void);
void protocol_init(void);           /* after the core, settings and serial */
void protocol_poll(void);           /* one pass of the four machines */
void protocol_main_loop(void);      /* for (;;) protocol_poll() */
/* One line as the parser/planner machine runs it (tests, fuzzing); writes
   the reply. The line must be assembled (stripped). */
void protocol_execute_line(char *line);
/* Raise an alarm: stop motion and laser at once, drop what the RX ring holds
   (nothing sent before the alarm runs after it), lock G-code, report. */
void protocol_alarm(uint8_t alarm);
/* Emergency stop input (board pin, simulator escape): call from any context. */
void protocol_estop(void);
/* Hard limits: the hal calls this from its limit pins' change interrupt, on every change (a
   press or a release, both edges), as GRBL's pin-change interrupt fires. With $21=1, outside
   an alarm and a homing cycle, it stops the step timer and the beam at once; the main loop
   then raises ALARM:1 (grbl dialect: "[MSG:Reset to continue]", nothing more is read until a
   reset). Any context. */
void protocol_limit_pin_change(void);

uint8_t protocol_state(void);
uint8_t protocol_hold_requested(void);   /* '!' given and not yet resumed */
uint8_t protocol_program_paused(void);   /* an M0 waits for '~' (grbl dialect) */
uint8_t protocol_planner_blocks(void);   /* free slots of an empty planner ($I) */
extern volatile uint8_t protocol_events;

/* A jog from the control panel: words as after "$J=" (e.g. "G91X1F600"). */
uint8_t protocol_jog(const char *words);

/* Background work of the hal, called every pass and while the parser waits
   (simulator: input, output and simulated time; board: nothing). */
void hal_poll(void);

/* Milliseconds since start (hal: SysTick on the board, the clock in the
   simulator); used to flush the look-ahead when the host goes quiet. */
uint32_t hal_millis(void);

#endif /* LK_PROTOCOL_H */
