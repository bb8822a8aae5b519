/* Device selection without a GPU: relief_vk_pick_device() on made-up device lists. */
#include <errno.h>
#include <string.h>

#include "../test_util.h"
#include "vk.h"

static struct relief_vk_device_desc dev(const char *name, VkPhysicalDeviceType type, uint8_t uuid0, bool usable)
{
	struct relief_vk_device_desc d = { .type = type, .usable = usable };
	snprintf(d.name, sizeof(d.name), "%s", name);
	d.uuid[0] = uuid0;
	d.uuid[15] = 0xab;
	return d;
}

static void test_default_order(void **state)
{
	struct relief_vk_device_desc devs[] = {
		dev("llvmpipe (LLVM 15.0.6, 256 bits)", VK_PHYSICAL_DEVICE_TYPE_CPU, 1, true),
		dev("Intel(R) UHD Graphics 620", VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU, 2, true),
		dev("AMD Radeon RX 6800", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, 3, true),
	};
	struct relief_vk_query q;
	size_t i = 99;
	assert_int_equal(relief_vk_query_parse(NULL, &q), 0);
	assert_int_equal(relief_vk_pick_device(devs, 3, &q, &i), 0);
	assert_int_equal(i, 2);
	/* Without the discrete GPU, the integrated one wins over the CPU. */
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), 0);
	assert_int_equal(i, 1);
	assert_int_equal(relief_vk_pick_device(devs, 1, &q, &i), 0);
	assert_int_equal(i, 0);
}

static void test_unusable_skipped(void **state)
{
	struct relief_vk_device_desc devs[] = {
		dev("Old GPU", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, 1, false),
		dev("llvmpipe", VK_PHYSICAL_DEVICE_TYPE_CPU, 2, true),
	};
	struct relief_vk_query q;
	size_t i = 99;
	assert_int_equal(relief_vk_query_parse("", &q), 0);
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), 0);
	assert_int_equal(i, 1);
	assert_int_equal(relief_vk_query_parse("Old", &q), 0);
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), -ENODEV);
	assert_int_equal(relief_vk_pick_device(devs, 0, &q, &i), -ENODEV);
}

static void test_by_name(void **state)
{
	struct relief_vk_device_desc devs[] = {
		dev("AMD Radeon RX 6800", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, 1, true),
		dev("llvmpipe (LLVM 15.0.6, 256 bits)", VK_PHYSICAL_DEVICE_TYPE_CPU, 2, true),
	};
	struct relief_vk_query q;
	size_t i = 99;
	assert_int_equal(relief_vk_query_parse("LLVMpipe", &q), 0);
	assert_int_equal(q.kind, RELIEF_VK_QUERY_NAME);
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), 0);
	assert_int_equal(i, 1);
	assert_int_equal(relief_vk_query_parse("nvidia", &q), 0);
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), -ENODEV);
}

static void test_by_uuid(void **state)
{
	struct relief_vk_device_desc devs[] = {
		dev("GPU A", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, 0x11, true),
		dev("GPU B", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, 0x22, true),
	};
	struct relief_vk_query q;
	size_t i = 99;
	assert_int_equal(relief_vk_query_parse("22000000-0000-0000-0000-0000000000AB", &q), 0);
	assert_int_equal(q.kind, RELIEF_VK_QUERY_UUID);
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), 0);
	assert_int_equal(i, 1);
	/* 31 digits is a name, not a UUID, and matches nothing. */
	assert_int_equal(relief_vk_query_parse("2200000000000000000000000000000", &q), 0);
	assert_int_equal(q.kind, RELIEF_VK_QUERY_NAME);
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), -ENODEV);
}

static void test_by_render_node(void **state)
{
	struct relief_vk_device_desc devs[] = {
		dev("GPU A", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, 1, true),
		dev("GPU B", VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU, 2, true),
	};
	devs[1].has_render_node = true;
	devs[1].render_major = 226;
	devs[1].render_minor = 129;
	struct relief_vk_query q = { .kind = RELIEF_VK_QUERY_RENDER_NODE, .render_major = 226, .render_minor = 129 };
	size_t i = 99;
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), 0);
	assert_int_equal(i, 1);
	q.render_minor = 128;
	assert_int_equal(relief_vk_pick_device(devs, 2, &q, &i), -ENODEV);
	/* A path that is not a render node is refused by the parser. */
	assert_true(relief_vk_query_parse("/dev/null", &q) < 0);
	assert_true(relief_vk_query_parse("/nonexistent/renderD128", &q) == -ENOENT);
}

static void test_result_mapping(void **state)
{
	assert_int_equal(relief_vk_errno(VK_SUCCESS), 0);
	assert_int_equal(relief_vk_errno(VK_ERROR_OUT_OF_HOST_MEMORY), -ENOMEM);
	assert_int_equal(relief_vk_errno(VK_ERROR_DEVICE_LOST), -ENODEV);
	assert_int_equal(relief_vk_errno((VkResult)-123456), -EIO);
	assert_string_equal(relief_vk_result_name(VK_ERROR_DEVICE_LOST), "VK_ERROR_DEVICE_LOST");
	assert_int_equal(relief_vk_check(NULL, VK_ERROR_INITIALIZATION_FAILED, "test"), -EIO);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_default_order),
		cmocka_unit_test(test_unusable_skipped),
		cmocka_unit_test(test_by_name),
		cmocka_unit_test(test_by_uuid),
		cmocka_unit_test(test_by_render_node),
		cmocka_unit_test(test_result_mapping),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
