/* See heap.h. glibc's mallopt: M_TRIM_THRESHOLD is the free top an arena keeps before it
 * trims (per-thread arenas included, heap_trim()); setting it switches off the dynamic
 * thresholds, so M_MMAP_THRESHOLD is set too (32 MiB is glibc's largest on 64-bit). */
#include "heap.h"

#include <stdlib.h> /* defines __GLIBC__ */

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
#include <malloc.h>
#endif

bool relief_heap_keep_freed(void)
{
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
	return mallopt(M_MMAP_THRESHOLD, 32 << 20) == 1 && mallopt(M_TRIM_THRESHOLD, 64 << 20) == 1;
#else
	return false;
#endif
}
