/*
  fuzz_line.c - libFuzzer target: bytes -> line assembler -> G-code parser.

  Every byte goes through line_asm_push(); every line it completes goes to
  gc_execute_line() (the core's parser) and the planned blocks are dropped
  again (as check mode does). Checks: the assembled line is NUL-terminated,
  shorter than LINE_BUFFER_SIZE, has no blank, comment or lower-case
  character; the statuses are the documented ones; the sanitizers see no
  fault. The first byte chooses the dialect and the line-end rule.
*/
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gcode.h"
#include "laser.h"
#include "planner.h"
#include "protocol.h"
#include "status_codes.h"
#include "stepper.h"

/* Power-on for every input: planner (look-ahead depth, mode, position),
   stepper, laser and parser as the firmware starts them, so that nothing
   one input set (a G5 depth, a position) reaches the next. 100 steps/mm:
   arcs are walked once in the parser; coarse steps keep a fuzzed 4 m circle
   from costing seconds (same code paths). */
static void power_on(void) {
  plan_init();
  lk_machine_t *m = plan_machine();
  for (int i = 0; i < 3; i++)
    m->steps_per_mm[i] = 100.0;
  if (plan_apply_machine() != STATUS_OK) {
    fprintf(stderr, "fuzz harness: 100 steps/mm refused by plan_apply_machine\n");
    abort();
  }
  st_init();
  laser_init();
  gc_init();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  if (size == 0)
    return 0;
  power_on();
  line_asm_t a;
  memset(&a, 0, sizeof a);
  a.crlf_one = data[0] & 1u;
  gc_set_dialect((data[0] >> 1) & 1u ? GC_DIALECT_GRBL : GC_DIALECT_LABKIT);
  for (size_t i = 1; i < size; i++) {
    int st = line_asm_push(&a, data[i]);
    if (st < 0)
      continue;
    if (st != STATUS_OK && st != STATUS_LINE_OVERFLOW && st != STATUS_BAD_DELIMITER &&
        st != STATUS_BAD_CHECKSUM)
      abort();
    if (st != STATUS_OK)
      continue;
    size_t n = strlen(a.buf);
    if (n >= LINE_BUFFER_SIZE)
      abort();
    for (size_t k = 0; k < n; k++) {
      char c = a.buf[k];
      if (c == ' ' || c == '(' || c == ';' || (c >= 'a' && c <= 'z') || c < 0x20 || c > 0x7E)
        abort();
    }
    char line[LINE_BUFFER_SIZE];
    memcpy(line, a.buf, n + 1);
    if (line[0] != '$') {
      (void)gc_execute_line(line);
      st_reset();
      plan_reset();
      (void)st_take_abort();
      gc_sync_position();   /* as the firmware after a reset: the parser starts where the machine is */
    }
  }
  return 0;
}
