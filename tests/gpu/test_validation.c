/* The validation plumbing itself: a deliberate API misuse must reach the counter that
 * every GPU test asserts is zero. Without this, "0 validation messages" could mean the
 * layer was never loaded. */
#include "gpu_test.h"

static unsigned seen;

static void expected_log(void *data, enum relief_log_level level, const char *fmt, va_list ap)
{
	if (level <= RELIEF_LOG_WARN)
		seen++;
}

static void test_misuse_is_counted(void **state)
{
	struct relief_logger quiet = { expected_log, NULL };
	struct relief_vk_options o = { .validation = true, .log = &quiet };
	struct relief_vk *vk = NULL;
	assert_int_equal(relief_vk_create(&o, &vk), 0);
	dl_iterate_phdr(gpu_test_pin_one, NULL);
	assert_int_equal(atomic_load(&vk->validation_messages), 0);
	/* VUID-VkBufferCreateInfo-size-00912: size must be greater than 0. */
	VkBufferCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
		.size = 0,
		.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	};
	VkBuffer buf = VK_NULL_HANDLE;
	VkResult r = vkCreateBuffer(vk->device, &info, NULL, &buf);
	assert_true(atomic_load(&vk->validation_messages) > 0);
	assert_true(seen > 0); /* and it went through the logger */
	if (r == VK_SUCCESS && buf)
		vkDestroyBuffer(vk->device, buf, NULL);
	relief_vk_destroy(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_misuse_is_counted),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
