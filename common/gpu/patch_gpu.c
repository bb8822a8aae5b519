/* The GPU side of the patch cache: descriptors, the three compute pipelines (decode,
 * normals, transition strip bounds), the batches' command buffers and the timestamps
 * around the passes (patch_cache_internal.h). */
#include <errno.h>
#include <string.h>

#include "patch_cache_internal.h"

#include "patch_decode.comp.spv.h"
#include "patch_normals.comp.spv.h"
#include "patch_strips.comp.spv.h"

/* Timestamps per batch: its start, the decode pass's end, the normals pass's, the strips
 * pass's (the batch's end). */
#define QUERIES 4

/* The staging words, the block records and the layer table as texel buffers
 * (relief_vk_texel_view_create() says why): the decode reads its staging slots, the
 * terrain's passes the block records and the layer table, for every lane at once on a CPU
 * implementation, where storage buffer reads had made up most of those passes
 * (docs/benchmarks.md, docs/lod.md). */
static int create_texel_views(struct relief_patch_cache *c)
{
	struct relief_vk *vk = c->vk;
	const struct {
		const struct relief_vk_buffer *b;
		VkFormat format;
		VkFormatFeatureFlags feature;
		const char *what;
		VkBufferView *view;
	} v[] = {
		{ &c->staging, VK_FORMAT_R32_SINT, VK_FORMAT_FEATURE_STORAGE_TEXEL_BUFFER_BIT,
		  "patch cache: the staging buffer (R32_SINT)", &c->staging_view },
		{ &c->errors, VK_FORMAT_R32_SFLOAT, VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT,
		  "patch cache: the block records (R32_SFLOAT)", &c->errors_view },
		{ &c->layer_table, VK_FORMAT_R32_SINT, VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT,
		  "patch cache: the layer table (R32_SINT)", &c->layer_view },
	};
	for (size_t i = 0; i < sizeof(v) / sizeof(v[0]); i++) {
		int ret = relief_vk_texel_view_create(vk, v[i].b, v[i].format, 1, v[i].feature, &c->log, v[i].what, v[i].view);
		if (ret < 0)
			return ret;
	}
	return 0;
}

/* The passes' descriptor set layout, pipeline layout and pipelines: the same for every
 * patch cache (nothing in them depends on the file or the budget: the patch size and the
 * rest come in the job records), so a device makes them once, at its first cache, and
 * keeps them (relief_vk_shared()). On lavapipe the strip bounds' pipeline alone takes
 * about 0.8 s to make, most of a cache's creation. */
struct patch_program {
	VkDescriptorSetLayout set_layout;
	VkPipelineLayout layout;
	VkPipeline decode, normals, strips;
};

static int program_create(struct relief_vk *vk, void *obj)
{
	struct patch_program *p = obj;
	VkDescriptorSetLayoutBinding b[6] = {
		{ 0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 2, VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 4, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
		{ 5, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL },
	};
	VkDescriptorSetLayoutCreateInfo li = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
		.bindingCount = 6,
		.pBindings = b,
	};
	int ret = relief_vk_check(vk, vkCreateDescriptorSetLayout(vk->device, &li, NULL, &p->set_layout),
	                          "vkCreateDescriptorSetLayout");
	if (ret < 0)
		return ret;
	VkPushConstantRange range = { VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(uint32_t) }; /* first job */
	VkPipelineLayoutCreateInfo pli = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
		.setLayoutCount = 1,
		.pSetLayouts = &p->set_layout,
		.pushConstantRangeCount = 1,
		.pPushConstantRanges = &range,
	};
	if ((ret = relief_vk_check(vk, vkCreatePipelineLayout(vk->device, &pli, NULL, &p->layout),
	                           "vkCreatePipelineLayout")) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, p->layout, RELIEF_SPIRV(patch_decode_comp_spv), &p->decode)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, p->layout, RELIEF_SPIRV(patch_normals_comp_spv), &p->normals)) < 0)
		return ret;
	return relief_vk_compute_pipeline_create(vk, p->layout, RELIEF_SPIRV(patch_strips_comp_spv), &p->strips);
}

static void program_destroy(struct relief_vk *vk, void *obj)
{
	struct patch_program *p = obj;
	const VkPipeline pipes[3] = { p->decode, p->normals, p->strips };
	for (int i = 0; i < 3; i++)
		if (pipes[i])
			vkDestroyPipeline(vk->device, pipes[i], NULL);
	if (p->layout)
		vkDestroyPipelineLayout(vk->device, p->layout, NULL);
	if (p->set_layout)
		vkDestroyDescriptorSetLayout(vk->device, p->set_layout, NULL);
}

static const struct relief_vk_shared_kind patch_program_kind = {
	"patch cache: the decode passes' pipelines", sizeof(struct patch_program), program_create, program_destroy,
};

static int create_descriptors(struct relief_patch_cache *c)
{
	struct relief_vk *vk = c->vk;
	void *prog;
	int ret = relief_vk_shared(vk, &patch_program_kind, &prog);
	if (ret < 0)
		return ret;
	c->prog = prog;
	VkDescriptorPoolSize sizes[3] = {
		{ VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2 },
		{ VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER, 1 },
		{ VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3 },
	};
	VkDescriptorPoolCreateInfo pi = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
		.maxSets = 1,
		.poolSizeCount = 3,
		.pPoolSizes = sizes,
	};
	if ((ret = relief_vk_check(vk, vkCreateDescriptorPool(vk->device, &pi, NULL, &c->descriptor_pool),
	                           "vkCreateDescriptorPool")) < 0)
		return ret;
	VkDescriptorSetAllocateInfo ai = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
		.descriptorPool = c->descriptor_pool,
		.descriptorSetCount = 1,
		.pSetLayouts = &c->prog->set_layout,
	};
	if ((ret = relief_vk_check(vk, vkAllocateDescriptorSets(vk->device, &ai, &c->set), "vkAllocateDescriptorSets")) < 0)
		return ret;
	VkDescriptorImageInfo hi = { VK_NULL_HANDLE, c->heights.view, VK_IMAGE_LAYOUT_GENERAL };
	VkDescriptorImageInfo ni = { VK_NULL_HANDLE, c->normals.view, VK_IMAGE_LAYOUT_GENERAL };
	VkDescriptorBufferInfo fi = { c->flags.buffer, 0, VK_WHOLE_SIZE };
	VkDescriptorBufferInfo ji = { c->jobs.buffer, 0, VK_WHOLE_SIZE };
	VkDescriptorBufferInfo ei = { c->errors.buffer, 0, VK_WHOLE_SIZE };
	VkWriteDescriptorSet w[6] = {
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 0, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, &hi, NULL, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 1, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, &ni, NULL, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 2, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER, NULL, NULL,
		  &c->staging_view },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 3, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, NULL, &fi, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 4, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, NULL, &ji, NULL },
		{ VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, c->set, 5, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, NULL, &ei, NULL },
	};
	vkUpdateDescriptorSets(vk->device, 6, w, 0, NULL);
	return 0;
}

static void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags src_access,
                           VkPipelineStageFlags dst, VkAccessFlags dst_access)
{
	VkMemoryBarrier m = { VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL, src_access, dst_access };
	vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &m, 0, NULL, 0, NULL);
}

/* Images start in GENERAL and stay there (storage writes, sampling, copies).
 * Puts the pools into the GENERAL layout, and runs the three passes once on a job that
 * does nothing (mode 2): drivers that compile pipelines at their first use (lavapipe
 * does) compile the device's shared ones here, at its first cache, not while the first
 * frames wait for patches; a later cache's dispatches find them compiled. */
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
			.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
			.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
			.newLayout = VK_IMAGE_LAYOUT_GENERAL,
			.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
			.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
			.image = images[i],
			.subresourceRange = { VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS },
		};
	vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, NULL, 0, NULL,
	                     2, b);
	/* Zero the pools: the memory is committed here rather than at each layer's first
	 * decode (on lavapipe, page faults in the middle of the decode passes). */
	const VkClearColorValue zero = { .uint32 = { 0, 0, 0, 0 } };
	const VkImageSubresourceRange all = { VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS };
	for (int i = 0; i < 2; i++)
		vkCmdClearColorImage(cmd, images[i], VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &all);
	vkCmdFillBuffer(cmd, c->errors.buffer, 0, VK_WHOLE_SIZE, 0);
	memory_barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
	               VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	*(struct job_params *)c->jobs.map = (struct job_params){ .mode = 2 };
	uint32_t first = 0;
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->layout, 0, 1, &c->set, 0, NULL);
	vkCmdPushConstants(cmd, c->prog->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(first), &first);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->decode);
	vkCmdDispatch(cmd, 1, 1, 1);
	memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	               VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->normals);
	vkCmdDispatch(cmd, 1, 1, 1);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->strips);
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
	if (vk->timestamp_valid_bits && (ret = relief_vk_query_pool_create(vk, 0, QUERIES * IN_FLIGHT, &c->timer)) < 0)
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

int patch_gpu_init(struct relief_patch_cache *c)
{
	int ret;
	if ((ret = create_texel_views(c)) < 0 || (ret = create_descriptors(c)) < 0 ||
	    (ret = create_batches(c)) < 0)
		return ret;
	c->pool.block_view = c->errors_view;
	c->pool.layer_view = c->layer_view;
	return init_layouts(c);
}

void patch_gpu_finish(struct relief_patch_cache *c)
{
	struct relief_vk *vk = c->vk;
	for (int i = 0; i < IN_FLIGHT; i++)
		if (c->batches[i].fence)
			vkDestroyFence(vk->device, c->batches[i].fence, NULL);
	if (c->cmd_pool)
		vkDestroyCommandPool(vk->device, c->cmd_pool, NULL);
	if (c->timer)
		vkDestroyQueryPool(vk->device, c->timer, NULL);
	if (c->descriptor_pool)
		vkDestroyDescriptorPool(vk->device, c->descriptor_pool, NULL);
	if (c->staging_view)
		vkDestroyBufferView(vk->device, c->staging_view, NULL);
	if (c->errors_view)
		vkDestroyBufferView(vk->device, c->errors_view, NULL);
	if (c->layer_view)
		vkDestroyBufferView(vk->device, c->layer_view, NULL);
}

void patch_gpu_time(struct relief_patch_cache *c, const struct batch *b)
{
	if (!c->timer)
		return;
	uint64_t t[QUERIES];
	uint32_t first = (uint32_t)(b - c->batches) * QUERIES;
	if (!c->o.pass_timing) { /* the batch's start and end only */
		if (vkGetQueryPoolResults(c->vk->device, c->timer, first, 1, sizeof(t[0]), &t[0], sizeof(uint64_t),
		                          VK_QUERY_RESULT_64_BIT) == VK_SUCCESS &&
		    vkGetQueryPoolResults(c->vk->device, c->timer, first + 3, 1, sizeof(t[3]), &t[3], sizeof(uint64_t),
		                          VK_QUERY_RESULT_64_BIT) == VK_SUCCESS)
			c->stats.gpu_ns += relief_vk_ticks_elapsed_ns(c->vk, t[0], t[3]);
		return;
	}
	if (vkGetQueryPoolResults(c->vk->device, c->timer, first, QUERIES, sizeof(t), t, sizeof(uint64_t),
	                          VK_QUERY_RESULT_64_BIT) != VK_SUCCESS)
		return;
	c->stats.gpu_ns += relief_vk_ticks_elapsed_ns(c->vk, t[0], t[3]);
	c->stats.gpu_decode_ns += relief_vk_ticks_elapsed_ns(c->vk, t[0], t[1]);
	c->stats.gpu_normals_ns += relief_vk_ticks_elapsed_ns(c->vk, t[1], t[2]);
	c->stats.gpu_strips_ns += relief_vk_ticks_elapsed_ns(c->vk, t[2], t[3]);
}

int patch_gpu_submit(struct relief_patch_cache *c, struct batch *b)
{
	struct relief_vk *vk = c->vk;
	const struct relief_layout *lay = &c->file->layout;
	/* The batch's own command buffer, or the capture's (tests, relief_vk_capture_begin()) */
	VkCommandBuffer cmd;
	int ret = relief_vk_cmd_reuse(vk, b->cmd, &cmd);
	if (ret < 0)
		return ret;
	uint32_t q = (uint32_t)(b - c->batches) * QUERIES;
	if (c->timer) {
		vkCmdResetQueryPool(cmd, c->timer, q, QUERIES);
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, c->timer, q);
	}
	/* Earlier batches (parents, reused layers) and readers of evicted layers come first. */
	memory_barrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
	               VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
	               VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
	               VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT);
	uint32_t *flags = c->flags.map;
	VkBufferCopy copies[MAX_BATCH]; /* the stored block errors, one region per patch */
	for (uint32_t i = 0; i < b->n; i++) {
		size_t slot_base = (size_t)b->jobs[i].slot * c->slot_ints;
		copies[i] = (VkBufferCopy){
			.srcOffset = (slot_base + c->slot_ints - c->block_floats) * 4,
			.dstOffset = (VkDeviceSize)b->layers[i] * c->layer_floats * sizeof(float),
			.size = c->block_floats * sizeof(float),
		};
		flags[b->jobs[i].slot] = 0;
	}
	vkCmdCopyBuffer(cmd, c->staging.buffer, c->errors.buffer, b->n, copies);
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
			.parent_layer = b->parent_layers[i],
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
			.finest = l + 1 == lay->levels,
			.e0 = relief_file_measured_draw_error(c->file, &rec),
		};
	}
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->layout, 0, 1, &c->set, 0, NULL);
	vkCmdPushConstants(cmd, c->prog->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(first), &first);
	/* Workgroup x: runs of about RUN_ITEMS items (shaders/patch_run.glsl): for decode a
	 * segment of 8 quads of a row, ((P + 3) / 2 + 7) / 8 x (P + 3) / 2 of them; for normals
	 * a block of 4 x 8 samples, (P + 3) / 4 x (P + 7) / 8 of them. Workgroup z: the job. */
	const uint32_t quads = (c->P + 3) / 2;
	const uint32_t runs_e = ((quads + 7) / 8 * quads + RUN_ITEMS - 1) / RUN_ITEMS;
	const uint32_t runs_p = ((c->P + 3) / 4 * ((c->P + 7) / 8) + RUN_ITEMS - 1) / RUN_ITEMS;
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->decode);
	vkCmdDispatch(cmd, runs_e, 1, b->n);
	/* The heights for the next two passes; and the block records' copy before the strips
	 * pass writes the rest of each record (other bytes, but the same buffer binding). */
	memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
	               VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	               VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	if (c->timer && c->o.pass_timing) /* after the barrier: the decode pass has finished */
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, c->timer, q + 1);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->normals);
	vkCmdDispatch(cmd, runs_p, 1, b->n);
	/* The transition strip bounds read the heights too and write their own part of the
	 * layers' block records: no barrier after the normals pass (so the timestamp between
	 * them marks the normals' end; the strips may have started). */
	if (c->timer && c->o.pass_timing)
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, c->timer, q + 2);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->prog->strips);
	vkCmdDispatch(cmd, 1, 1, b->n);
	/* Make the results visible to every later reader, and the flags to the host. */
	memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
	               VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
	               VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT,
	               VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT);
	if (c->timer)
		vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, c->timer, q + 3);
	if ((ret = relief_vk_check(vk, vkResetFences(vk->device, 1, &b->fence), "vkResetFences")) < 0)
		return ret;
	if ((ret = relief_vk_cmd_submit_kept(vk, cmd, b->fence)) < 0)
		return ret;
	b->busy = true;
	b->seq = c->next_seq++;
	c->stats.batches++;
	return 0;
}

int relief_patch_cache_read_layer(struct relief_patch_cache *c, uint32_t layer, int32_t *heights, int8_t *normals,
                                  float *block_errors)
{
	if (layer >= c->pool.layers)
		return -EINVAL;
	struct relief_vk *vk = c->vk;
	size_t hb = (size_t)c->E * c->E * 4, nb = (size_t)c->P * c->P * 4, eb = c->layer_floats * sizeof(float);
	struct relief_vk_buffer out;
	int ret = relief_vk_buffer_init(vk, &out, hb + nb + eb, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                RELIEF_VK_MEMORY_READBACK);
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
