/* The single VkResult -> errno table. Everything else calls relief_vk_check(). */
#include <errno.h>

#include "vk.h"

#define RESULTS(X)                                                   \
	X(VK_SUCCESS, 0)                                             \
	X(VK_NOT_READY, EAGAIN)                                      \
	X(VK_TIMEOUT, ETIMEDOUT)                                     \
	X(VK_EVENT_SET, 0)                                           \
	X(VK_EVENT_RESET, 0)                                         \
	X(VK_INCOMPLETE, 0)                                          \
	X(VK_ERROR_OUT_OF_HOST_MEMORY, ENOMEM)                       \
	X(VK_ERROR_OUT_OF_DEVICE_MEMORY, ENOSPC)                     \
	X(VK_ERROR_INITIALIZATION_FAILED, EIO)                       \
	X(VK_ERROR_DEVICE_LOST, ENODEV)                              \
	X(VK_ERROR_MEMORY_MAP_FAILED, EFAULT)                        \
	X(VK_ERROR_LAYER_NOT_PRESENT, ENOENT)                        \
	X(VK_ERROR_EXTENSION_NOT_PRESENT, ENOTSUP)                   \
	X(VK_ERROR_FEATURE_NOT_PRESENT, ENOTSUP)                     \
	X(VK_ERROR_INCOMPATIBLE_DRIVER, ENXIO)                       \
	X(VK_ERROR_TOO_MANY_OBJECTS, EMFILE)                         \
	X(VK_ERROR_FORMAT_NOT_SUPPORTED, ENOTSUP)                    \
	X(VK_ERROR_FRAGMENTED_POOL, ENOMEM)                          \
	X(VK_ERROR_UNKNOWN, EIO)                                     \
	X(VK_ERROR_OUT_OF_POOL_MEMORY, ENOMEM)                       \
	X(VK_ERROR_INVALID_EXTERNAL_HANDLE, EBADF)                   \
	X(VK_ERROR_FRAGMENTATION, ENOMEM)                            \
	X(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS, EINVAL)           \
	X(VK_ERROR_VALIDATION_FAILED_EXT, EINVAL)

int relief_vk_errno(VkResult r)
{
	switch (r) {
#define X(name, err) case name: return -(err);
		RESULTS(X)
#undef X
	default:
		return r < 0 ? -EIO : 0;
	}
}

const char *relief_vk_result_name(VkResult r)
{
	switch (r) {
#define X(name, err) case name: return #name;
		RESULTS(X)
#undef X
	default:
		return "VK_RESULT_UNKNOWN";
	}
}

int relief_vk_check(const struct relief_vk *vk, VkResult r, const char *what)
{
	if (r >= 0)
		return 0;
	relief_log(vk ? &vk->log : NULL, RELIEF_LOG_ERROR, "%s: %s", what, relief_vk_result_name(r));
	return relief_vk_errno(r);
}
