/* shell_test.h - tiny check macros for the shell's tests. */
#ifndef LK_SHELL_TEST_H
#define LK_SHELL_TEST_H

#include <stdio.h>
#include <string.h>

static int t_failures, t_checks;
#define CHECK(cond) do { t_checks++; if (!(cond)) { t_failures++; \
  fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); } } while (0)
#define CHECK_HAS(text, needle) do { t_checks++; if (!strstr((text), (needle))) { t_failures++; \
  fprintf(stderr, "%s:%d: expected %s in output:\n%s\n", __FILE__, __LINE__, #needle, (text)); } } while (0)
#define CHECK_NOT(text, needle) do { t_checks++; if (strstr((text), (needle))) { t_failures++; \
  fprintf(stderr, "%s:%d: did not expect %s in output:\n%s\n", __FILE__, __LINE__, #needle, (text)); } } while (0)
#define TEST_DONE(name) do { printf("%s: %d checks, %d failed\n", name, t_checks, t_failures); \
  return t_failures ? 1 : 0; } while (0)

static inline int count_of(const char *text, const char *needle) {
  int n = 0;
  size_t k = strlen(needle);
  for (const char *p = strstr(text, needle); p; p = strstr(p + k, needle))
    n++;
  return n;
}

#endif
