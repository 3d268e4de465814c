/* CHECK(cond): counts and reports failed conditions; main returns `failures == 0`. */
#ifndef XRCE_C_TEST_CHECK_H
#define XRCE_C_TEST_CHECK_H

#include <stdio.h>

static int failures = 0;
#define CHECK(cond)                                                                      \
    do {                                                                                 \
        if (!(cond)) {                                                                   \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);     \
            failures++;                                                                  \
        }                                                                                \
    } while (0)

#endif
