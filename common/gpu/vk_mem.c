/* Buffers, images and shader modules, and which memory type each use gets
 * (relief_vk_memory_pick()). Each image and each long-lived buffer (pools, staging,
 * targets) has its own allocation; a terrain view's small buffers share two
 * (relief_vk_buffer_group_init()), since a daemon keeps a view per client channel. Not a
 * general suballocator: nothing is freed inside an allocation. */
#include <errno.h>
#include <string.h>

#include "vk.h"

/* Flags relief never allocates: protected memory and the device-coherent types of
 * VK_AMD_device_coherent_memory need features it does not enable; lazily allocated memory
 * is for transient attachments. */
#define MEMORY_NEVER                                                                       \
	(VK_MEMORY_PROPERTY_PROTECTED_BIT | VK_MEMORY_PROPERTY_LAZILY_ALLOCATED_BIT |            \
	 VK_MEMORY_PROPERTY_DEVICE_COHERENT_BIT_AMD | VK_MEMORY_PROPERTY_DEVICE_UNCACHED_BIT_AMD)

/* Rank of a type with flags f for `use`: -1 unusable, else higher is better. */
static int memory_rank(VkMemoryPropertyFlags f, enum relief_vk_memory_use use)
{
	const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
	const bool local = f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, visible = f & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
	const bool cached = f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
	if (f & MEMORY_NEVER)
		return -1;
	switch (use) {
	case RELIEF_VK_MEMORY_DEVICE:
		return 2 * local + !visible;
	case RELIEF_VK_MEMORY_UPLOAD:
		return (f & host) != host ? -1 : !local;
	case RELIEF_VK_MEMORY_READBACK:
		return (f & host) != host ? -1 : cached;
	case RELIEF_VK_MEMORY_SHARED:
		return (f & host) != host ? -1 : 2 * local + cached;
	}
	return -1;
}

int relief_vk_memory_pick(const VkPhysicalDeviceMemoryProperties *mem, uint32_t type_bits,
                          enum relief_vk_memory_use use, uint32_t *index)
{
	int best = -1;
	for (uint32_t i = 0; i < mem->memoryTypeCount && i < VK_MAX_MEMORY_TYPES; i++) {
		int rank = (type_bits & (1u << i)) ? memory_rank(mem->memoryTypes[i].propertyFlags, use) : -1;
		if (rank > best) {
			best = rank;
			*index = i;
		}
	}
	return best < 0 ? -ENOMEM : 0;
}

static const char *memory_use_name(enum relief_vk_memory_use use)
{
	switch (use) {
	case RELIEF_VK_MEMORY_DEVICE:
		return "device";
	case RELIEF_VK_MEMORY_UPLOAD:
		return "upload";
	case RELIEF_VK_MEMORY_READBACK:
		return "readback";
	case RELIEF_VK_MEMORY_SHARED:
		return "shared";
	}
	return "?";
}

/* Allocates for `use` (every use but DEVICE gets a host-visible, coherent type). */
static int allocate(struct relief_vk *vk, VkMemoryRequirements req, enum relief_vk_memory_use use,
                    VkDeviceMemory *mem)
{
	*mem = VK_NULL_HANDLE;
	uint32_t type;
	int ret = relief_vk_memory_pick(&vk->mem, req.memoryTypeBits, use, &type);
	if (ret < 0) {
		relief_log(&vk->log, RELIEF_LOG_ERROR, "no memory type for %s use among types 0x%x", memory_use_name(use),
		           (unsigned)req.memoryTypeBits);
		return ret;
	}
	VkMemoryAllocateInfo info = {
		.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
		.allocationSize = req.size,
		.memoryTypeIndex = type,
	};
	ret = relief_vk_check(vk, vkAllocateMemory(vk->device, &info, NULL, mem), "vkAllocateMemory");
	if (ret == 0)
		atomic_fetch_add(&vk->allocations, 1);
	return ret;
}

static void release(struct relief_vk *vk, VkDeviceMemory mem)
{
	if (!mem)
		return;
	vkFreeMemory(vk->device, mem, NULL); /* unmaps implicitly */
	atomic_fetch_sub(&vk->allocations, 1);
}

static int buffer_create(struct relief_vk *vk, struct relief_vk_buffer *b, VkDeviceSize size, VkBufferUsageFlags usage)
{
	memset(b, 0, sizeof(*b));
	b->size = size;
	VkBufferCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
		.size = size,
		.usage = usage,
		.sharingMode = VK_SHARING_MODE_EXCLUSIVE,
	};
	return relief_vk_check(vk, vkCreateBuffer(vk->device, &info, NULL, &b->buffer), "vkCreateBuffer");
}

int relief_vk_buffer_init(struct relief_vk *vk, struct relief_vk_buffer *b, VkDeviceSize size,
                          VkBufferUsageFlags usage, enum relief_vk_memory_use use)
{
	int ret = buffer_create(vk, b, size, usage);
	if (ret < 0)
		goto fail;
	VkMemoryRequirements req;
	vkGetBufferMemoryRequirements(vk->device, b->buffer, &req);
	if ((ret = allocate(vk, req, use, &b->memory)) < 0)
		goto fail;
	ret = relief_vk_check(vk, vkBindBufferMemory(vk->device, b->buffer, b->memory, 0), "vkBindBufferMemory");
	if (ret < 0)
		goto fail;
	if (use != RELIEF_VK_MEMORY_DEVICE) {
		ret = relief_vk_check(vk, vkMapMemory(vk->device, b->memory, 0, VK_WHOLE_SIZE, 0, &b->map),
		                      "vkMapMemory");
		if (ret < 0)
			goto fail;
	}
	return 0;
fail:
	relief_vk_buffer_finish(vk, b);
	return ret;
}

int relief_vk_buffer_upload(struct relief_vk *vk, const struct relief_vk_buffer *b, const void *data,
                            VkDeviceSize size)
{
	if (size == 0 || size > b->size)
		return -EINVAL;
	struct relief_vk_buffer up;
	int ret = relief_vk_buffer_init(vk, &up, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, RELIEF_VK_MEMORY_UPLOAD);
	if (ret < 0)
		return ret;
	memcpy(up.map, data, size);
	VkCommandBuffer cmd;
	if ((ret = relief_vk_cmd_begin(vk, &cmd)) == 0) {
		vkCmdCopyBuffer(cmd, up.buffer, b->buffer, 1, &(VkBufferCopy){ 0, 0, size });
		/* Visible to every later command on the queue, whatever reads it (a barrier's
		 * second scope runs on in submission order, into later submissions). */
		VkMemoryBarrier mb = {
			.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
			.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
			.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT,
		};
		vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &mb, 0,
		                     NULL, 0, NULL);
		ret = relief_vk_cmd_submit_wait(vk, cmd);
	}
	relief_vk_buffer_finish(vk, &up);
	return ret;
}

void relief_vk_buffer_finish(struct relief_vk *vk, struct relief_vk_buffer *b)
{
	if (!b)
		return;
	if (b->buffer)
		vkDestroyBuffer(vk->device, b->buffer, NULL);
	release(vk, b->memory);
	memset(b, 0, sizeof(*b));
}

int relief_vk_texel_view_create(struct relief_vk *vk, const struct relief_vk_buffer *b, VkFormat format,
                                uint32_t components, VkFormatFeatureFlags feature, const struct relief_logger *log,
                                const char *what, VkBufferView *out)
{
	VkFormatProperties fp;
	vkGetPhysicalDeviceFormatProperties(vk->phys, format, &fp);
	const VkDeviceSize texels = b->size / (4u * components);
	if (!(fp.bufferFeatures & feature) || texels > vk->props.limits.maxTexelBufferElements) {
		relief_log(log, RELIEF_LOG_ERROR,
		           "%s: the device cannot read %llu texels of it as a %s texel buffer (maxTexelBufferElements %u%s)",
		           what, (unsigned long long)texels,
		           feature == VK_FORMAT_FEATURE_STORAGE_TEXEL_BUFFER_BIT ? "storage" : "uniform",
		           vk->props.limits.maxTexelBufferElements, fp.bufferFeatures & feature ? "" : "; the format lacks the feature");
		return -ENOTSUP;
	}
	VkBufferViewCreateInfo bi = {
		.sType = VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO,
		.buffer = b->buffer,
		.format = format,
		.offset = 0,
		.range = VK_WHOLE_SIZE,
	};
	return relief_vk_check(vk, vkCreateBufferView(vk->device, &bi, NULL, out), "vkCreateBufferView");
}

int relief_vk_buffer_group_init(struct relief_vk *vk, struct relief_vk_buffer_group *g,
                                const struct relief_vk_buffer_spec *specs, size_t n, enum relief_vk_memory_use use)
{
	memset(g, 0, sizeof(*g));
	if (n == 0 || n > RELIEF_VK_BUFFER_GROUP_MAX)
		return -EINVAL;
	for (size_t i = 0; i < n; i++)
		memset(specs[i].buffer, 0, sizeof(*specs[i].buffer));
	/* Offsets: each buffer at its own alignment after the previous one. */
	VkDeviceSize offsets[RELIEF_VK_BUFFER_GROUP_MAX];
	VkMemoryRequirements all = { .size = 0, .alignment = 1, .memoryTypeBits = ~0u };
	int ret = 0;
	for (size_t i = 0; i < n; i++) {
		if ((ret = buffer_create(vk, specs[i].buffer, specs[i].size, specs[i].usage)) < 0)
			break;
		VkMemoryRequirements req;
		vkGetBufferMemoryRequirements(vk->device, specs[i].buffer->buffer, &req);
		offsets[i] = (all.size + req.alignment - 1) / req.alignment * req.alignment;
		all.size = offsets[i] + req.size;
		all.alignment = req.alignment > all.alignment ? req.alignment : all.alignment;
		all.memoryTypeBits &= req.memoryTypeBits;
	}
	if (ret == 0 && (ret = allocate(vk, all, use, &g->memory)) == 0)
		g->size = all.size;
	void *base = NULL;
	if (ret == 0 && use != RELIEF_VK_MEMORY_DEVICE)
		ret = relief_vk_check(vk, vkMapMemory(vk->device, g->memory, 0, VK_WHOLE_SIZE, 0, &base), "vkMapMemory");
	for (size_t i = 0; i < n && ret == 0; i++) {
		ret = relief_vk_check(vk, vkBindBufferMemory(vk->device, specs[i].buffer->buffer, g->memory, offsets[i]),
		                      "vkBindBufferMemory");
		if (base)
			specs[i].buffer->map = (char *)base + offsets[i];
	}
	if (ret < 0) {
		for (size_t i = 0; i < n; i++)
			relief_vk_buffer_finish(vk, specs[i].buffer);
		relief_vk_buffer_group_finish(vk, g);
	}
	return ret;
}

void relief_vk_buffer_group_finish(struct relief_vk *vk, struct relief_vk_buffer_group *g)
{
	if (!g)
		return;
	release(vk, g->memory);
	memset(g, 0, sizeof(*g));
}

static VkImageCreateInfo image_info(VkFormat format, uint32_t width, uint32_t height, uint32_t layers,
                                    VkImageUsageFlags usage)
{
	return (VkImageCreateInfo){
		.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
		.imageType = VK_IMAGE_TYPE_2D,
		.format = format,
		.extent = { width, height, 1 },
		.mipLevels = 1,
		.arrayLayers = layers,
		.samples = VK_SAMPLE_COUNT_1_BIT,
		.tiling = VK_IMAGE_TILING_OPTIMAL,
		.usage = usage,
		.sharingMode = VK_SHARING_MODE_EXCLUSIVE,
		.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
	};
}

int relief_vk_image_init(struct relief_vk *vk, struct relief_vk_image *img, VkFormat format,
                         uint32_t width, uint32_t height, uint32_t layers, VkImageViewType view_type,
                         VkImageUsageFlags usage, VkImageAspectFlags aspect)
{
	memset(img, 0, sizeof(*img));
	img->format = format;
	img->width = width;
	img->height = height;
	img->layers = layers;
	VkImageCreateInfo info = image_info(format, width, height, layers, usage);
	int ret = relief_vk_check(vk, vkCreateImage(vk->device, &info, NULL, &img->image), "vkCreateImage");
	if (ret < 0)
		goto fail;
	VkMemoryRequirements req;
	vkGetImageMemoryRequirements(vk->device, img->image, &req);
	if ((ret = allocate(vk, req, RELIEF_VK_MEMORY_DEVICE, &img->memory)) < 0)
		goto fail;
	ret = relief_vk_check(vk, vkBindImageMemory(vk->device, img->image, img->memory, 0), "vkBindImageMemory");
	if (ret < 0)
		goto fail;
	VkImageViewCreateInfo view = {
		.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
		.image = img->image,
		.viewType = view_type,
		.format = format,
		.subresourceRange = { aspect, 0, 1, 0, layers },
	};
	ret = relief_vk_check(vk, vkCreateImageView(vk->device, &view, NULL, &img->view), "vkCreateImageView");
	if (ret < 0)
		goto fail;
	return 0;
fail:
	relief_vk_image_finish(vk, img);
	return ret;
}

VkDeviceSize relief_vk_image_bytes(struct relief_vk *vk, VkFormat format, uint32_t width, uint32_t height,
                                   uint32_t layers, VkImageUsageFlags usage)
{
	VkImageCreateInfo info = image_info(format, width, height, layers, usage);
	VkImage image;
	if (vkCreateImage(vk->device, &info, NULL, &image) != VK_SUCCESS)
		return 0;
	VkMemoryRequirements req;
	vkGetImageMemoryRequirements(vk->device, image, &req);
	vkDestroyImage(vk->device, image, NULL);
	return req.size;
}

void relief_vk_image_finish(struct relief_vk *vk, struct relief_vk_image *img)
{
	if (!img)
		return;
	if (img->view)
		vkDestroyImageView(vk->device, img->view, NULL);
	if (img->image)
		vkDestroyImage(vk->device, img->image, NULL);
	release(vk, img->memory);
	memset(img, 0, sizeof(*img));
}

int relief_vk_shader_module(struct relief_vk *vk, const uint32_t *code, size_t size, VkShaderModule *out)
{
	int ret = 0;
	pthread_mutex_lock(&vk->modules_lock);
	uint32_t i = 0;
	while (i < vk->n_modules && vk->modules[i].code != code)
		i++;
	if (i == vk->n_modules) {
		VkShaderModuleCreateInfo info = {
			.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
			.codeSize = size,
			.pCode = code,
		};
		VkShaderModule m = VK_NULL_HANDLE;
		if (i == RELIEF_VK_MAX_MODULES)
			ret = -ENOSPC;
		else if ((ret = relief_vk_check(vk, vkCreateShaderModule(vk->device, &info, NULL, &m),
		                                "vkCreateShaderModule")) == 0) {
			vk->modules[i].code = code;
			vk->modules[i].module = m;
			vk->n_modules++;
		}
	}
	if (ret == 0)
		*out = vk->modules[i].module;
	pthread_mutex_unlock(&vk->modules_lock);
	return ret;
}
