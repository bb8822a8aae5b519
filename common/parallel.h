/* Runs fn(ctx, i) for i in [0, n) on `threads` threads (0 = every online core). Items are
 * handed out one at a time from an atomic counter. Returns the first negative value any
 * call returned (the other items still run), else 0. */
#pragma once

#include <stddef.h>

int relief_parallel_for(size_t n, unsigned threads, int (*fn)(void *ctx, size_t i), void *ctx);
unsigned relief_cpu_count(void);
