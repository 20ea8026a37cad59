/*
  main.c - board main: hardware, then the firmware, the banner, the loop.

  The banner is the readiness signal: bytes sent to the board before its
  UART is enabled are lost (QEMU drops them too), so a host waits for it.
*/
#include "protocol.h"

void board_init(void);   /* board/stm32f4.c: clocks (no waits on ready bits), UART, timer */

int main(void) {
  board_init();
  protocol_startup();
  protocol_main_loop();
  return 0;
}
