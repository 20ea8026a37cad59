/* core_test.h - the check of the core's table tests (test_gcode, test_planner): every check
   counted, only the first failure printed (one fault in a table tends to bring many after it),
   with the message the test formats. The test defines fail_where, its "name: FAIL ..." prefix. */
#ifndef LK_CORE_TEST_H
#define LK_CORE_TEST_H

#include <stdio.h>

static int failures, checks;
static void fail_where(const char *file, int line);

#define CHECK(cond, ...)                                   \
  do {                                                     \
    checks++;                                              \
    if (!(cond)) {                                         \
      if (!failures) {                                     \
        fail_where(__FILE__, __LINE__);                    \
        printf(__VA_ARGS__);                               \
        printf("\n");                                      \
      }                                                    \
      failures++;                                          \
    }                                                      \
  } while (0)

#endif
