/* GPU test fixture: a Vulkan context with the validation layer (synchronisation checks
 * included) whose messages are printed and counted; gpu_test_teardown() fails the test on
 * any. Tests run on whatever device the default order picks (lavapipe in CI), or
 * RELIEF_DEVICE. */
#pragma once

#include <dlfcn.h>
#include <link.h>

#include "../test_util.h"
#include "vk.h"

/* The Vulkan loader dlcloses the driver and layers on vkDestroyInstance; LeakSanitizer then
 * cannot name the frames of their exit-time caches and tests/lsan.supp cannot match them.
 * Pinning every shared object loaded so far (RTLD_NODELETE) keeps them named. Leaks in
 * relief's own code are still reported: its frames are never in a suppressed module. */
static int gpu_test_pin_one(struct dl_phdr_info *info, size_t size, void *data)
{
	if (info->dlpi_name && info->dlpi_name[0])
		dlopen(info->dlpi_name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
	return 0;
}

static enum relief_log_level gpu_test_level = RELIEF_LOG_WARN;
static struct relief_logger gpu_test_log = { relief_log_stderr, &gpu_test_level };

/* Set by a test program before its group starts: its context enables the mesh capture
 * (relief_vk_options.mesh_capture). */
static bool gpu_test_mesh_capture;

static inline struct relief_vk *gpu_test_context(void)
{
	struct relief_vk_options o = { .validation = true, .log = &gpu_test_log, .mesh_capture = gpu_test_mesh_capture };
	struct relief_vk *vk = NULL;
	int ret = relief_vk_create(&o, &vk);
	if (ret < 0)
		fail_msg("no Vulkan context with validation: %d", ret);
	assert_true(vk->validation);
	dl_iterate_phdr(gpu_test_pin_one, NULL);
	return vk;
}

/* Whether draws are counted (pipeline statistics: triangles, invocations), which some
 * checks compare. Not under GPU-assisted validation (struct relief_vk's gpu_av): scripts/test
 * runs those checks in its normal passes, where it fails if any program printed the line
 * below, and the GPU tests once more with RELIEF_GPU_AV for the layer's messages. Says so
 * once per test program when it skips them. */
static inline bool gpu_test_has_statistics(const struct relief_vk *vk)
{
	static bool said;
	if (!vk->has.pipeline_statistics && !said) {
		printf("no pipeline statistics%s: the checks of triangle and invocation counts are skipped\n",
		       vk->gpu_av ? " under GPU-assisted validation" : "");
		said = true;
	}
	return vk->has.pipeline_statistics;
}

static inline void gpu_test_assert_clean(struct relief_vk *vk)
{
	assert_int_equal(atomic_load(&vk->validation_messages), 0);
}

/* A cmocka group fixture sharing one context: the group fails if any validation message
 * was raised during its tests. */
static struct relief_vk *gpu_test_vk;

static inline int gpu_test_group_setup(void **state)
{
	gpu_test_vk = gpu_test_context();
	return 0;
}

/* Prints the line scripts/test adds up for its summary. */
static inline void gpu_test_report(unsigned messages)
{
	printf("relief-validation: %u messages\n", messages);
}

static inline int gpu_test_group_teardown(void **state)
{
	unsigned messages = atomic_load(&gpu_test_vk->validation_messages);
	relief_vk_destroy(gpu_test_vk);
	gpu_test_report(messages);
	return messages ? -1 : 0;
}
