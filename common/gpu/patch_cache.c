/* The GPU patch cache: see patch_cache.h for the rules it keeps. This file holds the
 * render-thread side (requests, layers, eviction, batches); the worker thread is at the end.
 *
 * Locking: `lock` guards the request heap, `queued`, the free staging slots, the ready list
 * and the worker counters. Everything else (patch states, layers, batches, Vulkan objects)
 * belongs to the thread that calls the public functions. */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "decode.h"
#include "patch_cache.h"
#include "pipeline.h"

#include "patch_decode.comp.spv.h"
#include "patch_normals.comp.spv.h"

#define MAX_BATCH 64
#define IN_FLIGHT 3
/* Items (quads or samples) per workgroup of the patch passes (shaders/patch_run.glsl). */
#define RUN_ITEMS 1024u

/* Twin of `Job` in shaders/patch_decode.comp and patch_normals.comp (std430). */
struct job_params {
	int32_t layer, parent_layer, quadrant, ratio;
	uint32_t slot, flag;
	int32_t mode, P;
	uint32_t mask;
	float q2, inv_2sx, inv_2sy;
};
_Static_assert(sizeof(struct job_params) == 48, "job record");

struct request {
	float prio;
	uint32_t id;
};

/* A staging slot's content, handed from the worker to the render thread. */
struct job {
	uint32_t id, slot;
	int result; /* 0, or the worker's negative errno */
};

struct batch {
	bool busy;
	VkCommandBuffer cmd;
	VkFence fence;
	uint32_t n;
	struct job jobs[MAX_BATCH];
	uint32_t layers[MAX_BATCH];
};

struct relief_patch_cache {
	struct relief_vk *vk;            /* borrowed */
	const struct relief_file *file;  /* borrowed */
	struct relief_logger log;
	struct relief_patch_cache_options o;
	uint32_t P, E, count;
	size_t errors_per_layer;         /* floats */
	size_t slot_ints;                /* labels, values, mask, block errors */
	size_t mask_ints;                /* P^2 validity bytes, four per int */

	/* GPU objects */
	struct relief_vk_image heights, normals;
	struct relief_vk_buffer errors, staging, flags, layer_table, use_table;
	struct relief_vk_buffer jobs; /* job_params[IN_FLIGHT][MAX_BATCH], host-visible */
	VkDescriptorSetLayout set_layout;
	VkDescriptorPool descriptor_pool;
	VkDescriptorSet set;
	VkPipelineLayout pipeline_layout;
	VkPipeline decode_pipeline, normals_pipeline;
	VkCommandPool cmd_pool;
	VkQueryPool timer;
	struct batch batches[IN_FLIGHT];
	struct relief_patch_pool pool;
	uint64_t pool_bytes;

	/* render-thread state, per patch */
	uint8_t *state;
	int32_t *layer; /* layer of each resident patch, -1 otherwise; mirrored to layer_table */
	uint64_t *last_used;
	uint16_t *children; /* resident children */
	uint16_t *pins;     /* children queued or decoding */
	/* per layer */
	int32_t *owner;
	uint32_t *free_layers, n_free_layers;
	/* symbols ready, waiting for a layer and a batch */
	struct job *pending;
	uint32_t n_pending;
	struct relief_patch_cache_stats stats;

	/* shared with the worker, under lock */
	pthread_mutex_t lock;
	pthread_cond_t work, progress;
	struct request *heap;
	uint32_t n_heap, cap_heap;
	uint8_t *queued;
	uint32_t *free_slots, n_free_slots;
	struct job *ready;
	uint32_t n_ready;
	uint32_t in_worker;
	uint64_t entropy_ns;
	bool stop;
	uint32_t n_threads; /* workers started */
	pthread_t threads[RELIEF_PATCH_CACHE_MAX_WORKERS];
};

static void *worker_main(void *data);

static uint64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* ---- request heap (min-heap on priority), under lock ---- */

static int heap_push(struct relief_patch_cache *c, float prio, uint32_t id)
{
	if (c->n_heap == c->cap_heap) {
		uint32_t cap = c->cap_heap ? 2 * c->cap_heap : 256;
		struct request *h = realloc(c->heap, sizeof(*h) * cap);
		if (!h)
			return -ENOMEM;
		c->heap = h;
		c->cap_heap = cap;
	}
	uint32_t i = c->n_heap++;
	while (i > 0 && c->heap[(i - 1) / 2].prio > prio) {
		c->heap[i] = c->heap[(i - 1) / 2];
		i = (i - 1) / 2;
	}
	c->heap[i] = (struct request){ prio, id };
	return 0;
}

static struct request heap_pop(struct relief_patch_cache *c)
{
	struct request top = c->heap[0], last = c->heap[--c->n_heap];
	uint32_t i = 0;
	for (;;) {
		uint32_t l = 2 * i + 1, r = l + 1, m = i;
		float mp = last.prio;
		if (l < c->n_heap && c->heap[l].prio < mp)
			m = l, mp = c->heap[l].prio;
		if (r < c->n_heap && c->heap[r].prio < mp)
			m = r;
		if (m == i)
			break;
		c->heap[i] = c->heap[m];
		i = m;
	}
	if (c->n_heap)
		c->heap[i] = last;
	return top;
}

/* ---- creation ---- */

static uint32_t parent_of(const struct relief_patch_cache *c, uint32_t id)
{
	uint32_t l, px, py;
	relief_patch_coords(&c->file->layout, id, &l, &px, &py);
	return relief_patch_id(l - 1, px / 2, py / 2);
}

/* A patch that is resident or on its way there: a child may be requested under it, and a
 * child's job keeps waiting for it. Any other state means it will not become resident. */
static bool on_its_way(uint8_t state)
{
	return state == RELIEF_PATCH_RESIDENT || state == RELIEF_PATCH_QUEUED || state == RELIEF_PATCH_DECODING;
}

static const VkImageUsageFlags POOL_USAGE =
	VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;

static uint64_t pool_bytes_for(struct relief_patch_cache *c, uint32_t n)
{
	VkDeviceSize h = relief_vk_image_bytes(c->vk, VK_FORMAT_R32_SINT, c->E, c->E, n, POOL_USAGE);
	VkDeviceSize m = relief_vk_image_bytes(c->vk, VK_FORMAT_R8G8B8A8_SNORM, c->P, c->P, n, POOL_USAGE);
	if (!h || !m)
		return UINT64_MAX;
	return h + m + (uint64_t)n * c->errors_per_layer * sizeof(float);
}

/* The largest layer count whose pools fit the budget (real allocation sizes). */
static uint32_t layers_for_budget(struct relief_patch_cache *c, uint32_t cap)
{
	uint64_t one = pool_bytes_for(c, 1);
	if (one == UINT64_MAX || one > c->o.budget_bytes)
		return 0;
	uint64_t n = c->o.budget_bytes / one;
	if (n > cap)
		n = cap;
	while (n > 0) {
		uint64_t b = pool_bytes_for(c, (uint32_t)n);
		if (b <= c->o.budget_bytes)
			break;
		uint64_t over = (b - c->o.budget_bytes + one - 1) / one;
		n = n > over ? n - over : 0;
	}
	return (uint32_t)n;
}

static int create_descriptors(struct relief_patch_cache *c)
{
	struct relief_vk *vk = c->vk;
	VkDescriptorSetLayoutBinding b[5] = {
		{ 0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 4, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
	};
	VkDescriptorSetLayoutCreateInfo li = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
		.bindingCount = 5,
		.pBindings = b,
	};
	int ret = relief_vk_check(vk, vkCreateDescriptorSetLayout(vk->device, &li, NULL, &c->set_layout),
	                          "vkCreateDescriptorSetLayout");
	if (ret < 0)
		return ret;
	VkDescriptorPoolSize sizes[2] = {
		{ VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2 },
		{ VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3 },
	};
	VkDescriptorPoolCreateInfo pi = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
		.maxSets = 1,
		.poolSizeCount = 2,
		.pPoolSizes = sizes,
	};
	if ((ret = relief_vk_check(vk, vkCreateDescriptorPool(vk->device, &pi, NULL, &c->descriptor_pool),
	                           "vkCreateDescriptorPool")) < 0)
		return ret;
	VkDescriptorSetAllocateInfo ai = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
		.descriptorPool = c->descriptor_pool,
		.descriptorSetCount = 1,
		.pSetLayouts = &c->set_layout,
	};
	if ((ret = relief_vk_check(vk, vkAllocateDescriptorSets(vk->device, &ai, &c->set), "vkAllocateDescriptorSets")) < 0)
		return ret;
	VkDescriptorImageInfo hi = { VK_NULL_HANDLE, c->heights.view, VK_IMAGE_LAYOUT_GENERAL };
	VkDescriptorImageInfo ni = { VK_NULL_HANDLE, c->normals.view, VK_IMAGE_LAYOUT_GENERAL };
	VkDescriptorBufferInfo si = { c->staging.buffer, 0, VK_WHOLE_SIZE };
	VkDescriptorBufferInfo fi = { c->flags.buffer, 0, VK_WHOLE_SIZE };
	VkDescriptorBufferInfo ji = { c->jobs.buffer, 0, VK_WHOLE_SIZE };
	VkWriteDescriptorSet w[5] = {
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 0, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, &hi, NULL, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 1, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, &ni, NULL, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 2, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, NULL, &si, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 3, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, NULL, &fi, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 4, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, NULL, &ji, NULL },
	};
	vkUpdateDescriptorSets(vk->device, 5, w, 0, NULL);
	return 0;
}

static int create_pipelines(struct relief_patch_cache *c)
{
	struct relief_vk *vk = c->vk;
	VkPushConstantRange range = { VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(uint32_t) }; /* first job */
	VkPipelineLayoutCreateInfo li = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
		.setLayoutCount = 1,
		.pSetLayouts = &c->set_layout,
		.pushConstantRangeCount = 1,
		.pPushConstantRanges = &range,
	};
	int ret = relief_vk_check(vk, vkCreatePipelineLayout(vk->device, &li, NULL, &c->pipeline_layout),
	                          "vkCreatePipelineLayout");
	if (ret < 0)
		return ret;
	if ((ret = relief_vk_compute_pipeline_create(vk, c->pipeline_layout, RELIEF_SPIRV(patch_decode_comp_spv),
	                                             &c->decode_pipeline)) < 0)
		return ret;
	return relief_vk_compute_pipeline_create(vk, c->pipeline_layout, RELIEF_SPIRV(patch_normals_comp_spv),
	                                         &c->normals_pipeline);
}

static void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags src_access,
                           VkPipelineStageFlags dst, VkAccessFlags dst_access)
{
	VkMemoryBarrier m = { VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL, src_access, dst_access };
	vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &m, 0, NULL, 0, NULL);
}

/* Images start in GENERAL and stay there (storage writes, sampling, copies).
 * Puts the pools into the GENERAL layout, and runs both passes once on a job that does
 * nothing (mode 2): drivers that compile pipelines at their first use (lavapipe does)
 * compile them here, not while the first frames wait for patches. */
static int init_layouts(struct relief_patch_cache *c)
{
	VkCommandBuffer cmd;
	int ret = relief_vk_cmd_begin(c->vk, &cmd);
	if (ret < 0)
		return ret;
	VkImageMemoryBarrier b[2];
	const VkImage images[2] = { c->heights.image, c->normals.image };
	for (int i = 0; i < 2; i++)
		b[i] = (VkImageMemoryBarrier){
			.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
			.srcAccessMask = 0,
			.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT,
			.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
			.newLayout = VK_IMAGE_LAYOUT_GENERAL,
			.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
			.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
			.image = images[i],
			.subresourceRange = { VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS },
		};
	vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 0, NULL,
	                     0, NULL, 2, b);
	*(struct job_params *)c->jobs.map = (struct job_params){ .mode = 2 };
	uint32_t first = 0;
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->pipeline_layout, 0, 1, &c->set, 0, NULL);
	vkCmdPushConstants(cmd, c->pipeline_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(first), &first);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->decode_pipeline);
	vkCmdDispatch(cmd, 1, 1, 1);
	memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	               VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->normals_pipeline);
	vkCmdDispatch(cmd, 1, 1, 1);
	return relief_vk_cmd_submit_wait(c->vk, cmd);
}

static int create_batches(struct relief_patch_cache *c)
{
	struct relief_vk *vk = c->vk;
	VkCommandPoolCreateInfo pi = {
		.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
		.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
		.queueFamilyIndex = vk->queue_family,
	};
	int ret = relief_vk_check(vk, vkCreateCommandPool(vk->device, &pi, NULL, &c->cmd_pool), "vkCreateCommandPool");
	if (ret < 0)
		return ret;
	if (vk->timestamp_valid_bits && (ret = relief_vk_query_pool_create(vk, 0, 3 * IN_FLIGHT, &c->timer)) < 0)
		return ret;
	for (int i = 0; i < IN_FLIGHT; i++) {
		VkCommandBufferAllocateInfo ai = {
			.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
			.commandPool = c->cmd_pool,
			.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
			.commandBufferCount = 1,
		};
		VkFenceCreateInfo fi = { .sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO };
		if ((ret = relief_vk_check(vk, vkAllocateCommandBuffers(vk->device, &ai, &c->batches[i].cmd),
		                           "vkAllocateCommandBuffers")) < 0 ||
		    (ret = relief_vk_check(vk, vkCreateFence(vk->device, &fi, NULL, &c->batches[i].fence), "vkCreateFence")) < 0)
			return ret;
	}
	return 0;
}

int relief_patch_cache_create(struct relief_vk *vk, const struct relief_file *f,
                              const struct relief_patch_cache_options *opts, const struct relief_logger *log,
                              struct relief_patch_cache **out)
{
	struct relief_patch_cache *c = calloc(1, sizeof(*c));
	if (!c)
		return -ENOMEM;
	pthread_mutex_init(&c->lock, NULL);
	pthread_cond_init(&c->work, NULL);
	pthread_cond_init(&c->progress, NULL);
	c->vk = vk;
	c->file = f;
	if (log)
		c->log = *log;
	c->o = *opts;
	if (!c->o.budget_bytes)
		c->o.budget_bytes = 256ull << 20;
	if (!c->o.staging_slots)
		c->o.staging_slots = 32;
	if (!c->o.workers || c->o.workers > RELIEF_PATCH_CACHE_MAX_WORKERS)
		c->o.workers = c->o.workers ? RELIEF_PATCH_CACHE_MAX_WORKERS : 1;
	if (!c->o.batch || c->o.batch > MAX_BATCH)
		c->o.batch = c->o.batch > MAX_BATCH ? MAX_BATCH : 16;
	if (!c->o.keep_frames)
		c->o.keep_frames = 2;
	c->P = f->layout.geom.P;
	c->E = f->layout.geom.E;
	c->count = f->hdr.patch_count;
	c->errors_per_layer = relief_block_errors_per_patch(c->P);
	c->mask_ints = ((size_t)c->P * c->P + 3) / 4;
	c->slot_ints = f->layout.geom.n_labels + (size_t)c->E * c->E + c->mask_ints + c->errors_per_layer;

	int ret = -ENOMEM;
	c->state = calloc(c->count, 1);
	c->layer = malloc(sizeof(int32_t) * c->count);
	c->last_used = calloc(c->count, sizeof(uint64_t));
	c->children = calloc(c->count, sizeof(uint16_t));
	c->pins = calloc(c->count, sizeof(uint16_t));
	c->queued = calloc(c->count, 1);
	if (!c->state || !c->layer || !c->last_used || !c->children || !c->pins || !c->queued)
		goto fail;
	uint32_t drawable = 0;
	for (uint32_t id = 0; id < c->count; id++) {
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		c->state[id] = (r.flags & RELIEF_PATCH_EMPTY) ? RELIEF_PATCH_NONE : RELIEF_PATCH_ABSENT;
		drawable += !(r.flags & RELIEF_PATCH_EMPTY);
	}

	VkFormatProperties fp;
	vkGetPhysicalDeviceFormatProperties(vk->phys, VK_FORMAT_R8G8B8A8_SNORM, &fp);
	if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT)) {
		relief_log(&c->log, RELIEF_LOG_ERROR, "patch cache: the device cannot write R8G8B8A8_SNORM storage images");
		ret = -ENOTSUP;
		goto fail;
	}
	uint32_t cap = vk->props.limits.maxImageArrayLayers;
	if (cap > drawable)
		cap = drawable;
	if (c->o.max_layers && cap > c->o.max_layers)
		cap = c->o.max_layers;
	uint32_t n = layers_for_budget(c, cap);
	if (n == 0) {
		relief_log(&c->log, RELIEF_LOG_ERROR, "patch cache: a budget of %llu bytes does not hold one %u-sample patch",
		           (unsigned long long)c->o.budget_bytes, c->P);
		ret = -ENOSPC;
		goto fail;
	}
	if ((ret = relief_vk_image_init(vk, &c->heights, VK_FORMAT_R32_SINT, c->E, c->E, n, VK_IMAGE_VIEW_TYPE_2D_ARRAY,
	                                POOL_USAGE, VK_IMAGE_ASPECT_COLOR_BIT)) < 0 ||
	    (ret = relief_vk_image_init(vk, &c->normals, VK_FORMAT_R8G8B8A8_SNORM, c->P, c->P, n,
	                                VK_IMAGE_VIEW_TYPE_2D_ARRAY, POOL_USAGE, VK_IMAGE_ASPECT_COLOR_BIT)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->errors, (VkDeviceSize)n * c->errors_per_layer * sizeof(float),
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
	                                 VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->staging, (VkDeviceSize)c->o.staging_slots * c->slot_ints * 4,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->flags, sizeof(uint32_t) * c->o.staging_slots,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->layer_table, sizeof(int32_t) * c->count,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->jobs, sizeof(struct job_params) * IN_FLIGHT * MAX_BATCH,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->use_table, sizeof(uint32_t) * c->count,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, true)) < 0)
		goto fail;
	/* -1: nothing resident */
	memset(c->layer, 0xff, sizeof(int32_t) * c->count);
	memset(c->layer_table.map, 0xff, sizeof(int32_t) * c->count);
	memset(c->use_table.map, 0, sizeof(uint32_t) * c->count);
	c->pool_bytes = pool_bytes_for(c, n);
	c->pool = (struct relief_patch_pool){ c->heights.view, c->normals.view, c->errors.buffer, n,
	                                      c->layer_table.buffer, c->use_table.buffer };
	c->owner = malloc(sizeof(int32_t) * n);
	c->free_layers = malloc(sizeof(uint32_t) * n);
	c->free_slots = malloc(sizeof(uint32_t) * c->o.staging_slots);
	c->pending = malloc(sizeof(struct job) * c->o.staging_slots);
	c->ready = malloc(sizeof(struct job) * c->o.staging_slots);
	if (!c->owner || !c->free_layers || !c->free_slots || !c->pending || !c->ready) {
		ret = -ENOMEM;
		goto fail;
	}
	for (uint32_t i = 0; i < n; i++) {
		c->owner[i] = -1;
		c->free_layers[i] = n - 1 - i; /* pop gives layer 0 first */
	}
	c->n_free_layers = n;
	for (uint32_t i = 0; i < c->o.staging_slots; i++)
		c->free_slots[i] = c->o.staging_slots - 1 - i;
	c->n_free_slots = c->o.staging_slots;
	if ((ret = create_descriptors(c)) < 0 || (ret = create_pipelines(c)) < 0 || (ret = create_batches(c)) < 0 ||
	    (ret = init_layouts(c)) < 0)
		goto fail;
	for (; c->n_threads < c->o.workers; c->n_threads++)
		if (pthread_create(&c->threads[c->n_threads], NULL, worker_main, c) != 0) {
			ret = -EAGAIN;
			goto fail;
		}
	relief_log(&c->log, RELIEF_LOG_INFO, "patch cache: %u layers of %u-sample patches, %llu bytes of GPU memory "
	           "(budget %llu), %u decode worker(s)", n, c->P, (unsigned long long)c->pool_bytes,
	           (unsigned long long)c->o.budget_bytes, c->n_threads);
	*out = c;
	return 0;
fail:
	relief_patch_cache_destroy(c);
	return ret;
}

void relief_patch_cache_destroy(struct relief_patch_cache *c)
{
	if (!c)
		return;
	if (c->n_threads) {
		pthread_mutex_lock(&c->lock);
		c->stop = true;
		pthread_cond_broadcast(&c->work);
		pthread_mutex_unlock(&c->lock);
		for (uint32_t i = 0; i < c->n_threads; i++)
			pthread_join(c->threads[i], NULL);
	}
	struct relief_vk *vk = c->vk;
	if (vk->device)
		vkDeviceWaitIdle(vk->device);
	for (int i = 0; i < IN_FLIGHT; i++)
		if (c->batches[i].fence)
			vkDestroyFence(vk->device, c->batches[i].fence, NULL);
	if (c->cmd_pool)
		vkDestroyCommandPool(vk->device, c->cmd_pool, NULL);
	if (c->timer)
		vkDestroyQueryPool(vk->device, c->timer, NULL);
	if (c->decode_pipeline)
		vkDestroyPipeline(vk->device, c->decode_pipeline, NULL);
	if (c->normals_pipeline)
		vkDestroyPipeline(vk->device, c->normals_pipeline, NULL);
	if (c->pipeline_layout)
		vkDestroyPipelineLayout(vk->device, c->pipeline_layout, NULL);
	if (c->descriptor_pool)
		vkDestroyDescriptorPool(vk->device, c->descriptor_pool, NULL);
	if (c->set_layout)
		vkDestroyDescriptorSetLayout(vk->device, c->set_layout, NULL);
	relief_vk_image_finish(vk, &c->heights);
	relief_vk_image_finish(vk, &c->normals);
	relief_vk_buffer_finish(vk, &c->errors);
	relief_vk_buffer_finish(vk, &c->staging);
	relief_vk_buffer_finish(vk, &c->flags);
	relief_vk_buffer_finish(vk, &c->layer_table);
	relief_vk_buffer_finish(vk, &c->use_table);
	relief_vk_buffer_finish(vk, &c->jobs);
	free(c->state);
	free(c->layer);
	free(c->last_used);
	free(c->children);
	free(c->pins);
	free(c->queued);
	free(c->owner);
	free(c->free_layers);
	free(c->free_slots);
	free(c->pending);
	free(c->ready);
	free(c->heap);
	pthread_cond_destroy(&c->work);
	pthread_cond_destroy(&c->progress);
	pthread_mutex_destroy(&c->lock);
	free(c);
}

/* ---- requests ---- */

int relief_patch_cache_request(struct relief_patch_cache *c, uint32_t id, float priority)
{
	if (id >= c->count)
		return -EINVAL;
	switch (c->state[id]) {
	case RELIEF_PATCH_NONE:
		return -ENOENT;
	case RELIEF_PATCH_BAD:
		return -EIO;
	case RELIEF_PATCH_ABSENT:
		break;
	default:
		return 0;
	}
	if (id != 0) {
		uint32_t parent = parent_of(c, id);
		if (!on_its_way(c->state[parent])) {
			int ret = relief_patch_cache_request(c, parent, priority - 1.0f);
			return ret == 0 || ret == -EAGAIN ? -EAGAIN : ret;
		}
		c->pins[parent]++;
	}
	c->state[id] = RELIEF_PATCH_QUEUED;
	pthread_mutex_lock(&c->lock);
	int ret = heap_push(c, priority, id);
	/* The child's symbols can be decoded while its parent is on its way; the worker must
	 * still take the ancestors first (a child's slot is held until its parent is resident),
	 * so those still in the heap are pushed again ahead of it (the stale entries are
	 * skipped when they come up). */
	float ahead = priority;
	for (uint32_t a = id; ret == 0 && a != 0;) {
		a = parent_of(c, a);
		if (!c->queued[a])
			break;
		ahead = fminf(ahead - 1.0f, nextafterf(ahead, -INFINITY)); /* strictly ahead, any magnitude */
		ret = heap_push(c, ahead, a);
	}
	if (ret == 0) {
		c->queued[id] = 1;
		pthread_cond_signal(&c->work);
	}
	pthread_mutex_unlock(&c->lock);
	if (ret < 0) {
		c->state[id] = RELIEF_PATCH_ABSENT;
		if (id != 0)
			c->pins[parent_of(c, id)]--;
	}
	return ret;
}

void relief_patch_cache_touch(struct relief_patch_cache *c, uint32_t id, uint64_t frame)
{
	if (id < c->count && c->last_used[id] < frame)
		c->last_used[id] = frame;
}

/* ---- layers ---- */

/* The host array is what the CPU reads (layer_table may be uncached, write-combined memory
 * on a discrete GPU); layer_table is what the shaders read. Only this writes either. */
static void set_layer(struct relief_patch_cache *c, uint32_t id, int32_t layer)
{
	c->layer[id] = layer;
	((int32_t *)c->layer_table.map)[id] = layer;
}

static int32_t alloc_layer(struct relief_patch_cache *c, uint64_t frame)
{
	if (c->n_free_layers)
		return (int32_t)c->free_layers[--c->n_free_layers];
	/* Evict the least recently used patch that nothing depends on. Views on the GPU stamp
	 * the use table with the frame they drew a patch in. */
	const uint32_t *gpu_use = c->use_table.map;
	int32_t best = -1;
	uint64_t oldest = UINT64_MAX;
	for (uint32_t i = 0; i < c->pool.layers; i++) {
		int32_t id = c->owner[i];
		if (id <= 0)
			continue;
		uint64_t used = c->last_used[id] > gpu_use[id] ? c->last_used[id] : gpu_use[id];
		if (c->children[id] || c->pins[id] || used + c->o.keep_frames >= frame)
			continue;
		if (used < oldest) {
			oldest = used;
			best = (int32_t)i;
		}
	}
	if (best < 0)
		return -1;
	uint32_t id = (uint32_t)c->owner[best];
	c->state[id] = RELIEF_PATCH_ABSENT;
	set_layer(c, id, -1);
	c->children[parent_of(c, id)]--;
	c->owner[best] = -1;
	c->stats.evicted++;
	return best;
}

static void mark_bad(struct relief_patch_cache *c, uint32_t id, int why)
{
	uint32_t l, px, py;
	relief_patch_coords(&c->file->layout, id, &l, &px, &py);
	c->state[id] = RELIEF_PATCH_BAD; /* final: logged exactly once */
	c->stats.bad++;
	relief_log(&c->log, RELIEF_LOG_ERROR, "patch %u (level %u, %u,%u): %s; its parent keeps serving the area", id, l,
	           px, py, why == -EBADMSG ? "corrupt (checksum or values)" : why == -EIO ? "missing from the file"
	                                                                      : "cannot be decoded");
	if (id != 0)
		c->pins[parent_of(c, id)]--;
}

static void release_slot(struct relief_patch_cache *c, uint32_t slot)
{
	pthread_mutex_lock(&c->lock);
	c->free_slots[c->n_free_slots++] = slot;
	pthread_cond_signal(&c->work);
	pthread_mutex_unlock(&c->lock);
}

/* ---- batches ---- */

static void retire(struct relief_patch_cache *c, struct batch *b, uint64_t frame, int *made)
{
	const uint32_t *flags = c->flags.map;
	for (uint32_t i = 0; i < b->n; i++) {
		uint32_t id = b->jobs[i].id, layer = b->layers[i];
		if (flags[b->jobs[i].slot]) {
			c->owner[layer] = -1;
			c->free_layers[c->n_free_layers++] = layer;
			mark_bad(c, id, -EBADMSG);
		} else {
			c->state[id] = RELIEF_PATCH_RESIDENT;
			set_layer(c, id, (int32_t)layer);
			if (c->last_used[id] < frame)
				c->last_used[id] = frame;
			if (id != 0) {
				uint32_t parent = parent_of(c, id);
				c->children[parent]++;
				c->pins[parent]--;
			}
			c->stats.decoded++;
			(*made)++;
		}
		release_slot(c, b->jobs[i].slot);
	}
	if (c->timer) {
		/* Timestamps: batch start, decode pass done, normals pass done. */
		uint64_t t[3];
		uint32_t first = (uint32_t)(b - c->batches) * 3;
		const double period = c->vk->props.limits.timestampPeriod;
		if (vkGetQueryPoolResults(c->vk->device, c->timer, first, 3, sizeof(t), t, sizeof(uint64_t),
		                          VK_QUERY_RESULT_64_BIT) == VK_SUCCESS) {
			c->stats.gpu_ns += (uint64_t)((double)(t[2] - t[0]) * period);
			c->stats.gpu_decode_ns += (uint64_t)((double)(t[1] - t[0]) * period);
			c->stats.gpu_normals_ns += (uint64_t)((double)(t[2] - t[1]) * period);
		}
	}
	b->busy = false;
	b->n = 0;
}

static int submit(struct relief_patch_cache *c, struct batch *b)
{
	struct relief_vk *vk = c->vk;
	const struct relief_layout *lay = &c->file->layout;
	VkCommandBuffer cmd = b->cmd;
	int ret = relief_vk_check(vk, vkResetCommandBuffer(cmd, 0), "vkResetCommandBuffer");
	VkCommandBufferBeginInfo bi = {
		.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
		.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
	};
	if (ret < 0 || (ret = relief_vk_check(vk, vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer")) < 0)
		return ret;
	uint32_t q = (uint32_t)(b - c->batches) * 3;
	if (c->timer) {
		vkCmdResetQueryPool(cmd, c->timer, q, 3);
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, c->timer, q);
	}
	/* Earlier batches (parents, reused layers) and readers of evicted layers come first. */
	memory_barrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
	               VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
	               VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
	               VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT);
	uint32_t *flags = c->flags.map;
	for (uint32_t i = 0; i < b->n; i++) {
		size_t slot_base = (size_t)b->jobs[i].slot * c->slot_ints;
		VkBufferCopy copy = {
			.srcOffset = (slot_base + c->slot_ints - c->errors_per_layer) * 4,
			.dstOffset = (VkDeviceSize)b->layers[i] * c->errors_per_layer * sizeof(float),
			.size = c->errors_per_layer * sizeof(float),
		};
		vkCmdCopyBuffer(cmd, c->staging.buffer, c->errors.buffer, 1, &copy);
		flags[b->jobs[i].slot] = 0;
	}
	/* One record per job, read by both passes; each pass is one dispatch for the batch. */
	uint32_t first = (uint32_t)(b - c->batches) * MAX_BATCH;
	struct job_params *jp = (struct job_params *)c->jobs.map + first;
	for (uint32_t i = 0; i < b->n; i++) {
		uint32_t id = b->jobs[i].id, l, px, py;
		relief_patch_coords(lay, id, &l, &px, &py);
		double step = (double)(1u << (lay->levels - 1 - l));
		struct relief_patch_record rec;
		relief_file_record(c->file, id, &rec);
		jp[i] = (struct job_params){
			.layer = (int32_t)b->layers[i],
			.parent_layer = id ? c->layer[parent_of(c, id)] : 0,
			.quadrant = (int32_t)((px & 1) | ((py & 1) << 1)),
			.ratio = (int32_t)lay->ratio,
			.slot = (uint32_t)(b->jobs[i].slot * c->slot_ints),
			.flag = b->jobs[i].slot,
			.mode = id == 0,
			.P = (int32_t)c->P,
			.mask = (rec.flags & RELIEF_PATCH_MASKED)
			            ? (uint32_t)(b->jobs[i].slot * c->slot_ints + lay->geom.n_labels + (size_t)c->E * c->E)
			            : UINT32_MAX,
			.q2 = (float)(2.0 * lay->delta[l]),
			.inv_2sx = (float)(1.0 / (2.0 * c->file->hdr.spacing_x * step)),
			.inv_2sy = (float)(1.0 / (2.0 * c->file->hdr.spacing_y * step)),
		};
	}
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->pipeline_layout, 0, 1, &c->set, 0, NULL);
	vkCmdPushConstants(cmd, c->pipeline_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(first), &first);
	/* Workgroup x: runs of about RUN_ITEMS items, ((P + 3) / 2)^2 quads for decode and P^2
	 * samples for normals; workgroup z: the job. */
	const uint32_t quads = (c->P + 3) / 2;
	const uint32_t runs_e = (quads * quads + RUN_ITEMS - 1) / RUN_ITEMS;
	const uint32_t runs_p = (c->P * c->P + RUN_ITEMS - 1) / RUN_ITEMS;
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->decode_pipeline);
	vkCmdDispatch(cmd, runs_e, 1, b->n);
	memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	               VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
	if (c->timer) /* after the barrier: the decode pass has finished */
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, c->timer, q + 1);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->normals_pipeline);
	vkCmdDispatch(cmd, runs_p, 1, b->n);
	/* Make the results visible to every later reader, and the flags to the host. */
	memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
	               VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
	               VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT,
	               VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT);
	if (c->timer)
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, c->timer, q + 2);
	if ((ret = relief_vk_check(vk, vkEndCommandBuffer(cmd), "vkEndCommandBuffer")) < 0)
		return ret;
	if ((ret = relief_vk_check(vk, vkResetFences(vk->device, 1, &b->fence), "vkResetFences")) < 0)
		return ret;
	VkSubmitInfo si = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &cmd };
	if ((ret = relief_vk_check(vk, vkQueueSubmit(vk->queue, 1, &si, b->fence), "vkQueueSubmit")) < 0)
		return ret;
	b->busy = true;
	c->stats.batches++;
	return 0;
}

int relief_patch_cache_update(struct relief_patch_cache *c, uint64_t frame)
{
	int made = 0, ret = 0;
	for (int i = 0; i < IN_FLIGHT; i++) {
		struct batch *b = &c->batches[i];
		if (b->busy && vkGetFenceStatus(c->vk->device, b->fence) == VK_SUCCESS)
			retire(c, b, frame, &made);
	}
	/* Take what the worker finished. */
	pthread_mutex_lock(&c->lock);
	struct job ready[256];
	uint32_t n = c->n_ready < 256 ? c->n_ready : 256;
	memcpy(ready, c->ready, sizeof(struct job) * n);
	memmove(c->ready, c->ready + n, sizeof(struct job) * (c->n_ready - n));
	c->n_ready -= n;
	c->stats.entropy_ns = c->entropy_ns;
	pthread_mutex_unlock(&c->lock);
	for (uint32_t i = 0; i < n; i++) {
		if (ready[i].result < 0) {
			mark_bad(c, ready[i].id, ready[i].result);
			release_slot(c, ready[i].slot);
		} else {
			c->state[ready[i].id] = RELIEF_PATCH_DECODING;
			c->pending[c->n_pending++] = ready[i];
		}
	}
	/* Fill free batches with pending patches whose parent is resident (the decode pass
	 * reads it) and that get a layer; the others keep their order in `pending`. */
	bool no_layer = false;
	for (int i = 0; i < IN_FLIGHT && c->n_pending && !no_layer; i++) {
		struct batch *b = &c->batches[i];
		if (b->busy)
			continue;
		uint32_t kept = 0;
		for (uint32_t k = 0; k < c->n_pending; k++) {
			struct job j = c->pending[k];
			uint32_t parent = j.id ? parent_of(c, j.id) : 0;
			uint8_t ps = j.id ? c->state[parent] : RELIEF_PATCH_RESIDENT;
			if (!on_its_way(ps)) {
				/* The parent went bad, or was dropped for that reason itself: an ancestor
				 * serves the area; the request may be made again later. */
				c->state[j.id] = RELIEF_PATCH_ABSENT;
				c->pins[parent]--;
				release_slot(c, j.slot);
				continue;
			}
			int32_t layer = -1;
			if (ps == RELIEF_PATCH_RESIDENT && b->n < c->o.batch && !no_layer)
				no_layer = (layer = alloc_layer(c, frame)) < 0;
			if (layer < 0) {
				c->pending[kept++] = j;
				continue;
			}
			b->jobs[b->n] = j;
			b->layers[b->n] = (uint32_t)layer;
			c->owner[layer] = (int32_t)j.id;
			b->n++;
		}
		c->n_pending = kept;
		if (!b->n)
			break;
		if ((ret = submit(c, b)) < 0)
			return ret;
	}
	return made;
}

int relief_patch_cache_flush(struct relief_patch_cache *c, uint64_t frame)
{
	for (;;) {
		int ret = relief_patch_cache_update(c, frame);
		if (ret < 0)
			return ret;
		bool in_flight = false;
		for (int i = 0; i < IN_FLIGHT; i++)
			if (c->batches[i].busy) {
				vkWaitForFences(c->vk->device, 1, &c->batches[i].fence, VK_TRUE, UINT64_MAX);
				in_flight = true;
			}
		if (in_flight)
			continue;
		pthread_mutex_lock(&c->lock);
		bool worker = c->n_heap || c->in_worker || c->n_ready;
		if (!worker) {
			pthread_mutex_unlock(&c->lock);
			/* Pending symbols here wait for a layer that nothing will free at this frame. */
			return c->n_pending ? -ENOSPC : 0;
		}
		if (!c->n_ready) {
			struct timespec ts;
			clock_gettime(CLOCK_REALTIME, &ts);
			ts.tv_nsec += 2000000;
			if (ts.tv_nsec >= 1000000000) {
				ts.tv_sec++;
				ts.tv_nsec -= 1000000000;
			}
			pthread_cond_timedwait(&c->progress, &c->lock, &ts);
		}
		pthread_mutex_unlock(&c->lock);
	}
}

enum relief_patch_state relief_patch_cache_state(const struct relief_patch_cache *c, uint32_t id)
{
	return id < c->count ? (enum relief_patch_state)c->state[id] : RELIEF_PATCH_NONE;
}

int relief_patch_cache_layer(const struct relief_patch_cache *c, uint32_t id)
{
	return id < c->count && c->state[id] == RELIEF_PATCH_RESIDENT ? c->layer[id] : -1;
}

void relief_patch_cache_stats(const struct relief_patch_cache *c, struct relief_patch_cache_stats *s)
{
	*s = c->stats;
	s->layers = c->pool.layers;
	s->free = c->n_free_layers;
	s->used = c->pool.layers - c->n_free_layers;
	s->bytes = c->pool_bytes;
	s->bytes_per_layer = c->pool_bytes / c->pool.layers;
	s->staging_bytes = c->staging.size + c->flags.size;
}

const struct relief_patch_pool *relief_patch_cache_pool(const struct relief_patch_cache *c)
{
	return &c->pool;
}

int relief_patch_cache_read_layer(struct relief_patch_cache *c, uint32_t layer, int32_t *heights, int8_t *normals,
                                  float *block_errors)
{
	if (layer >= c->pool.layers)
		return -EINVAL;
	struct relief_vk *vk = c->vk;
	size_t hb = (size_t)c->E * c->E * 4, nb = (size_t)c->P * c->P * 4, eb = c->errors_per_layer * sizeof(float);
	struct relief_vk_buffer out;
	int ret = relief_vk_buffer_init(vk, &out, hb + nb + eb, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
	if (ret < 0)
		return ret;
	VkCommandBuffer cmd;
	if ((ret = relief_vk_cmd_begin(vk, &cmd)) < 0) {
		relief_vk_buffer_finish(vk, &out);
		return ret;
	}
	/* The layer goes to TRANSFER_SRC_OPTIMAL for the copy and back to GENERAL. */
	VkImageMemoryBarrier to[2], back[2];
	const VkImage images[2] = { c->heights.image, c->normals.image };
	for (int i = 0; i < 2; i++) {
		to[i] = (VkImageMemoryBarrier){
			.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
			.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT,
			.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT,
			.oldLayout = VK_IMAGE_LAYOUT_GENERAL,
			.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
			.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
			.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
			.image = images[i],
			.subresourceRange = { VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, layer, 1 },
		};
		back[i] = to[i];
		back[i].srcAccessMask = 0;
		back[i].dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
		back[i].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
		back[i].newLayout = VK_IMAGE_LAYOUT_GENERAL;
	}
	VkMemoryBarrier mb = { VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL,
	                       VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT };
	vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &mb, 0, NULL,
	                     2, to);
	VkBufferImageCopy h = {
		.bufferOffset = 0,
		.imageSubresource = { VK_IMAGE_ASPECT_COLOR_BIT, 0, layer, 1 },
		.imageExtent = { c->E, c->E, 1 },
	};
	VkBufferImageCopy n = h;
	n.bufferOffset = hb;
	n.imageExtent = (VkExtent3D){ c->P, c->P, 1 };
	vkCmdCopyImageToBuffer(cmd, c->heights.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.buffer, 1, &h);
	vkCmdCopyImageToBuffer(cmd, c->normals.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.buffer, 1, &n);
	VkBufferCopy e = { (VkDeviceSize)layer * eb, hb + nb, eb };
	vkCmdCopyBuffer(cmd, c->errors.buffer, out.buffer, 1, &e);
	vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0, NULL, 0, NULL,
	                     2, back);
	memory_barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
	               VK_ACCESS_HOST_READ_BIT);
	if ((ret = relief_vk_cmd_submit_wait(vk, cmd)) == 0) {
		const uint8_t *m = out.map;
		if (heights)
			memcpy(heights, m, hb);
		if (normals)
			memcpy(normals, m + hb, nb);
		if (block_errors)
			memcpy(block_errors, m + hb + nb, eb);
	}
	relief_vk_buffer_finish(vk, &out);
	return ret;
}

/* ---- the worker: fetch, check, entropy-decode into a staging slot ---- */

static int fill_slot(struct relief_patch_cache *c, struct relief_decoder *dec, int32_t *root_tmp, uint32_t id,
                     uint32_t slot)
{
	const struct relief_patch_geom *g = &c->file->layout.geom;
	int ret = relief_decoder_symbols(dec, id);
	if (ret < 0)
		return ret;
	int32_t *s = (int32_t *)c->staging.map + (size_t)slot * c->slot_ints;
	int32_t *values = s + g->n_labels;
	if (id == 0) {
		/* The root's MED prediction runs in raster order: reconstructed here, copied on the GPU. */
		if ((ret = relief_root_reconstruct(g, dec->residuals, root_tmp)) < 0)
			return ret;
		memcpy(values, root_tmp, sizeof(int32_t) * g->E * g->E);
	} else {
		for (uint32_t i = 0; i < g->n_labels; i++)
			s[i] = dec->labels[i];
		memcpy(values, dec->residuals, sizeof(int32_t) * g->n_residuals);
	}
	struct relief_patch_record rec;
	relief_file_record(c->file, id, &rec);
	if (rec.flags & RELIEF_PATCH_MASKED) {
		/* Validity bytes, four per int, read by the normals pass into the normals' w. */
		uint8_t *mask = (uint8_t *)(values + (size_t)g->E * g->E);
		memset(mask, 0, c->mask_ints * 4);
		if ((ret = relief_file_mask(c->file, id, mask)) < 0)
			return ret;
	}
	relief_file_block_errors(c->file, id, (float *)(s + c->slot_ints - c->errors_per_layer));
	return 0;
}

static void *worker_main(void *data)
{
	struct relief_patch_cache *c = data;
	struct relief_decoder dec;
	int init = relief_decoder_init(&dec, c->file);
	int32_t *root_tmp = malloc(sizeof(int32_t) * c->E * c->E);
	pthread_mutex_lock(&c->lock);
	for (;;) {
		while (!c->stop && (c->n_heap == 0 || c->n_free_slots == 0))
			pthread_cond_wait(&c->work, &c->lock);
		if (c->stop)
			break;
		struct request r = heap_pop(c);
		if (!c->queued[r.id])
			continue; /* a duplicate of a request already served */
		c->queued[r.id] = 0;
		uint32_t slot = c->free_slots[--c->n_free_slots];
		c->in_worker++;
		pthread_mutex_unlock(&c->lock);
		uint64_t t0 = now_ns();
		int result = init < 0 ? init : !root_tmp ? -ENOMEM : fill_slot(c, &dec, root_tmp, r.id, slot);
		uint64_t t1 = now_ns();
		pthread_mutex_lock(&c->lock);
		c->ready[c->n_ready++] = (struct job){ r.id, slot, result };
		c->in_worker--;
		c->entropy_ns += t1 - t0;
		pthread_cond_broadcast(&c->progress);
	}
	pthread_mutex_unlock(&c->lock);
	free(root_tmp);
	if (init == 0)
		relief_decoder_finish(&dec);
	return NULL;
}
