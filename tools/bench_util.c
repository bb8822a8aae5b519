#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_util.h"
#include "cli.h"
#include "format.h"
#include "vk.h"

static double clock_seconds(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return ts.tv_sec + ts.tv_nsec * 1e-9;
}

double bench_now(void) { return clock_seconds(CLOCK_MONOTONIC); }

double bench_cpu_time(void) { return clock_seconds(CLOCK_PROCESS_CPUTIME_ID); }

uint32_t bench_cores(void)
{
	cpu_set_t set;
	if (sched_getaffinity(0, sizeof(set), &set) < 0)
		return 1;
	int n = CPU_COUNT(&set);
	return n > 0 ? (uint32_t)n : 1;
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return x < y ? -1 : x > y;
}

double bench_median(double *v, size_t n)
{
	qsort(v, n, sizeof(double), cmp_double);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double bench_quantile(double *v, size_t n, double q)
{
	qsort(v, n, sizeof(double), cmp_double);
	size_t k = (size_t)ceil(q * n);
	return v[k ? k - 1 : 0];
}

const char *bench_cpu_name(void)
{
	static char name[128] = "unknown CPU";
	FILE *f = fopen("/proc/cpuinfo", "re");
	if (!f)
		return name;
	char line[256];
	while (fgets(line, sizeof(line), f)) {
		if (strncmp(line, "model name", 10) == 0) {
			char *c = strchr(line, ':');
			if (c) {
				c++;
				while (*c == ' ')
					c++;
				c[strcspn(c, "\n")] = '\0';
				snprintf(name, sizeof(name), "%s", c);
			}
			break;
		}
	}
	fclose(f);
	return name;
}

uint32_t bench_decoded_patches(const struct relief_file *f)
{
	uint32_t n = 0;
	for (uint32_t e = 0; e < f->hdr.index_records; e++) { /* patches without an entry are EMPTY */
		struct relief_patch_record r;
		relief_file_record(f, relief_index_patch(&f->hdr, e), &r);
		n += !(r.flags & RELIEF_PATCH_EMPTY);
	}
	return n;
}

void bench_json_machine(const struct relief_vk *vk)
{
	if (vk) {
		printf(",\"device_type\":");
		cli_json_string(stdout, relief_vk_device_type_name(vk->props.deviceType));
		printf(",\"device\":");
		cli_json_string(stdout, vk->props.deviceName);
	}
	printf(",\"cpu\":");
	cli_json_string(stdout, bench_cpu_name());
	printf("}\n");
}
