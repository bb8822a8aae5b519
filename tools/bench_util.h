/* Timing and reporting helpers shared by the `relief bench` modes. */
#pragma once

#include <stddef.h>

double bench_now(void);
/* Median of n values (sorts them). */
double bench_median(double *v, size_t n);
/* "model name" from /proc/cpuinfo, or "unknown CPU". */
const char *bench_cpu_name(void);
