/* The terrain renderer (see terrain.h): the terrain, the device's LOD program (descriptor
 * set layout, pipeline layouts and compute pipelines, shared by every terrain on it) and
 * the terrain's draw pipelines. One descriptor set layout serves every pipeline
 * (selection, draw records, borders, factors, drawing); each view has two sets that swap
 * its hysteresis buffers every frame (terrain_view.c); a frame is recorded in
 * terrain_frame.c. */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline.h"
#include "terrain_internal.h"

#include "lod_commands.comp.spv.h"
#include "lod_borders.comp.spv.h"
#include "lod_factors.comp.spv.h"
#include "lod_force.comp.spv.h"
#include "lod_select.comp.spv.h"
#include "terrain.frag.spv.h"
#include "terrain.tesc.spv.h"
#include "terrain.tese.spv.h"
#include "terrain_mesh.geom.spv.h"
#include "terrain_mesh.tese.spv.h"
#include "terrain.vert.spv.h"

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
 * desktop GPUs and lavapipe take thousands) and UNIFORM_TEXEL_BUFFERS uniform texel buffers,
 * which count as sampled images (within the minimum of 16 per stage, checked all the same),
 * and a frame may issue max_draws draw records. -ENOTSUP, naming the limit, where the
 * device has less. */
static int check_limits(struct relief_vk *vk, uint32_t max_draws)
{
	const VkPhysicalDeviceLimits *l = &vk->props.limits;
	const struct { const char *name; uint32_t have, need; } req[] = {
		{ "maxPerStageDescriptorStorageBuffers", l->maxPerStageDescriptorStorageBuffers, STORAGE_BUFFERS },
		{ "maxDescriptorSetStorageBuffers", l->maxDescriptorSetStorageBuffers, STORAGE_BUFFERS },
		{ "maxPerStageDescriptorSampledImages", l->maxPerStageDescriptorSampledImages, UNIFORM_TEXEL_BUFFERS },
		{ "maxDescriptorSetSampledImages", l->maxDescriptorSetSampledImages, UNIFORM_TEXEL_BUFFERS },
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

static void program_destroy(struct relief_vk *vk, void *obj)
{
	struct terrain_program *p = obj;
	VkDevice dev = vk->device;
	VkPipeline pipes[3 + 2 * 4] = { p->select, p->force, p->commands };
	for (int k = 0; k < 4; k++) {
		pipes[3 + 2 * k] = p->lod[k].borders;
		pipes[4 + 2 * k] = p->lod[k].factors;
	}
	for (size_t i = 0; i < sizeof(pipes) / sizeof(pipes[0]); i++)
		if (pipes[i])
			vkDestroyPipeline(dev, pipes[i], NULL);
	VkPipelineLayout layouts[4] = { p->select_layout, p->commands_layout, p->factors_layout, p->draw_layout };
	for (int i = 0; i < 4; i++)
		if (layouts[i])
			vkDestroyPipelineLayout(dev, layouts[i], NULL);
	if (p->set_layout)
		vkDestroyDescriptorSetLayout(dev, p->set_layout, NULL);
	if (p->locked)
		pthread_mutex_destroy(&p->lock);
}

/* One descriptor set layout for every pass and stage, a pipeline layout per push-constant
 * block, the selection's and the lists' pipelines; the factor and border passes' come per
 * kind of frame when first needed. */
static int program_create(struct relief_vk *vk, void *obj)
{
	struct terrain_program *p = obj;
	int ret = pthread_mutex_init(&p->lock, NULL);
	if (ret != 0)
		return -ret;
	p->locked = true;
	VkDescriptorSetLayoutBinding b[BINDINGS];
	for (uint32_t i = 0; i < BINDINGS; i++)
		b[i] = (VkDescriptorSetLayoutBinding){ i, binding_type(i), 1, VK_SHADER_STAGE_ALL, NULL };
	VkDescriptorSetLayoutCreateInfo li = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
		.bindingCount = BINDINGS,
		.pBindings = b,
	};
	if ((ret = relief_vk_check(vk, vkCreateDescriptorSetLayout(vk->device, &li, NULL, &p->set_layout),
	                           "vkCreateDescriptorSetLayout")) < 0 ||
	    (ret = layout_with_push(vk, p->set_layout, VK_SHADER_STAGE_COMPUTE_BIT, sizeof(struct select_push),
	                            &p->select_layout)) < 0 ||
	    (ret = layout_with_push(vk, p->set_layout, VK_SHADER_STAGE_COMPUTE_BIT, sizeof(struct commands_push),
	                            &p->commands_layout)) < 0 ||
	    (ret = layout_with_push(vk, p->set_layout, VK_SHADER_STAGE_COMPUTE_BIT, sizeof(struct draw_push),
	                            &p->factors_layout)) < 0 ||
	    (ret = layout_with_push(vk, p->set_layout, VK_SHADER_STAGE_ALL_GRAPHICS, sizeof(struct draw_push),
	                            &p->draw_layout)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, p->select_layout, RELIEF_SPIRV(lod_select_comp_spv), &p->select)) < 0 ||
	    (ret = relief_vk_compute_pipeline_create(vk, p->select_layout, RELIEF_SPIRV(lod_force_comp_spv), &p->force)) < 0)
		return ret;
	return relief_vk_compute_pipeline_create(vk, p->commands_layout, RELIEF_SPIRV(lod_commands_comp_spv), &p->commands);
}

static const struct relief_vk_shared_kind terrain_program_kind = {
	"terrain: the LOD passes' pipelines", sizeof(struct terrain_program), program_create, program_destroy,
};

/* The terrain's draw pipeline: solid, both faces kept, no capture. */
static struct relief_vk_tess_pipeline_desc draw_pipeline_desc(const struct relief_terrain *t)
{
	return (struct relief_vk_tess_pipeline_desc){
		.vert = RELIEF_SPIRV(terrain_vert_spv),
		.tesc = RELIEF_SPIRV(terrain_tesc_spv),
		.tese = RELIEF_SPIRV(terrain_tese_spv),
		.frag = RELIEF_SPIRV(terrain_frag_spv),
		.control_points = 4,
		.layout = t->prog->draw_layout,
		.pass = t->pass,
		.reversed_z = true,
	};
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
	t->count = f->hdr.index_records;
	t->blocks = f->layout.blocks;
	t->per_patch = t->blocks * t->blocks;
	/* A quad's factors are at most its block's cells: (16 + 1)^2 tessellated vertices. */
	t->per_draw = relief_vk_quads_per_draw(RELIEF_BLOCK_CELLS);
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
	for (uint32_t e = 0; e < t->count; e++) {
		uint32_t id = relief_index_patch(&f->hdr, e);
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		bool empty = r.flags & RELIEF_PATCH_EMPTY;
		info[e] = (struct patch_info){ r.height_min, r.height_max, relief_patch_select_error(f, id, &r),
			                       empty ? -1.0f : skirt_depth(f, id, &r) };
	}
	if ((ret = relief_vk_buffer_init(vk, &t->info, sizeof(*info) * t->count,
	                                 VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                 RELIEF_VK_MEMORY_DEVICE)) == 0)
		ret = relief_vk_buffer_upload(vk, &t->info, info, sizeof(*info) * t->count);
	free(info);
	if (ret < 0)
		goto fail;
	/* The index windows (shaders/patch_entry.glsl); levels beyond the tree have none. */
	uint32_t windows[RELIEF_MAX_LEVELS][4];
	for (uint32_t l = 0; l < RELIEF_MAX_LEVELS; l++) {
		bool in = l < f->hdr.levels;
		memcpy(windows[l], (uint32_t[4]){ in ? f->hdr.index_cols[l] : 0, in ? f->hdr.index_rows[l] : 0,
		                                  in ? f->hdr.index_first[l] : t->count, 0 }, sizeof(windows[l]));
	}
	if ((ret = relief_vk_buffer_init(vk, &t->windows, sizeof(windows),
	                                 VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                 RELIEF_VK_MEMORY_DEVICE)) < 0 ||
	    (ret = relief_vk_buffer_upload(vk, &t->windows, windows, sizeof(windows))) < 0)
		goto fail;
	/* Both read as texels (shaders/patch_entry.glsl says why). */
	if ((ret = relief_vk_texel_view_create(vk, &t->info, VK_FORMAT_R32G32B32A32_SFLOAT, 4,
	                                       VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT, &vk->log,
	                                       "terrain: the patch info (RGBA32_SFLOAT, binding 0)", &t->info_view)) < 0 ||
	    (ret = relief_vk_texel_view_create(vk, &t->windows, VK_FORMAT_R32G32B32A32_UINT, 4,
	                                       VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT, &vk->log,
	                                       "terrain: the index windows (RGBA32_UINT, binding 22)", &t->windows_view)) < 0)
		goto fail;

	void *prog;
	if ((ret = relief_vk_shared(vk, &terrain_program_kind, &prog)) < 0)
		goto fail;
	t->prog = prog;
	t->pass = target->pass;
	const struct lod_pipelines *lp;
	if ((ret = terrain_lod_pipelines_create(t, RELIEF_FINE_ERRORS, false, &lp)) < 0 ||
	    (ret = terrain_draw_pipelines_create(t, false, false, false)) < 0)
		goto fail;
	*out = t;
	return 0;
fail:
	relief_terrain_destroy(t);
	return ret;
}

/* The kind of frame a pipeline is made for: the specialization constants of
 * shaders/terrain_draw.glsl, MORPH_CODE (0), FINE_LOD (1) and SEAL_CODE (2). */
struct kind_spec {
	VkBool32 morph;
	uint32_t fine;
	VkBool32 seal;
};

static const VkSpecializationMapEntry kind_spec_entries[3] = {
	{ 0, offsetof(struct kind_spec, morph), sizeof(VkBool32) },
	{ 1, offsetof(struct kind_spec, fine), sizeof(uint32_t) },
	{ 2, offsetof(struct kind_spec, seal), sizeof(VkBool32) },
};

static VkSpecializationInfo kind_spec_info(const struct kind_spec *k)
{
	return (VkSpecializationInfo){ 3, kind_spec_entries, sizeof(*k), k };
}

int terrain_draw_pipelines_create(struct relief_terrain *t, bool morph, bool wire, bool mesh)
{
	struct draw_pipelines *p = &t->draw[morph];
	/* The draw stages read MORPH_CODE and SEAL_CODE only. */
	const struct kind_spec kind = { morph, RELIEF_FINE_ERRORS, true }, open = { morph, RELIEF_FINE_ERRORS, false };
	const VkSpecializationInfo spec = kind_spec_info(&kind), open_spec = kind_spec_info(&open);
	struct relief_vk_tess_pipeline_desc d = draw_pipeline_desc(t);
	/* Each slot with what it draws: solid, solid culled, both without the seal code,
	 * wireframe; the capture's four, the same kinds as the solid ones (so that a mesh check
	 * sees the quads drawn without the seal code as drawn). */
	struct {
		VkPipeline *pipe;
		bool want, cull_back, wireframe, capture, open;
	} slots[] = {
		{ &p->fill, true, false, false, false, false },
		{ &p->cull, true, true, false, false, false },
		{ &p->fill_open, true, false, false, false, true },
		{ &p->cull_open, true, true, false, false, true },
		{ &p->wire, wire && t->vk->has.fill_mode_non_solid, false, true, false, false },
		{ &p->mesh_fill, mesh, false, false, true, false },
		{ &p->mesh_cull, mesh, true, false, true, false },
		{ &p->mesh_fill_open, mesh, false, false, true, true },
		{ &p->mesh_cull_open, mesh, true, false, true, true },
	};
	for (size_t i = 0; i < sizeof(slots) / sizeof(slots[0]); i++) {
		if (!slots[i].want || *slots[i].pipe)
			continue;
		d.cull_back = slots[i].cull_back;
		d.wireframe = slots[i].wireframe;
		d.tese_spec = slots[i].open ? &open_spec : &spec;
		d.tese = slots[i].capture ? RELIEF_SPIRV(terrain_mesh_tese_spv) : RELIEF_SPIRV(terrain_tese_spv);
		d.geom = slots[i].capture ? RELIEF_SPIRV(terrain_mesh_geom_spv) : (struct relief_vk_spirv){ 0 };
		int ret = relief_vk_tess_pipeline_create(t->vk, &d, slots[i].pipe);
		if (ret < 0)
			return ret;
	}
	return 0;
}

int terrain_lod_pipelines_create(struct relief_terrain *t, enum relief_fine_lod fine, bool morph,
                                 const struct lod_pipelines **out)
{
	if ((unsigned)fine > RELIEF_FINE_DISTANCE)
		return -EINVAL;
	morph = morph && fine == RELIEF_FINE_ERRORS; /* the baselines do not geomorph */
	struct terrain_program *prog = t->prog;
	struct lod_pipelines *p = &prog->lod[fine == RELIEF_FINE_ERRORS ? (unsigned)morph : 1u + (unsigned)fine];
	*out = p;
	const struct kind_spec kind = { morph, (uint32_t)fine, true };
	const VkSpecializationInfo spec = kind_spec_info(&kind);
	int ret = 0;
	pthread_mutex_lock(&prog->lock);
	if (!p->borders)
		ret = relief_vk_compute_pipeline_create_spec(t->vk, prog->factors_layout, RELIEF_SPIRV(lod_borders_comp_spv),
		                                             &spec, &p->borders);
	if (ret == 0 && !p->factors)
		ret = relief_vk_compute_pipeline_create_spec(t->vk, prog->factors_layout, RELIEF_SPIRV(lod_factors_comp_spv),
		                                             &spec, &p->factors);
	pthread_mutex_unlock(&prog->lock);
	return ret;
}

uint64_t relief_terrain_bytes(const struct relief_terrain *t)
{
	return t->info.size + t->windows.size;
}

void relief_terrain_destroy(struct relief_terrain *t)
{
	if (!t)
		return;
	VkDevice dev = t->vk->device;
	for (int m = 0; m < 2; m++) {
		const struct draw_pipelines *p = &t->draw[m];
		VkPipeline draw[] = { p->fill,  p->cull,      p->fill_open,      p->cull_open,     p->wire,
			              p->mesh_fill, p->mesh_cull, p->mesh_fill_open, p->mesh_cull_open };
		for (size_t i = 0; i < sizeof(draw) / sizeof(draw[0]); i++)
			if (draw[i])
				vkDestroyPipeline(dev, draw[i], NULL);
	}
	if (t->info_view)
		vkDestroyBufferView(dev, t->info_view, NULL);
	if (t->windows_view)
		vkDestroyBufferView(dev, t->windows_view, NULL);
	relief_vk_buffer_finish(t->vk, &t->info);
	relief_vk_buffer_finish(t->vk, &t->windows);
	free(t);
}
