/* Device selection, kept free of Vulkan calls so that it is unit-tested without a GPU.
 * The caller (vk.c) fills one relief_vk_device_desc per physical device. */
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <xf86drm.h>

#include "vk.h"

const char *relief_vk_device_type_name(VkPhysicalDeviceType type)
{
	switch (type) {
	case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
	case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
	case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
	case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
	default: return "other";
	}
}

/* Lower is better: the default order. */
static int type_rank(VkPhysicalDeviceType type)
{
	switch (type) {
	case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
	case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
	case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
	case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
	default: return 4;
	}
}

static int hex_value(char c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	c = (char)tolower((unsigned char)c);
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	return -1;
}

/* 32 hex digits, dashes ignored; anything else is not a UUID. */
static bool parse_uuid(const char *s, uint8_t uuid[VK_UUID_SIZE])
{
	size_t digits = 0;
	uint8_t out[VK_UUID_SIZE] = { 0 };
	for (; *s; s++) {
		if (*s == '-')
			continue;
		int v = hex_value(*s);
		if (v < 0 || digits >= 2 * VK_UUID_SIZE)
			return false;
		out[digits / 2] = (uint8_t)(out[digits / 2] | (v << (digits % 2 ? 0 : 4)));
		digits++;
	}
	if (digits != 2 * VK_UUID_SIZE)
		return false;
	memcpy(uuid, out, VK_UUID_SIZE);
	return true;
}

static int render_node_lookup(const char *path, int64_t *major, int64_t *minor)
{
	int fd = open(path, O_RDWR | O_CLOEXEC);
	if (fd < 0)
		return -errno;
	int ret = 0;
	struct stat st;
	if (fstat(fd, &st) < 0)
		ret = -errno;
	else if (!S_ISCHR(st.st_mode) || drmGetNodeTypeFromFd(fd) != DRM_NODE_RENDER)
		ret = -EINVAL;
	close(fd);
	if (ret == 0) {
		*major = major(st.st_rdev);
		*minor = minor(st.st_rdev);
	}
	return ret;
}

int relief_vk_query_parse(const char *want, struct relief_vk_query *q)
{
	struct relief_vk_query r = { .kind = RELIEF_VK_QUERY_DEFAULT };
	if (!want || !*want) {
		*q = r;
		return 0;
	}
	if (want[0] == '/') {
		int ret = render_node_lookup(want, &r.render_major, &r.render_minor);
		if (ret < 0)
			return ret;
		r.kind = RELIEF_VK_QUERY_RENDER_NODE;
	} else if (parse_uuid(want, r.uuid)) {
		r.kind = RELIEF_VK_QUERY_UUID;
	} else {
		if (strlen(want) >= sizeof(r.name))
			return -ENAMETOOLONG;
		strcpy(r.name, want);
		r.kind = RELIEF_VK_QUERY_NAME;
	}
	*q = r;
	return 0;
}

static bool name_contains(const char *name, const char *needle)
{
	size_t n = strlen(needle);
	for (; *name; name++) {
		size_t i = 0;
		while (i < n && name[i] && tolower((unsigned char)name[i]) == tolower((unsigned char)needle[i]))
			i++;
		if (i == n)
			return true;
	}
	return n == 0;
}

static bool matches(const struct relief_vk_device_desc *d, const struct relief_vk_query *q)
{
	switch (q->kind) {
	case RELIEF_VK_QUERY_DEFAULT:
		return true;
	case RELIEF_VK_QUERY_NAME:
		return name_contains(d->name, q->name);
	case RELIEF_VK_QUERY_UUID:
		return memcmp(d->uuid, q->uuid, VK_UUID_SIZE) == 0;
	case RELIEF_VK_QUERY_RENDER_NODE:
		return d->has_render_node && d->render_major == q->render_major &&
		       d->render_minor == q->render_minor;
	}
	return false;
}

int relief_vk_pick_device(const struct relief_vk_device_desc *devs, size_t n,
                          const struct relief_vk_query *q, size_t *index)
{
	size_t best = n;
	for (size_t i = 0; i < n; i++) {
		if (!devs[i].usable || !matches(&devs[i], q))
			continue;
		if (best == n || type_rank(devs[i].type) < type_rank(devs[best].type))
			best = i;
	}
	if (best == n)
		return -ENODEV;
	*index = best;
	return 0;
}
