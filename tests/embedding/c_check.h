/* The C API tests' checks (C11): CHECK counts a failed condition and goes on, CHECK_OK stops
 * the test at a call that did not succeed, printing lamina_last_error(). */
#ifndef LAMINA_TEST_C_CHECK_H
#define LAMINA_TEST_C_CHECK_H

#include <lamina/c_api.h>
#include <stdio.h>
#include <stdlib.h>

static int failures = 0;

#define CHECK(cond)                                                            \
  do {                                                                         \
    if (!(cond)) {                                                             \
      fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
      ++failures;                                                              \
    }                                                                          \
  } while (0)

#define CHECK_OK(call)                                                                   \
  do {                                                                                   \
    lamina_status s_ = (call);                                                           \
    if (s_ != LAMINA_OK) {                                                               \
      fprintf(stderr, "%s:%d: %s returned %d: %s\n", __FILE__, __LINE__, #call, (int)s_, \
              lamina_last_error());                                                      \
      exit(1);                                                                           \
    }                                                                                    \
  } while (0)

#endif
