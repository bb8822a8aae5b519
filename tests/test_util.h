/* Helpers shared by relief's cmocka tests. */
#pragma once

#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#ifdef NDEBUG
#error "tests must not be built with NDEBUG"
#endif

/* Open file descriptors of this process; compare before and after a test to catch leaks. */
static inline int test_count_fds(void)
{
	DIR *d = opendir("/proc/self/fd");
	if (!d)
		return -1;
	int n = 0;
	struct dirent *e;
	while ((e = readdir(d)))
		if (e->d_name[0] != '.')
			n++;
	closedir(d);
	return n - 1; /* the directory's own fd */
}

/* Path of a file in tests/data/ (RELIEF_TEST_DATA is set by CMake). */
static inline const char *test_data(const char *name)
{
	static char buf[4][1024];
	static int slot;
	slot = (slot + 1) % 4;
	snprintf(buf[slot], sizeof(buf[slot]), "%s/%s", RELIEF_TEST_DATA, name);
	return buf[slot];
}
