/* storage_ram.h - the settings storage of the host hals (the simulator, the tests, the
   fuzzers): 4 KB of RAM (hal_storage_read / hal_storage_write), optionally backed by a file
   (the simulator's --eeprom); the tests erase it at every power-on. */
#ifndef LK_STORAGE_RAM_H
#define LK_STORAGE_RAM_H

#include <stdint.h>

void storage_file(const char *path);    /* keep the storage in this file too (0: RAM only) */
uint8_t *storage_area(uint32_t *len);   /* the bytes last written and their count (tests corrupt them) */
void storage_erase(void);               /* nothing stored, as a board's erased EEPROM */

#endif
