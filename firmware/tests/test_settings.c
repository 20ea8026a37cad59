/*
  test_settings.c - checksum, storage round trip, $N=, $RST.
*/
#include <stdint.h>
#include <string.h>

#include "gcode.h"
#include "planner.h"
#include "protocol.h"
#include "settings.h"
#include "shell_test.h"
#include "shell_util.h"
#include "status_codes.h"

int main(int argc, char **argv) {
  (void)argc; (void)argv;
  shell_storage_clear();
  plan_init();
  gc_init();
  CHECK(settings_init() == 0);                 /* empty storage: defaults, written back */
  uint32_t len;
  uint8_t *mem = shell_storage(&len);
  CHECK(len == sizeof(settings_t));
  CHECK(settings_init() == 1);                 /* now it reads back */

  /* checksum sees every byte */
  settings_t s = settings;
  uint32_t c0 = settings_checksum(&s);
  s.machine.steps_per_mm[0] += 1.0;
  CHECK(settings_checksum(&s) != c0);
  s = settings;
  s.dialect ^= 1;
  CHECK(settings_checksum(&s) != c0);

  /* a corrupt copy restores the defaults */
  mem[20] ^= 0x55;
  CHECK(settings_init() == 0);
  CHECK(settings_init() == 1);

  /* $N=value */
  CHECK(settings_store_setting("100=80") == STATUS_OK);
  CHECK(settings.machine.steps_per_mm[0] == 80.0);
  CHECK(plan_machine()->steps_per_mm[0] == 80.0);
  CHECK(settings_init() == 1 && settings.machine.steps_per_mm[0] == 80.0);   /* stored */
  CHECK(settings_store_setting("110=1200.5") == STATUS_OK);
  CHECK(settings.machine.max_rate_mm_min[0] == 1200.5);
  CHECK(settings_store_setting("999=1") == STATUS_INVALID_STATEMENT);   /* GRBL: unknown setting */
  CHECK(settings_store_setting("100=") == STATUS_BAD_NUMBER);
  CHECK(settings_store_setting("100=abc") == STATUS_BAD_NUMBER);
  CHECK(settings_store_setting("100=-5") == STATUS_NEGATIVE_VALUE);
  CHECK(settings_store_setting("32=2") == STATUS_OK && settings.laser_mode == 1);   /* a GRBL flag */
  CHECK(settings_store_setting("26=1000") == STATUS_OK && settings.homing_debounce_ms == 232);   /* 8 bits */
  CHECK(settings_store_setting("0=2") == STATUS_SETTING_STEP_PULSE_MIN);
  CHECK(settings_store_setting("20=1") == STATUS_SOFT_LIMIT_ERROR);     /* homing is off */
  CHECK(settings_store_setting("1.5=7") == STATUS_OK && settings.step_idle_delay == 7);
  CHECK(settings_store_setting("205=1.5") == STATUS_NON_INTEGER_COMMAND);
  CHECK(settings_store_setting("100") == STATUS_INVALID_STATEMENT);
  CHECK(settings_store_setting("110=1e3") == STATUS_INVALID_STATEMENT);
  CHECK(settings.machine.steps_per_mm[0] == 80.0);   /* rejected values change nothing */

  /* planner choice and MBLA mode reach the planner */
  CHECK(settings_store_setting("204=1") == STATUS_OK);
  CHECK(settings_store_setting("205=2") == STATUS_OK);
  CHECK(plan_get_mode() == PLAN_MODE_HQ);
  CHECK(settings_store_setting("205=0") == STATUS_OK);
  CHECK(plan_get_mode() == PLAN_MODE_FAST);
  CHECK(settings_store_setting("204=0") == STATUS_OK);
  CHECK(plan_get_mode() == PLAN_MODE_JUNCTION);
  CHECK(settings_store_setting("206=0") == STATUS_OK);
  CHECK(plan_get_law() == PLAN_LAW_LINEAR);
  CHECK(settings_store_setting("207=8") == STATUS_OK);
  CHECK(plan_get_depth() == 8);
  CHECK(settings_store_setting("207=0") == STATUS_MAX_VALUE_EXCEEDED);

  /* dialect */
  CHECK(settings_store_setting("208=1") == STATUS_OK);
  CHECK(gc_get_dialect() == GC_DIALECT_GRBL);
  CHECK(settings_store_setting("30=255") == STATUS_OK);
  CHECK(gc_get_s_max() == 255.0);

  /* $RST=$ keeps the dialect and the offsets, $RST=# clears only the offsets,
     $RST=* restores everything (the default dialect is grbl) */
  CHECK(settings_store_setting("208=0") == STATUS_OK);
  double g55[3] = {1.0, 2.0, 3.0};
  settings_store_coord(1, g55);
  CHECK(settings_restore('$') == STATUS_OK);
  CHECK(settings.machine.steps_per_mm[0] == 6400.0 / 3.0);
  CHECK(settings.dialect == GC_DIALECT_LABKIT);
  CHECK(settings.coord[1][1] == 2.0);
  CHECK(settings_store_setting("100=80") == STATUS_OK);
  CHECK(settings_restore('#') == STATUS_OK);
  CHECK(settings.coord[1][1] == 0.0 && settings.machine.steps_per_mm[0] == 80.0);
  CHECK(settings_restore('*') == STATUS_OK);
  CHECK(settings.dialect == GC_DIALECT_GRBL);
  CHECK(gc_get_dialect() == GC_DIALECT_GRBL);
  CHECK(settings_restore('x') == STATUS_INVALID_STATEMENT);
  CHECK(settings_init() == 1);

  TEST_DONE("test_settings");
}
