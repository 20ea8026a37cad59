/* storage_util.h - the settings storage of the test and fuzzing hals: 4 KB of RAM
   (hal_storage_read / hal_storage_write), erased by every power-on of a test. */
#ifndef LK_STORAGE_UTIL_H
#define LK_STORAGE_UTIL_H

#include <stdint.h>

uint8_t *storage_area(uint32_t *len);   /* the bytes last written and their count (tests corrupt them) */
void storage_erase(void);               /* nothing stored, as a board's erased EEPROM */

#endif
