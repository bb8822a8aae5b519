/* The terrain renderer (see terrain.h). One descriptor set layout serves the three
 * pipelines (selection, draw records, drawing); each view has two sets that swap its
 * hysteresis buffers every frame. */
#include <assert.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline.h"
#include "terrain.h"

#include "lod_commands.comp.spv.h"
#include "lod_borders.comp.spv.h"
#include "lod_factors.comp.spv.h"
#include "lod_select.comp.spv.h"
#include "terrain.frag.spv.h"
#include "terrain.tesc.spv.h"
#include "terrain.tese.spv.h"
#include "terrain.vert.spv.h"

/* Requests one view can make in a frame (id and distance each); the rest follow next frame. */
#define WANT_CAP 1024
struct want {
	uint32_t id;
	float distance; /* metres from the camera to the patch's box */
};
/* Tessellated vertices of one quad patch at most: factor 16 everywhere, (16 + 1)^2. */
#define MAX_VERTICES_PER_QUAD 289u
/* Metres a camera must be above relief_surface_height_bound() for back faces to be culled:
 * drawn heights are floats of at most ~10 km, rounded to ~1 mm. */
#define FACE_CULL_MARGIN 0.01

/* std430 twins of the shaders' push blocks and structs (shaders/terrain_*.glsl). */
struct select_push {
	float vp[16];
	int32_t cell[2];
	float frac[2], spacing[2];
	float cam_z, kappa, tau;
	uint32_t frame, count, levels, P, want_cap;
	float delta_finest;
	uint32_t ratio;
};
_Static_assert(sizeof(struct select_push) == 128, "select push block");

struct commands_push {
	uint32_t per_patch, blocks, per_draw, max_draws;
	uint32_t cpu_cull; /* relief_surface_height_bound()'s decision, for when no drawn block holds the eye */
	float margin;      /* FACE_CULL_MARGIN */
};

struct draw_push {
	float vp[16];
	float viewport[2];
	float tau, cam_z;
	uint32_t P, blocks, per_patch, mode;
	float sun[4];
	float hrange[2];
	float target_px;
	uint32_t ratio;
};
_Static_assert(sizeof(struct draw_push) == 128, "draw push block");

struct patch_info {
	float hmin, hmax, err, skirt;
};

struct instance {
	uint32_t id;
	int32_t layer;
	uint32_t level;
	float q2;
	int32_t base[2], scale;
	float err, skirt;
	uint32_t px, py;
	float pad, frac[2], spacing[2];
};
_Static_assert(sizeof(struct instance) == 64, "instance");

struct counters {
	uint32_t drawn, draws, wants, curtains;
	uint32_t factor_groups[4]; /* VkDispatchIndirectCommand for lod_factors.comp, then padding */
	uint32_t border_groups[4]; /* the same for lod_borders.comp */
	/* lod_commands.comp: back faces culled; a drawn block holds the eye; the highest
	 * block around it (metres) */
	uint32_t face_culled, found;
	float near_high;
	uint32_t pad;
	uint32_t draw_split[4];       /* the draw count for the culling pipeline, for the other */
};
/* The per-view camera buffer (binding 15): the drawing view-projection, then the drawing
 * eye relative to the LOD camera (x east, y north) and its absolute height (z). */
struct draw_camera {
	float vp[16];
	float eye[4];
};

/* draw_push.mode: bit 0 wireframe pass, bits 1-2 enum relief_fine_lod, bit 3 no skirts,
 * bit 4 no block culling. */
#define MODE_NO_SKIRTS 8u
#define MODE_NO_BLOCK_CULL 16u
#define MODE_MORPH 32u

/* One descriptor set for every stage. Bindings: 0 patch info, 1 layer table, 2-3 split
 * state (this frame's input, output), 4 instances, 5 counters, 6 requests, 7 use table,
 * 8 draw records, 9 heights, 10 normals (storage images), 11 block errors, 12 drawn marks,
 * 13 tessellation factors and morph bytes (uvec4 per quad, lod_factors.comp), 14 curtains
 * (terrain-edge sides of drawn patches), 15 the draw camera's view-projection (float[16]),
 * 16 seal records (uvec4 per quad, terrain_seal.glsl),
 * 17 border records (uvec2 per drawn patch's border block edge and corner, lod_borders.comp),
 * 18 the cache's use distances (patch_cache.h, pool.use_dist). */
#define BINDINGS 19u
#define STORAGE_BUFFERS (BINDINGS - 2u) /* all but the two images */

static VkDescriptorType binding_type(uint32_t i)
{
	return i == 9 || i == 10 ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
}

struct relief_terrain {
	struct relief_vk *vk;
	const struct relief_file *file;
	struct relief_patch_cache *cache;
	struct relief_vk_buffer info;
	VkDescriptorSetLayout set_layout;
	VkPipelineLayout select_layout, commands_layout, factors_layout, draw_layout;
	/* draw_cull: draw_fill with back faces culled, for cameras above the surface */
	VkPipeline select, commands, borders, factors, draw_fill, draw_cull, draw_wire;
	/* per_patch: block quads per drawn patch; max_quads: block and curtain quads of a frame
	 * at most (every layer drawn, each with four curtains: a loose bound) */
	uint32_t count, blocks, per_patch, per_draw, max_patches, max_quads, max_draws;
};

struct relief_terrain_view {
	struct relief_terrain *t;
	struct relief_vk_buffer split[2], instances, cmds, counters, wants, drawn, factors, seals, borders, curtains;
	/* struct draw_camera: the view-projection positions are drawn with (the LOD's own
	 * matrix is in the push constants), written by the frame's command buffer */
	struct relief_vk_buffer camera;
	/* What the CPU reads after a frame: counters and requests, copied at its end; the
	 * drawn instances, copied when asked for (relief_terrain_view_drawn()) */
	struct relief_vk_buffer read_counters, read_wants, read_instances;
	/* The memory of the buffers above: device (all but the last three), readback (those).
	 * Nothing the device reads or updates every frame lives in memory the CPU maps, which
	 * on a discrete GPU is system memory across the bus. */
	struct relief_vk_buffer_group local, readback;
	VkDescriptorPool pool;
	VkDescriptorSet set[2];
	uint32_t parity;
	uint32_t last_drawn;
	/* Per view, so that several views' frames can be in flight at once */
	VkQueryPool stats_pool;
	struct relief_vk_timer timer; /* 0 frame start, 1 selection and records done, 2 factors done, 3 frame done */
	/* The frame in flight (relief_terrain_draw_submit() to relief_terrain_view_wait()):
	 * its command buffer (VK_NULL_HANDLE: none), fence, and how back faces were culled */
	VkCommandBuffer pending;
	VkFence fence;
	bool gpu_cull, cpu_cull;
};

static int layout_with_push(struct relief_vk *vk, VkDescriptorSetLayout set, VkShaderStageFlags stages, uint32_t size,
                            VkPipelineLayout *out)
{
	VkPushConstantRange range = { stages, 0, size };
	VkPipelineLayoutCreateInfo li = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
		.setLayoutCount = 1,
		.pSetLayouts = &set,
		.pushConstantRangeCount = 1,
		.pPushConstantRanges = &range,
	};
	return relief_vk_check(vk, vkCreatePipelineLayout(vk->device, &li, NULL, out), "vkCreatePipelineLayout");
}

/* Skirt depth: how far below its border a patch's skirt reaches. Skirts hang only from the
 * terrain's outer edge (inside, borders are sealed: docs/lod.md), as a curtain that hides
 * the gap under the edge's simplified outline: the coarsest block simplification's bound
 * (max eps_4) plus Err(P), doubled, plus the finest tolerance. Generous on purpose: eps_4
 * alone bounds the outline against the finest surface (for files before version 4 it
 * already holds Err(P), which is then counted twice; a deeper curtain costs nothing). */
static float skirt_depth(const struct relief_file *f, uint32_t id, const struct relief_patch_record *r)
{
	size_t n = relief_block_errors_per_patch(f->hdr.patch_size);
	float eps[16 * 16 * 4];
	relief_file_block_errors(f, id, eps);
	float worst = 0.0f;
	for (size_t i = 3; i < n; i += 4)
		worst = isfinite(eps[i]) && eps[i] > worst ? eps[i] : worst;
	return 2.0f * (r->error + worst) + (float)f->layout.delta[f->hdr.levels - 1];
}

/* The device limits the terrain needs beyond Vulkan's guaranteed minimums: every stage
 * sees the one descriptor set's STORAGE_BUFFERS storage buffers (the minimum per stage is 4;
 * desktop GPUs and lavapipe take thousands), and a frame may issue max_draws draw records.
 * -ENOTSUP, naming the limit, where the device has less. */
static int check_limits(struct relief_vk *vk, uint32_t max_draws)
{
	const VkPhysicalDeviceLimits *l = &vk->props.limits;
	const struct { const char *name; uint32_t have, need; } req[] = {
		{ "maxPerStageDescriptorStorageBuffers", l->maxPerStageDescriptorStorageBuffers, STORAGE_BUFFERS },
		{ "maxDescriptorSetStorageBuffers", l->maxDescriptorSetStorageBuffers, STORAGE_BUFFERS },
		{ "maxDrawIndirectCount", l->maxDrawIndirectCount, max_draws },
	};
	for (size_t i = 0; i < sizeof(req) / sizeof(req[0]); i++)
		if (req[i].have < req[i].need) {
			relief_log(&vk->log, RELIEF_LOG_ERROR, "terrain: the device's %s is %u, the terrain needs %u",
			           req[i].name, req[i].have, req[i].need);
			return -ENOTSUP;
		}
	return 0;
}

int relief_terrain_create(struct relief_vk *vk, const struct relief_file *f, struct relief_patch_cache *cache,
                          const struct relief_vk_target *target, struct relief_terrain **out)
{
	struct relief_terrain *t = calloc(1, sizeof(*t));
	if (!t)
		return -ENOMEM;
	t->vk = vk;
	t->file = f;
	t->cache = cache;
	t->count = f->hdr.patch_count;
	t->blocks = f->layout.blocks;
	t->per_patch = t->blocks * t->blocks;
	t->per_draw = RELIEF_VK_MAX_TESS_VERTICES_PER_DRAW / MAX_VERTICES_PER_QUAD;
	t->max_patches = relief_patch_cache_pool(cache)->layers;
	if (t->max_patches > t->count)
		t->max_patches = t->count;
	t->max_quads = t->max_patches * (t->per_patch + 4 * t->blocks);
	t->max_draws = (t->max_quads + t->per_draw - 1) / t->per_draw;

	int ret = check_limits(vk, t->max_draws);
	if (ret < 0)
		goto fail;
	/* Every frame's selection reads it: device memory, filled once. */
	struct patch_info *info = malloc(sizeof(*info) * t->count);
	if (!info) {
		ret = -ENOMEM;
		goto fail;
	}
	for (uint32_t id = 0; id < t->count; id++) {
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		bool empty = r.flags & RELIEF_PATCH_EMPTY;
		info[id] = (struct patch_info){ r.height_min, r.height_max, r.error, empty ? -1.0f : skirt_depth(f, id, &r) };
	}
	if ((ret = relief_vk_buffer_init(vk, &t->info, sizeof(*info) * t->count,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                 RELIEF_VK_MEMORY_DEVICE)) == 0)
		ret = relief_vk_buffer_upload(vk, &t->info, info, sizeof(*info) * t->count);
	free(info);
	if (ret < 0)
		goto fail;

	VkDescriptorSetLayoutBinding b[BINDINGS];
	for (uint32_t i = 0; i < BINDINGS; i++)
		b[i] = (VkDescriptorSetLayoutBinding){ i, binding_type(i), 1, VK_SHADER_STAGE_ALL, NULL };
	VkDescriptorSetLayoutCreateInfo li = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
		.bindingCount = BINDINGS,
		.pBindings = b,
	};
	if ((ret = relief_vk_check(vk, vkCreateDescriptorSetLayout(vk->device, &li, NULL, &t->set_layout),
	                           "vkCreateDescriptorSetLayout")) < 0 ||
	    (ret = layout_with_push(vk, t->set_layout, VK_SHADER_STAGE_COMPUTE_BIT, sizeof(struct select_push),
	                            &t->select_layout)) < 0 ||
	    (ret = layout_with_push(vk, t->set_layout, VK_SHADER_STAGE_COMPUTE_BIT, sizeof(struct commands_push),
	                            &t->commands_layout)) < 0 ||
	    (ret = layout_with_push(vk, t->set_layout, VK_SHADER_STAGE_COMPUTE_BIT, sizeof(struct draw_push),
	                            &t->factors_layout)) < 0 ||
	    (ret = layout_with_push(vk, t->set_layout, VK_SHADER_STAGE_ALL_GRAPHICS, sizeof(struct draw_push),
	                            &t->draw_layout)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, t->select_layout, RELIEF_SPIRV(lod_select_comp_spv), &t->select)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, t->commands_layout, RELIEF_SPIRV(lod_commands_comp_spv),
	                                             &t->commands)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, t->factors_layout, RELIEF_SPIRV(lod_borders_comp_spv),
	                                             &t->borders)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, t->factors_layout, RELIEF_SPIRV(lod_factors_comp_spv),
	                                             &t->factors)) < 0)
		goto fail;
	struct relief_vk_tess_pipeline_desc d = {
		.vert = RELIEF_SPIRV(terrain_vert_spv),
		.tesc = RELIEF_SPIRV(terrain_tesc_spv),
		.tese = RELIEF_SPIRV(terrain_tese_spv),
		.frag = RELIEF_SPIRV(terrain_frag_spv),
		.control_points = 4,
		.layout = t->draw_layout,
		.pass = target->pass,
		.reversed_z = true,
	};
	if ((ret = relief_vk_tess_pipeline_create(vk, &d, &t->draw_fill)) < 0)
		goto fail;
	d.cull_back = true;
	if ((ret = relief_vk_tess_pipeline_create(vk, &d, &t->draw_cull)) < 0)
		goto fail;
	d.cull_back = false;
	if (vk->has.fill_mode_non_solid) {
		d.wireframe = true;
		if ((ret = relief_vk_tess_pipeline_create(vk, &d, &t->draw_wire)) < 0)
			goto fail;
	}
	*out = t;
	return 0;
fail:
	relief_terrain_destroy(t);
	return ret;
}

void relief_terrain_destroy(struct relief_terrain *t)
{
	if (!t)
		return;
	VkDevice dev = t->vk->device;
	VkPipeline pipes[7] = { t->select, t->commands, t->borders, t->factors, t->draw_fill, t->draw_cull, t->draw_wire };
	for (int i = 0; i < 7; i++)
		if (pipes[i])
			vkDestroyPipeline(dev, pipes[i], NULL);
	VkPipelineLayout layouts[4] = { t->select_layout, t->commands_layout, t->factors_layout, t->draw_layout };
	for (int i = 0; i < 4; i++)
		if (layouts[i])
			vkDestroyPipelineLayout(dev, layouts[i], NULL);
	if (t->set_layout)
		vkDestroyDescriptorSetLayout(dev, t->set_layout, NULL);
	relief_vk_buffer_finish(t->vk, &t->info);
	free(t);
}

int relief_terrain_view_create(struct relief_terrain *t, struct relief_terrain_view **out)
{
	struct relief_vk *vk = t->vk;
	struct relief_terrain_view *v = calloc(1, sizeof(*v));
	if (!v)
		return -ENOMEM;
	v->t = t;
	const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
	const VkBufferUsageFlags indirect = storage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
	const VkBufferUsageFlags read = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
	const struct relief_vk_buffer_spec local[] = {
		{ &v->split[0], 4 * t->count, storage },
		{ &v->split[1], 4 * t->count, storage },
		{ &v->instances, sizeof(struct instance) * t->max_patches, storage | read },
		{ &v->cmds, 16 * (VkDeviceSize)(t->max_draws ? t->max_draws : 1), indirect },
		{ &v->counters, sizeof(struct counters), indirect | read },
		{ &v->wants, sizeof(struct want) * WANT_CAP, storage | read },
		{ &v->drawn, 4 * t->count, storage },
		{ &v->factors, 16 * (VkDeviceSize)t->max_quads + 16, storage },
		{ &v->seals, 16 * (VkDeviceSize)t->max_quads + 16, storage },
		{ &v->borders, 8 * (VkDeviceSize)t->max_patches * (4 * t->blocks + 4), storage },
		{ &v->curtains, 16 * (VkDeviceSize)t->max_patches + 4, storage },
		{ &v->camera, sizeof(struct draw_camera), storage },
	};
	const struct relief_vk_buffer_spec readback[] = {
		{ &v->read_counters, sizeof(struct counters), VK_BUFFER_USAGE_TRANSFER_DST_BIT },
		{ &v->read_wants, sizeof(struct want) * WANT_CAP, VK_BUFFER_USAGE_TRANSFER_DST_BIT },
		{ &v->read_instances, sizeof(struct instance) * t->max_patches, VK_BUFFER_USAGE_TRANSFER_DST_BIT },
	};
	int ret;
	if ((ret = relief_vk_buffer_group_init(vk, &v->local, local, sizeof(local) / sizeof(local[0]),
	                                       RELIEF_VK_MEMORY_DEVICE)) < 0 ||
	    (ret = relief_vk_buffer_group_init(vk, &v->readback, readback, sizeof(readback) / sizeof(readback[0]),
	                                       RELIEF_VK_MEMORY_READBACK)) < 0)
		goto fail;
	VkDescriptorPoolSize sizes[2] = {
		{ VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * STORAGE_BUFFERS },
		{ VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2 * 2 },
	};
	VkDescriptorPoolCreateInfo pi = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
		.maxSets = 2,
		.poolSizeCount = 2,
		.pPoolSizes = sizes,
	};
	if ((ret = relief_vk_check(vk, vkCreateDescriptorPool(vk->device, &pi, NULL, &v->pool), "vkCreateDescriptorPool")) < 0)
		goto fail;
	VkDescriptorSetLayout layouts[2] = { t->set_layout, t->set_layout };
	VkDescriptorSetAllocateInfo ai = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
		.descriptorPool = v->pool,
		.descriptorSetCount = 2,
		.pSetLayouts = layouts,
	};
	if ((ret = relief_vk_check(vk, vkAllocateDescriptorSets(vk->device, &ai, v->set), "vkAllocateDescriptorSets")) < 0)
		goto fail;
	const struct relief_patch_pool *pool = relief_patch_cache_pool(t->cache);
	for (int s = 0; s < 2; s++) {
		VkBuffer bufs[BINDINGS] = { t->info.buffer, pool->layer_table, v->split[s].buffer, v->split[s ^ 1].buffer,
		                            v->instances.buffer, v->counters.buffer, v->wants.buffer, pool->use_table,
		                            v->cmds.buffer, VK_NULL_HANDLE, VK_NULL_HANDLE, pool->block_errors,
		                            v->drawn.buffer, v->factors.buffer, v->curtains.buffer, v->camera.buffer,
		                            v->seals.buffer, v->borders.buffer, pool->use_dist };
		VkDescriptorBufferInfo bi[BINDINGS];
		VkDescriptorImageInfo ii[2] = {
			{ VK_NULL_HANDLE, pool->heights, VK_IMAGE_LAYOUT_GENERAL },
			{ VK_NULL_HANDLE, pool->normals, VK_IMAGE_LAYOUT_GENERAL },
		};
		VkWriteDescriptorSet w[BINDINGS];
		for (uint32_t i = 0; i < BINDINGS; i++) {
			bi[i] = (VkDescriptorBufferInfo){ bufs[i], 0, VK_WHOLE_SIZE };
			w[i] = (VkWriteDescriptorSet){
				.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
				.dstSet = v->set[s],
				.dstBinding = i,
				.descriptorCount = 1,
				.descriptorType = binding_type(i),
				.pBufferInfo = binding_type(i) == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE ? NULL : &bi[i],
				.pImageInfo = i == 9 ? &ii[0] : i == 10 ? &ii[1] : NULL,
			};
		}
		vkUpdateDescriptorSets(vk->device, BINDINGS, w, 0, NULL);
	}
	VkFenceCreateInfo fi = { .sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO };
	if ((vk->has.pipeline_statistics &&
	     (ret = relief_vk_query_pool_create(vk, VK_QUERY_PIPELINE_STATISTIC_CLIPPING_INVOCATIONS_BIT, 1,
	                                        &v->stats_pool)) < 0) ||
	    ((ret = relief_vk_timer_init(vk, &v->timer, 4)) < 0 && ret != -ENOTSUP) ||
	    (ret = relief_vk_check(vk, vkCreateFence(vk->device, &fi, NULL, &v->fence), "vkCreateFence")) < 0)
		goto fail;
	/* Hysteresis starts with nothing split. */
	VkCommandBuffer cmd;
	if ((ret = relief_vk_cmd_begin(vk, &cmd)) < 0)
		goto fail;
	vkCmdFillBuffer(cmd, v->split[0].buffer, 0, VK_WHOLE_SIZE, 0);
	vkCmdFillBuffer(cmd, v->split[1].buffer, 0, VK_WHOLE_SIZE, 0);
	if ((ret = relief_vk_cmd_submit_wait(vk, cmd)) < 0)
		goto fail;
	*out = v;
	return 0;
fail:
	relief_terrain_view_destroy(v);
	return ret;
}

void relief_terrain_view_destroy(struct relief_terrain_view *v)
{
	if (!v)
		return;
	struct relief_vk *vk = v->t->vk;
	if (v->pending)
		relief_terrain_view_wait(v->t, v, NULL);
	if (v->fence)
		vkDestroyFence(vk->device, v->fence, NULL);
	if (v->stats_pool)
		vkDestroyQueryPool(vk->device, v->stats_pool, NULL);
	relief_vk_timer_finish(vk, &v->timer);
	if (v->pool)
		vkDestroyDescriptorPool(vk->device, v->pool, NULL);
	relief_vk_buffer_finish(vk, &v->split[0]);
	relief_vk_buffer_finish(vk, &v->split[1]);
	relief_vk_buffer_finish(vk, &v->instances);
	relief_vk_buffer_finish(vk, &v->drawn);
	relief_vk_buffer_finish(vk, &v->factors);
	relief_vk_buffer_finish(vk, &v->seals);
	relief_vk_buffer_finish(vk, &v->borders);
	relief_vk_buffer_finish(vk, &v->curtains);
	relief_vk_buffer_finish(vk, &v->camera);
	relief_vk_buffer_finish(vk, &v->cmds);
	relief_vk_buffer_finish(vk, &v->counters);
	relief_vk_buffer_finish(vk, &v->wants);
	relief_vk_buffer_finish(vk, &v->read_counters);
	relief_vk_buffer_finish(vk, &v->read_wants);
	relief_vk_buffer_finish(vk, &v->read_instances);
	relief_vk_buffer_group_finish(vk, &v->local);
	relief_vk_buffer_group_finish(vk, &v->readback);
	free(v);
}

static void barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags sa, VkPipelineStageFlags dst,
                    VkAccessFlags da)
{
	VkMemoryBarrier m = { VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL, sa, da };
	vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &m, 0, NULL, 0, NULL);
}

static int want_cmp(const void *a, const void *b)
{
	uint32_t x = ((const struct want *)a)->id, y = ((const struct want *)b)->id;
	return x < y ? -1 : x > y;
}

/* Records the frame's draw records with `pipe`, as many as the count at `count_at` in the
 * view's counters (all of them where vkCmdDrawIndirectCount is missing: unused records
 * hold zero instances). */
static void draw_records(struct relief_terrain *t, struct relief_terrain_view *v, VkCommandBuffer cmd, VkPipeline pipe,
                         const struct draw_push *dp, VkDeviceSize count_at)
{
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
	vkCmdPushConstants(cmd, t->draw_layout, VK_SHADER_STAGE_ALL_GRAPHICS, 0, sizeof(*dp), dp);
	if (t->vk->has.draw_indirect_count)
		vkCmdDrawIndirectCount(cmd, v->cmds.buffer, 0, v->counters.buffer, count_at, t->max_draws, 16);
	else
		vkCmdDrawIndirect(cmd, v->cmds.buffer, 0, t->max_draws, 16);
}

int relief_terrain_draw_submit(struct relief_terrain *t, struct relief_terrain_view *v, const struct relief_view *view,
                               struct relief_vk_target *target, uint64_t frame, const struct relief_draw_options *opts)
{
	if (v->pending)
		return -EBUSY;
	const struct relief_draw_options defaults = { .fine = RELIEF_FINE_ERRORS };
	if (!opts)
		opts = &defaults;
	const bool wire = opts->wire;
	const char *why;
	/* The level of detail is chosen for lod (selection, block factors, seals), the picture
	 * drawn from view; both give positions relative to lod's camera. */
	const struct relief_view *lod = opts->lod_view ? opts->lod_view : view;
	if (relief_view_check(view, &why) < 0 || relief_view_check(lod, &why) < 0 || lod->width != view->width ||
	    lod->height != view->height)
		return -EINVAL;
	struct relief_vk *vk = t->vk;
	const struct relief_file *f = t->file;
	/* Everything hangs from the root: make sure it is on its way. */
	if (relief_patch_cache_state(t->cache, 0) == RELIEF_PATCH_ABSENT)
		relief_patch_cache_request(t->cache, 0, -1.0f);
	struct relief_view_origin o;
	relief_view_origin(f, lod, &o);
	struct select_push sp = {
		.cell = { (int32_t)o.cell_x, (int32_t)o.cell_y },
		.frac = { (float)o.frac_x, (float)o.frac_y },
		.spacing = { (float)f->hdr.spacing_x, (float)f->hdr.spacing_y },
		.cam_z = (float)o.z,
		.kappa = (float)relief_view_kappa(lod),
		/* relief's own method leaves part of tau to the tessellator (lod.h); the baselines'
		 * selections use the whole value they are given. */
		.tau = (float)((opts->select_tau > 0 ? opts->select_tau : lod->tau) *
		               (opts->fine == RELIEF_FINE_ERRORS ? RELIEF_LOD_COARSE_SHARE : 1.0)),
		.frame = (uint32_t)frame,
		.count = t->count,
		.levels = f->hdr.levels,
		.P = f->hdr.patch_size,
		.want_cap = WANT_CAP,
		.delta_finest = (float)f->hdr.tolerance,
		.ratio = f->hdr.ratio,
	};
	relief_view_matrix(lod, sp.vp);
	struct draw_camera camera;
	relief_view_matrix_from(view, lod->eye, camera.vp);
	camera.eye[0] = (float)(view->eye.x - lod->eye.x);
	camera.eye[1] = (float)(view->eye.y - lod->eye.y);
	camera.eye[2] = (float)view->eye.z;
	camera.eye[3] = 0.0f;
	struct draw_push dp = {
		.viewport = { (float)lod->width, (float)lod->height },
		.tau = (float)lod->tau,
		.cam_z = (float)o.z,
		.P = f->hdr.patch_size,
		.blocks = t->blocks,
		.per_patch = t->per_patch,
		.sun = { 0.45f, 0.3f, 0.84f, 0.0f },
		.hrange = { (float)f->hdr.height_min, (float)f->hdr.height_max },
		.target_px = opts->target_px > 0 ? opts->target_px : 1.0f,
		.ratio = f->hdr.ratio,
	};
	memcpy(dp.vp, sp.vp, sizeof(dp.vp));
	/* Back faces are hidden wherever the drawing camera is above the surface drawn under it:
	 * along each ray the first surface met is then an upper side; inside the terrain the
	 * underside stays drawn. The CPU's bound (relief_surface_height_bound(), every level's
	 * blocks there, with a margin for the rounding of drawn heights) is conservative;
	 * lod_commands.comp decides from the blocks actually drawn around the eye and splits
	 * the draw count between the two pipelines, which needs vkCmdDrawIndirectCount. */
	const bool cpu_cull = !opts->no_face_cull &&
	                      view->eye.z > relief_surface_height_bound(f, view->eye.x, view->eye.y) + FACE_CULL_MARGIN;
	const bool gpu_cull = !opts->no_face_cull && vk->has.draw_indirect_count;
	struct commands_push cp = {
		t->per_patch, t->blocks, t->per_draw, t->max_draws, cpu_cull, (float)FACE_CULL_MARGIN
	};

	VkCommandBuffer cmd;
	int ret = relief_vk_cmd_begin(vk, &cmd);
	if (ret < 0)
		return ret;
	if (v->timer.pool) {
		relief_vk_timer_reset(&v->timer, cmd);
		relief_vk_timer_write(&v->timer, cmd, 0, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT);
	}
	if (v->stats_pool)
		vkCmdResetQueryPool(cmd, v->stats_pool, 0, 1);
	/* The work submitted before (this view's last frame, other views' frames, decodes) is
	 * done with what this frame writes, and its writes are visible. */
	barrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
	        VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	vkCmdUpdateBuffer(cmd, v->camera.buffer, 0, sizeof(camera), &camera);
	vkCmdFillBuffer(cmd, v->counters.buffer, 0, VK_WHOLE_SIZE, 0);
	vkCmdFillBuffer(cmd, v->cmds.buffer, 0, VK_WHOLE_SIZE, 0);
	vkCmdFillBuffer(cmd, v->drawn.buffer, 0, VK_WHOLE_SIZE, 0);
	/* The first view drawn in a frame clears the frame's half of the use distances; the
	 * selection (its half: frame & 1) takes the least over the frame's views. */
	bool reset;
	uint32_t half = relief_patch_cache_use_dist_half(t->cache, frame, &reset);
	if (reset)
		vkCmdFillBuffer(cmd, relief_patch_cache_pool(t->cache)->use_dist, (VkDeviceSize)half * 4 * t->count,
		                (VkDeviceSize)4 * t->count, UINT32_MAX);
	/* The camera is read by compute and by the evaluation shader. */
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
	        VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TESSELLATION_EVALUATION_SHADER_BIT,
	        VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	VkDescriptorSet set = v->set[v->parity];
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->select_layout, 0, 1, &set, 0, NULL);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->select);
	vkCmdPushConstants(cmd, t->select_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(sp), &sp);
	vkCmdDispatch(cmd, (t->count + 63) / 64, 1, 1);
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	/* Different push ranges make the layouts incompatible for the set: bind it again. */
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->commands_layout, 0, 1, &set, 0, NULL);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->commands);
	vkCmdPushConstants(cmd, t->commands_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(cp), &cp);
	vkCmdDispatch(cmd, 1, 1, 1);
	/* Tessellation factors of every drawn quad, as many groups as the drawn count needs. */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	        VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_SHADER_READ_BIT);
	if (v->timer.pool)
		relief_vk_timer_write(&v->timer, cmd, 1, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
	const uint32_t mode = ((uint32_t)opts->fine << 1) | (opts->no_skirts ? MODE_NO_SKIRTS : 0u) |
	                      (opts->no_block_cull ? MODE_NO_BLOCK_CULL : 0u) | (view->morph ? MODE_MORPH : 0u);
	dp.mode = mode;
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->factors_layout, 0, 1, &set, 0, NULL);
	vkCmdPushConstants(cmd, t->factors_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(dp), &dp);
	/* The border edges and corners first (lod_borders.comp), then every quad. */
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->borders);
	vkCmdDispatchIndirect(cmd, v->counters.buffer, offsetof(struct counters, border_groups));
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_SHADER_READ_BIT);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->factors);
	vkCmdDispatchIndirect(cmd, v->counters.buffer, offsetof(struct counters, factor_groups));
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	        VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_VERTEX_SHADER_BIT |
	                VK_PIPELINE_STAGE_TESSELLATION_CONTROL_SHADER_BIT | VK_PIPELINE_STAGE_TESSELLATION_EVALUATION_SHADER_BIT,
	        VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_SHADER_READ_BIT);
	if (v->timer.pool)
		relief_vk_timer_write(&v->timer, cmd, 2, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);

	const float sky[4] = { 0.62f, 0.74f, 0.88f, 1.0f };
	relief_vk_target_begin(target, cmd, sky, 0.0f); /* reversed Z */
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, t->draw_layout, 0, 1, &set, 0, NULL);
	if (v->stats_pool)
		vkCmdBeginQuery(cmd, v->stats_pool, 0, 0);
	for (int pass = 0; pass < (wire && t->draw_wire ? 2 : 1); pass++) {
		dp.mode = mode | (uint32_t)pass;
		if (pass == 1)
			draw_records(t, v, cmd, t->draw_wire, &dp, offsetof(struct counters, draws));
		else if (gpu_cull) { /* one of the two counts is 0 */
			draw_records(t, v, cmd, t->draw_cull, &dp, offsetof(struct counters, draw_split));
			draw_records(t, v, cmd, t->draw_fill, &dp, offsetof(struct counters, draw_split) + 4);
		} else
			draw_records(t, v, cmd, cpu_cull ? t->draw_cull : t->draw_fill, &dp, offsetof(struct counters, draws));
		if (v->stats_pool && pass == 0)
			vkCmdEndQuery(cmd, v->stats_pool, 0);
	}
	relief_vk_target_end(target, cmd);
	/* The counters and requests to where the CPU reads them. */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
	        VK_ACCESS_TRANSFER_READ_BIT);
	vkCmdCopyBuffer(cmd, v->counters.buffer, v->read_counters.buffer, 1,
	                &(VkBufferCopy){ 0, 0, sizeof(struct counters) });
	vkCmdCopyBuffer(cmd, v->wants.buffer, v->read_wants.buffer, 1,
	                &(VkBufferCopy){ 0, 0, sizeof(struct want) * WANT_CAP });
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
	        VK_ACCESS_HOST_READ_BIT);
	if (v->timer.pool)
		relief_vk_timer_write(&v->timer, cmd, 3, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
	if ((ret = relief_vk_cmd_submit(vk, cmd, v->fence)) < 0)
		return ret;
	v->pending = cmd;
	v->gpu_cull = gpu_cull;
	v->cpu_cull = cpu_cull;
	v->parity ^= 1;
	relief_patch_cache_hold(t->cache);
	return 0;
}

int relief_terrain_view_wait(struct relief_terrain *t, struct relief_terrain_view *v, struct relief_terrain_stats *st)
{
	if (!v->pending)
		return -EINVAL;
	struct relief_vk *vk = t->vk;
	const struct relief_file *f = t->file;
	int ret = relief_vk_check(vk, vkWaitForFences(vk->device, 1, &v->fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
	if (ret == 0)
		ret = relief_vk_check(vk, vkResetFences(vk->device, 1, &v->fence), "vkResetFences");
	vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &v->pending);
	v->pending = VK_NULL_HANDLE;
	relief_patch_cache_release(t->cache);
	if (ret < 0)
		return ret;
	const bool gpu_cull = v->gpu_cull, cpu_cull = v->cpu_cull;
	const struct counters *c = v->read_counters.map;
	struct relief_terrain_stats s = {
		.patches = c->drawn, .draws = c->draws, .requests = c->wants,
		.face_culled = gpu_cull ? c->face_culled != 0 : cpu_cull,
		.cull_height = gpu_cull && c->found ? c->near_high : NAN
	};
	if (relief_patch_cache_state(t->cache, 0) != RELIEF_PATCH_RESIDENT)
		s.requests++; /* the root itself is still missing */
	v->last_drawn = c->drawn < t->max_patches ? c->drawn : t->max_patches;
	if (v->stats_pool)
		vkGetQueryPoolResults(vk->device, v->stats_pool, 0, 1, sizeof(uint64_t), &s.triangles, sizeof(uint64_t),
		                      VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
	if (v->timer.pool && (relief_vk_timer_ns(vk, &v->timer, 0, 1, &s.select_ns) < 0 ||
	                      relief_vk_timer_ns(vk, &v->timer, 0, 2, &s.lod_ns) < 0 ||
	                      relief_vk_timer_ns(vk, &v->timer, 0, 3, &s.gpu_ns) < 0))
		s.select_ns = s.lod_ns = s.gpu_ns = 0;
	/* Requests, made in id order: coarser patches first (lower ids are coarser), so that a
	 * parent is on its way before its child is asked for and a whole chain is accepted in
	 * one frame. The cache serves the nearest first (its ancestors ahead of it). */
	static_assert(WANT_CAP * sizeof(struct want) <= 16384, "the copy below lives on the stack");
	struct want want[WANT_CAP];
	uint32_t n = c->wants < WANT_CAP ? c->wants : WANT_CAP;
	memcpy(want, v->read_wants.map, n * sizeof(*want)); /* sorted in place below */
	qsort(want, n, sizeof(*want), want_cmp);
	for (uint32_t i = 0; i < n; i++)
		if (want[i].id < f->hdr.patch_count)
			relief_patch_cache_request(t->cache, want[i].id, want[i].distance);
	if (st)
		*st = s;
	return 0;
}

int relief_terrain_draw(struct relief_terrain *t, struct relief_terrain_view *v, const struct relief_view *view,
                        struct relief_vk_target *target, uint64_t frame, const struct relief_draw_options *opts,
                        struct relief_terrain_stats *st)
{
	int ret = relief_terrain_draw_submit(t, v, view, target, frame, opts);
	return ret < 0 ? ret : relief_terrain_view_wait(t, v, st);
}

int relief_terrain_view_drawn(struct relief_terrain_view *v, uint32_t *ids, uint32_t cap)
{
	struct relief_vk *vk = v->t->vk;
	if (v->pending)
		return -EBUSY;
	uint32_t n = v->last_drawn < cap ? v->last_drawn : cap;
	if (n == 0)
		return 0;
	/* The instances stay in device memory: copied out on demand, not every frame. */
	VkDeviceSize bytes = sizeof(struct instance) * n;
	VkCommandBuffer cmd;
	int ret = relief_vk_cmd_begin(vk, &cmd);
	if (ret < 0)
		return ret;
	/* The last frame's selection wrote them (that frame was waited for). */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
	        VK_ACCESS_TRANSFER_READ_BIT);
	vkCmdCopyBuffer(cmd, v->instances.buffer, v->read_instances.buffer, 1, &(VkBufferCopy){ 0, 0, bytes });
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
	        VK_ACCESS_HOST_READ_BIT);
	if ((ret = relief_vk_cmd_submit_wait(vk, cmd)) < 0)
		return ret;
	const struct instance *in = v->read_instances.map;
	for (uint32_t i = 0; i < n; i++)
		ids[i] = in[i].id;
	return (int)n;
}

uint32_t relief_terrain_view_wants(const struct relief_terrain_view *v, uint32_t *ids, uint32_t cap)
{
	if (v->pending)
		return 0;
	const struct counters *c = v->read_counters.map;
	const struct want *w = v->read_wants.map;
	uint32_t n = c->wants < WANT_CAP ? c->wants : WANT_CAP;
	n = n < cap ? n : cap;
	for (uint32_t i = 0; i < n; i++)
		ids[i] = w[i].id;
	return n;
}
