/* storage_ram.c - RAM settings storage for the host hals (see storage_ram.h). */
#include "storage_ram.h"

#include <stdio.h>
#include <string.h>

#include "settings.h"

static uint8_t storage[4096];
static uint32_t storage_len;
static const char *storage_path;

void storage_file(const char *path) { storage_path = path; }

/* A read longer than what was written fails, as a board's checksum over an erased page does.
   With a file, what the file holds now is read (another run may have written it). */
uint8_t hal_storage_read(void *buf, uint32_t len) {
  if (storage_path) {
    FILE *f = fopen(storage_path, "rb");
    if (f) {
      storage_len = (uint32_t)fread(storage, 1, sizeof storage, f);
      fclose(f);
    }
  }
  if (len > storage_len)
    return 0;
  memcpy(buf, storage, len);
  return 1;
}

/* With a file, a write that does not reach it fails (the RAM copy is kept). */
uint8_t hal_storage_write(const void *buf, uint32_t len) {
  if (len > sizeof storage)
    return 0;
  memcpy(storage, buf, len);
  storage_len = len;
  if (storage_path) {
    FILE *f = fopen(storage_path, "wb");
    if (!f || fwrite(buf, 1, len, f) != len) {
      if (f)
        fclose(f);
      return 0;
    }
    fclose(f);
  }
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
