/*
  serial.c - RX/TX rings; the RX handler stores bytes and sets flags only.
*/
#include "serial.h"

#include <string.h>

#include "hal.h"

volatile uint16_t serial_rt_flags;
static serial_overrides_t ovr_pending;   /* written by the RX interrupt */

/* The ring is twice the budget so that it holds all SERIAL_RX_SIZE bytes. */
#define RX_RING (2u * SERIAL_RX_SIZE)
static volatile uint8_t rx_buf[RX_RING];
static volatile uint16_t rx_head, rx_tail;   /* head: written by the ISR */
static volatile uint32_t rx_overruns;
static volatile uint8_t tx_buf[SERIAL_TX_SIZE];
static volatile uint16_t tx_head, tx_tail;   /* tail: read by the hal */
static volatile uint8_t panel[8];
static volatile uint8_t panel_head, panel_tail;

void serial_init(void) {
  rx_head = rx_tail = 0;
  tx_head = tx_tail = 0;
  rx_overruns = 0;
  panel_head = panel_tail = 0;
  serial_rt_flags = 0;
  memset(&ovr_pending, 0, sizeof ovr_pending);
}

void serial_rx_isr(uint8_t byte) {
  switch (byte) {
  case '?': serial_rt_flags |= RT_STATUS; return;
  case '!': serial_rt_flags |= RT_HOLD; return;
  case '~': serial_rt_flags |= RT_RESUME; return;
  case 0x18: serial_rt_flags |= RT_RESET; return;
  case 0x84: serial_rt_flags |= RT_DOOR; return;
  case 0x85: serial_rt_flags |= RT_JOG_CANCEL; return;
  default: break;
  }
  if (byte >= 0x90 && byte <= 0x9D) {
    static const int8_t step[5] = {0, 10, -10, 1, -1};
    serial_overrides_t *o = &ovr_pending;
    if (byte == 0x90) {
      o->feed_reset = 1;
      o->feed_delta = 0;
    } else if (byte <= 0x94) {
      if (o->feed_delta > -400 && o->feed_delta < 400) o->feed_delta += step[byte - 0x90];
    } else if (byte <= 0x97) {
      o->rapid = byte == 0x95 ? 100 : byte == 0x96 ? 50 : 25;
    } else if (byte == 0x99) {
      o->power_reset = 1;
      o->power_delta = 0;
    } else if (byte >= 0x9A) {
      if (o->power_delta > -400 && o->power_delta < 400) o->power_delta += step[byte - 0x99];
    }
    serial_rt_flags |= RT_OVERRIDE;
    return;
  }
  /* Any other byte above 0x7F is dropped, as GRBL does: no G-code word is made of
     it, and the panel's events never come from the host (two UTF-8 superscript
     twos, C2 B2, in a comment once pressed OK twice on the menu). */
  if (byte > 0x7F)
    return;
  uint16_t next = (uint16_t)((rx_head + 1u) & (RX_RING - 1u));
  if (serial_rx_count() >= SERIAL_RX_SIZE) { /* full: the host broke its character count */
    rx_overruns++;
    return;
  }
  rx_buf[rx_head] = byte;
  rx_head = next;
  if (byte == '\n' || byte == '\r')
    serial_rt_flags |= RT_LINE;
}

void serial_panel_event(uint8_t ev) {
  uint8_t next = (uint8_t)((panel_head + 1u) & 7u);
  if (next != panel_tail) {
    panel[panel_head] = ev;
    panel_head = next;
  }
  serial_rt_flags |= RT_MENU;
}

int serial_panel_pop(void) {
  if (panel_tail == panel_head)
    return -1;
  uint8_t ev = panel[panel_tail];
  panel_tail = (uint8_t)((panel_tail + 1u) & 7u);
  return ev;
}

/* The rings: a power-of-two size (mask = size - 1); the producer moves only head, the
   consumer only tail, so neither needs the interrupts off. */
static inline int ring_pop(const volatile uint8_t *buf, volatile uint16_t *tail, uint16_t head,
                           uint16_t mask) {
  uint16_t t = *tail;
  if (t == head)
    return -1;
  uint8_t b = buf[t];
  *tail = (uint16_t)((t + 1u) & mask);
  return b;
}

static inline uint16_t ring_count(uint16_t head, uint16_t tail, uint16_t mask) {
  return (uint16_t)((head - tail) & mask);
}

int serial_read(void) { return ring_pop(rx_buf, &rx_tail, rx_head, RX_RING - 1u); }

uint16_t serial_rx_count(void) { return ring_count(rx_head, rx_tail, RX_RING - 1u); }

uint16_t serial_rx_free(void) { return (uint16_t)(SERIAL_RX_SIZE - serial_rx_count()); }

uint32_t serial_rx_overruns(void) { return rx_overruns; }

void serial_rx_flush(void) {
  hal_irq_disable();
  rx_tail = rx_head;
  hal_irq_enable();
}

void serial_putc(char c) {
  uint16_t next = (uint16_t)((tx_head + 1u) & (SERIAL_TX_SIZE - 1u));
  while (next == tx_tail)
    hal_serial_tx_wait();
  tx_buf[tx_head] = (uint8_t)c;
  tx_head = next;
  hal_serial_tx_kick();
}

void serial_write(const char *s) {
  while (*s)
    serial_putc(*s++);
}

int serial_tx_pop(void) { return ring_pop(tx_buf, &tx_tail, tx_head, SERIAL_TX_SIZE - 1u); }

uint16_t serial_tx_count(void) { return ring_count(tx_head, tx_tail, SERIAL_TX_SIZE - 1u); }

uint16_t serial_take_flags(uint16_t mask) {
  hal_irq_disable();
  uint16_t f = serial_rt_flags & mask;
  serial_rt_flags = (uint16_t)(serial_rt_flags & ~mask);
  hal_irq_enable();
  return f;
}

void serial_take_overrides(serial_overrides_t *out)
{
  hal_irq_disable();
  *out = ovr_pending;
  memset(&ovr_pending, 0, sizeof ovr_pending);
  hal_irq_enable();
}
