/* shell_util.h - the shell's hal for tests: captured output, RAM storage, a fake clock. */
#ifndef LK_SHELL_UTIL_H
#define LK_SHELL_UTIL_H

#include <stdint.h>

const char *shell_out(void);        /* everything written since shell_out_clear() */
void shell_out_clear(void);
void shell_send(const char *bytes); /* bytes through the RX interrupt, then poll until quiet */
void shell_advance_ms(uint32_t ms); /* move the fake clock */
uint8_t *shell_storage(uint32_t *len);  /* the RAM storage area (tests corrupt it) */
void shell_storage_clear(void);
/* Called at every hal_poll (also inside the parser's waits): a test's input arriving there. */
extern void (*shell_poll_hook)(void);

#endif
