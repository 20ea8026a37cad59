/*
  serial.h - byte rings between the UART and the main loop.

  The receive interrupt (the board's USART handler, the simulator's input
  reader) calls serial_rx_isr() for every byte. It only stores the byte in
  the 128-byte RX ring (GRBL's size, the budget of the host's character
  counting) and sets flags. Real-time bytes ('?' '!' '~' 0x18 0x84 0x85 and
  the override bytes 0x90..0x9D) are picked out there, set a bit in
  serial_rt_flags and are never buffered; the main loop acts on the flags.
  Every other byte above 0x7F is dropped (GRBL's rule), so nothing the host
  sends can reach the control panel: panel events come from the panel alone
  (the board's button and encoder handlers, the simulator's --panel channel)
  through serial_panel_event(), and the e-stop input calls protocol_estop().

  Replies go to the TX ring; the hal drains it (the board's TXE interrupt,
  the simulator's writer) through serial_tx_pop(). serial_write() never
  drops a byte: when the ring is full it calls hal_serial_tx_wait() (the
  board sends one byte synchronously, the simulator flushes).
*/
#ifndef LK_SERIAL_H
#define LK_SERIAL_H

#include <stdint.h>

#define SERIAL_RX_SIZE 128u   /* bytes; power of two; $I reports it */
#define SERIAL_TX_SIZE 256u   /* bytes; power of two */

/* Real-time requests (bits of serial_rt_flags). */
#define RT_STATUS      0x0001u  /* '?'  */
#define RT_HOLD        0x0002u  /* '!'  */
#define RT_RESUME      0x0004u  /* '~'  */
#define RT_RESET       0x0008u  /* 0x18 */
#define RT_DOOR        0x0010u  /* 0x84 (treated as a hold) */
#define RT_JOG_CANCEL  0x0020u  /* 0x85 */
#define RT_OVERRIDE    0x0040u  /* 0x90..0x9D: see serial_take_overrides */
#define RT_LINE        0x0080u  /* a line end arrived (wakes the parser) */
#define RT_ESTOP       0x0100u  /* emergency stop input (board / simulator) */
#define RT_MENU        0x0200u  /* encoder or button event (menu.h) */

/* Control-panel events (serial_panel_event; never read from the RX line). The
   simulator's --panel channel carries them as these bytes, 0xB8 being its
   e-stop input: */
#define PANEL_CW    0xB0u   /* encoder one detent clockwise */
#define PANEL_CCW   0xB1u   /* encoder one detent counter-clockwise */
#define PANEL_OK    0xB2u   /* OK button */
#define PANEL_ESTOP 0xB8u   /* emergency stop input */

extern volatile uint16_t serial_rt_flags;

void serial_init(void);                 /* empty rings, no flags */
void serial_rx_isr(uint8_t byte);       /* from the RX interrupt only */
int serial_read(void);                  /* next RX byte, -1 when empty (main) */
uint16_t serial_rx_count(void);         /* bytes waiting in the RX ring */
uint16_t serial_rx_free(void);          /* free RX bytes (Bf: report) */
uint32_t serial_rx_overruns(void);      /* bytes lost to a full ring */
void serial_rx_flush(void);             /* drop what is buffered (reset) */

void serial_putc(char c);               /* (main) */
void serial_write(const char *s);       /* (main) */
int serial_tx_pop(void);                /* next byte to send, -1 when empty (hal) */
uint16_t serial_tx_count(void);

/* Panel events (PANEL_CW/CCW/OK) for the menu: pushed by the panel's own
   interrupt handlers (never by serial_rx_isr), popped in the main loop (-1
   when none). */
void serial_panel_event(uint8_t ev);
int serial_panel_pop(void);

/* Override bytes received since the main loop last looked, summed in the RX
   interrupt so that none is lost however many arrive between two passes
   (GRBL keeps one flag per kind and so counts a burst of "+10 %" once):
   a "100 %" byte clears what came before it. */
typedef struct {
  uint8_t feed_reset, power_reset;   /* a 0x90 / 0x99 arrived (before the deltas) */
  int16_t feed_delta, power_delta;   /* sum of the +-10 / +-1 bytes after it, % */
  uint8_t rapid;                     /* last rapid byte: 100, 50, 25; 0 none */
} serial_overrides_t;
/* Atomically take and clear the pending overrides. */
void serial_take_overrides(serial_overrides_t *out);

/* Atomically take and clear real-time flags. */
uint16_t serial_take_flags(uint16_t mask);

/* Provided by the hal (board or simulator). */
void hal_serial_tx_kick(void);          /* bytes are waiting: start sending */
void hal_serial_tx_wait(void);          /* ring full: make room (may send synchronously) */

#endif /* LK_SERIAL_H */
