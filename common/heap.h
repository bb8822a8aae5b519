/* The process heap's policy for freed memory. Programs (not libraries) call this once at
 * start: a library must not change a process-wide allocator setting behind its caller.
 *
 * Why: a CPU Vulkan driver runs the vertex and tessellation stages on its own threads and
 * allocates their buffers (megabytes) per draw. With glibc's default dynamic thresholds a
 * thread arena whose free top exceeds the trim threshold gives it back to the kernel
 * (madvise MADV_DONTNEED) on every free, and the next draw faults every page in again and
 * has the kernel zero it: on lavapipe, in the first seconds of `relief fly`, 14 trims and
 * ~8,500 page faults per 640 x 360 frame; frames up to 38 % shorter without them
 * (docs/benchmarks.md, "The heap"). Keeping freed memory costs nothing once the peak has
 * been reached: the memory is reused by the next draw. */
#pragma once

#include <stdbool.h>

/* Freed memory below 64 MiB at an arena's top stays with the process, and blocks up to
 * 32 MiB come from the arenas rather than from mmap (so freeing them does not unmap them).
 * Returns true when the allocator took the setting, false where it has no such setting
 * (not glibc, or a sanitizer's allocator): a hint, nothing depends on it but speed. */
bool relief_heap_keep_freed(void);
