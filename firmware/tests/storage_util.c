/* storage_util.c - RAM settings storage for the test and fuzzing hals (see storage_util.h). */
#include "storage_util.h"

#include <string.h>

#include "settings.h"

static uint8_t storage[4096];
static uint32_t storage_len;

/* A read longer than what was written fails, as a board's checksum over an erased page does. */
uint8_t hal_storage_read(void *buf, uint32_t len) {
  if (len > storage_len)
    return 0;
  memcpy(buf, storage, len);
  return 1;
}

uint8_t hal_storage_write(const void *buf, uint32_t len) {
  if (len > sizeof storage)
    return 0;
  memcpy(storage, buf, len);
  storage_len = len;
  return 1;
}

uint8_t *storage_area(uint32_t *len) {
  *len = storage_len;
  return storage;
}

void storage_erase(void) {
  storage_len = 0;
  memset(storage, 0, sizeof storage);
}
