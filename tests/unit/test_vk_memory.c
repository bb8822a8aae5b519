/* Memory types without a GPU: relief_vk_memory_pick() on memory tables in the
 * shapes real devices report. lavapipe has one type with every host flag, so
 * the GPU tests cannot tell a good choice from a bad one; a discrete GPU can
 * (video memory, system memory cached or not, the small window of video memory
 * the CPU maps), and so can these tables. */
#include <errno.h>
#include <string.h>

#include "../test_util.h"
#include "vk.h"

#define DL VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT
#define HV VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT
#define HC VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
#define CACHED VK_MEMORY_PROPERTY_HOST_CACHED_BIT
#define AMD (VK_MEMORY_PROPERTY_DEVICE_COHERENT_BIT_AMD | VK_MEMORY_PROPERTY_DEVICE_UNCACHED_BIT_AMD)

struct type {
	VkMemoryPropertyFlags flags;
	uint32_t heap;
};

static VkPhysicalDeviceMemoryProperties table(const struct type *t, uint32_t n)
{
	VkPhysicalDeviceMemoryProperties m;
	memset(&m, 0, sizeof(m));
	m.memoryTypeCount = n;
	for (uint32_t i = 0; i < n; i++) {
		m.memoryTypes[i].propertyFlags = t[i].flags;
		m.memoryTypes[i].heapIndex = t[i].heap;
		if (t[i].heap + 1 > m.memoryHeapCount)
			m.memoryHeapCount = t[i].heap + 1;
	}
	return m;
}

static uint32_t pick(const VkPhysicalDeviceMemoryProperties *m, uint32_t bits, enum relief_vk_memory_use use)
{
	uint32_t i = 99;
	assert_int_equal(relief_vk_memory_pick(m, bits, use, &i), 0);
	return i;
}

/* What this machine's lavapipe (Mesa 22.3) reports: one heap, one type with
 * every flag. */
static void test_lavapipe(void **state)
{
	const struct type t[] = { { DL | HV | HC | CACHED, 0 } };
	VkPhysicalDeviceMemoryProperties m = table(t, 1);
	for (int use = RELIEF_VK_MEMORY_DEVICE; use <= RELIEF_VK_MEMORY_SHARED; use++)
		assert_int_equal(pick(&m, 1, use), 0);
}

/* A discrete GPU without resizable BAR, in the shape of a GeForce RTX 3070's
 * listing (github.com/cg-tuwien/Auto-Vk issue 66: heaps of 8.4 GB video
 * memory, 17.1 GB system memory and a 224 MB window of video memory the CPU can
 * map), with a type of no flags as NVIDIA's drivers list. Each use gets its own
 * type. */
static void test_discrete_small_bar(void **state)
{
	const struct type t[] = {
		{ 0, 1 }, { DL, 0 }, { HV | HC, 1 }, { HV | HC | CACHED, 1 }, { DL | HV | HC, 2 },
	};
	VkPhysicalDeviceMemoryProperties m = table(t, 5);
	assert_int_equal(pick(&m, 0x1f, RELIEF_VK_MEMORY_DEVICE), 1);
	assert_int_equal(pick(&m, 0x1f, RELIEF_VK_MEMORY_UPLOAD), 2);   /* not the small window */
	assert_int_equal(pick(&m, 0x1f, RELIEF_VK_MEMORY_READBACK), 3); /* cached for the CPU's reads */
	assert_int_equal(pick(&m, 0x1f, RELIEF_VK_MEMORY_SHARED), 4);   /* video memory the CPU maps */
	/* A resource whose types leave out the window: system memory, cached. */
	assert_int_equal(pick(&m, 0x0f, RELIEF_VK_MEMORY_SHARED), 3);
	/* No device-local type allowed: device use still gets memory, one the CPU
	 * cannot map first. */
	assert_int_equal(pick(&m, 0x0d, RELIEF_VK_MEMORY_DEVICE), 0);
	assert_int_equal(pick(&m, 0x0c, RELIEF_VK_MEMORY_DEVICE), 2);
}

/* An AMD device listing VK_AMD_device_coherent_memory's types ahead of the
 * plain ones, in the shape of a listing in
 * github.com/GpuZelenograd/memtest_vulkan issue 22 (the plain device-local,
 * host-visible and mappable video memory types at indices 8-10). Allocating the
 * first eight is invalid without the deviceCoherentMemory feature
 * (VUID-vkAllocateMemory-deviceCoherentMemory-02790), and they are uncached on
 * the device. */
static void test_amd_coherent_first(void **state)
{
	const struct type t[] = {
		{ DL | AMD, 0 },
		{ HV | HC | AMD, 1 },
		{ DL | HV | HC | AMD, 2 },
		{ HV | HC | CACHED | AMD, 1 },
		{ DL | VK_MEMORY_PROPERTY_DEVICE_COHERENT_BIT_AMD, 0 },
		{ HV | HC | VK_MEMORY_PROPERTY_DEVICE_COHERENT_BIT_AMD, 1 },
		{ DL | HV | HC | VK_MEMORY_PROPERTY_DEVICE_COHERENT_BIT_AMD, 2 },
		{ HV | HC | CACHED | VK_MEMORY_PROPERTY_DEVICE_COHERENT_BIT_AMD, 1 },
		{ DL, 0 },
		{ HV | HC, 1 },
		{ DL | HV | HC, 2 },
		{ HV | HC | CACHED, 1 },
	};
	VkPhysicalDeviceMemoryProperties m = table(t, 12);
	/* The rule before this function (the first type with the wanted flags) took
	 * type 0 for device memory and 1 for every host use. */
	assert_int_equal(pick(&m, 0xfff, RELIEF_VK_MEMORY_DEVICE), 8);
	assert_int_equal(pick(&m, 0xfff, RELIEF_VK_MEMORY_UPLOAD), 9);
	assert_int_equal(pick(&m, 0xfff, RELIEF_VK_MEMORY_SHARED), 10);
	assert_int_equal(pick(&m, 0xfff, RELIEF_VK_MEMORY_READBACK), 11);
	/* Only AMD types allowed: nothing, rather than an invalid allocation. */
	uint32_t i = 99;
	assert_int_equal(relief_vk_memory_pick(&m, 0xff, RELIEF_VK_MEMORY_DEVICE, &i), -ENOMEM);
	assert_int_equal(i, 99);
}

/* Unified memory (an integrated GPU): every type is device-local. */
static void test_unified(void **state)
{
	const struct type t[] = { { DL, 0 }, { DL | HV | HC, 0 }, { DL | HV | HC | CACHED, 0 } };
	VkPhysicalDeviceMemoryProperties m = table(t, 3);
	assert_int_equal(pick(&m, 7, RELIEF_VK_MEMORY_DEVICE), 0);
	assert_int_equal(pick(&m, 7, RELIEF_VK_MEMORY_UPLOAD), 1);
	assert_int_equal(pick(&m, 7, RELIEF_VK_MEMORY_READBACK), 2);
	assert_int_equal(pick(&m, 7, RELIEF_VK_MEMORY_SHARED), 2);
}

/* Nothing qualifies: -ENOMEM, whatever the use. */
static void test_none(void **state)
{
	const struct type t[] = {
		{ DL | VK_MEMORY_PROPERTY_PROTECTED_BIT, 0 },
		{ DL | VK_MEMORY_PROPERTY_LAZILY_ALLOCATED_BIT, 0 },
		{ DL, 0 },
	};
	VkPhysicalDeviceMemoryProperties m = table(t, 3);
	uint32_t i = 99;
	for (int use = RELIEF_VK_MEMORY_DEVICE; use <= RELIEF_VK_MEMORY_SHARED; use++) {
		assert_int_equal(relief_vk_memory_pick(&m, 0x3, use, &i), -ENOMEM);
		assert_int_equal(relief_vk_memory_pick(&m, 0, use, &i), -ENOMEM);
	}
	/* host uses need a host-visible, coherent type */
	assert_int_equal(relief_vk_memory_pick(&m, 0x7, RELIEF_VK_MEMORY_UPLOAD, &i), -ENOMEM);
	assert_int_equal(relief_vk_memory_pick(&m, 0x7, RELIEF_VK_MEMORY_DEVICE, &i), 0);
	assert_int_equal(i, 2);
	/* bits beyond memoryTypeCount are ignored */
	m.memoryTypeCount = 2;
	assert_int_equal(relief_vk_memory_pick(&m, 0x7, RELIEF_VK_MEMORY_DEVICE, &i), -ENOMEM);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_lavapipe),
		cmocka_unit_test(test_discrete_small_bar),
		cmocka_unit_test(test_amd_coherent_first),
		cmocka_unit_test(test_unified),
		cmocka_unit_test(test_none),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
