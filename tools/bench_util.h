/* Timing and reporting helpers shared by the `relief bench` modes. */
#pragma once

#include <stddef.h>
#include <stdint.h>

struct relief_file;
struct relief_vk;

double bench_now(void);
/* CPU time of the whole process (every thread, the driver's too), seconds. */
double bench_cpu_time(void);
/* CPUs this process may run on (its affinity mask), at least 1. */
uint32_t bench_cores(void);
/* Median of n values (sorts them). */
double bench_median(double *v, size_t n);
/* The q-quantile (0 < q <= 1) of n >= 1 values, the smallest value with at least q n of
 * them at or below it (sorts them). */
double bench_quantile(double *v, size_t n, double q);
/* Patches with a stream (not empty): the ones a decoder decodes. */
uint32_t bench_decoded_patches(const struct relief_file *f);
/* "model name" from /proc/cpuinfo, or "unknown CPU". */
const char *bench_cpu_name(void);
/* Ends a JSON record on stdout with the machine: ,"device_type":"..." and ,"device":"..."
 * (relief_vk_device_type_name() and the device's name, when vk is not NULL), ,"cpu":"..."
 * and the closing brace and newline. */
void bench_json_machine(const struct relief_vk *vk);
