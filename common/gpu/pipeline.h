/* Graphics pipelines for tessellated patch rendering (vertex, control, evaluation, fragment
 * stages; no vertex buffers: shaders derive positions from gl_VertexIndex/InstanceIndex). */
#pragma once

#include "vk.h"

struct relief_vk_spirv {
	const uint32_t *code;
	size_t size; /* bytes */
};
#define RELIEF_SPIRV(array) ((struct relief_vk_spirv){ (array), sizeof(array) })

struct relief_vk_tess_pipeline_desc {
	struct relief_vk_spirv vert, tesc, tese, frag;
	struct relief_vk_spirv geom; /* optional (size 0: none); needs the geometryShader feature */
	uint32_t control_points;
	VkPipelineLayout layout;
	VkRenderPass pass;
	bool wireframe; /* needs vk->has.fill_mode_non_solid */
	bool reversed_z; /* depth test GREATER (nearer is larger) instead of LESS */
	/* Cull back faces: clockwise triangles in the framebuffer (y down), the underside of a
	 * terrain whose evaluation shader emits the quad domain counter-clockwise. */
	bool cull_back;
	/* The evaluation stage's specialization constants (NULL: the shader's defaults). */
	const VkSpecializationInfo *tese_spec;
};

/* The pipeline has dynamic viewport and scissor, depth test LESS with writes, back faces
 * kept unless cull_back (terrain is seen from below when the camera is inside it). */
int relief_vk_tess_pipeline_create(struct relief_vk *vk, const struct relief_vk_tess_pipeline_desc *d,
                                   VkPipeline *out);
/* A compute pipeline from SPIR-V (entry point main); _spec: with specialization constants
 * (spec may be NULL). */
int relief_vk_compute_pipeline_create_spec(struct relief_vk *vk, VkPipelineLayout layout, struct relief_vk_spirv code,
                                           const VkSpecializationInfo *spec, VkPipeline *out);
int relief_vk_compute_pipeline_create(struct relief_vk *vk, VkPipelineLayout layout, struct relief_vk_spirv code,
                                      VkPipeline *out);
/* A query pool: `count` timestamps (statistics == 0) or one pipeline-statistics query
 * counting `statistics`. */
int relief_vk_query_pool_create(struct relief_vk *vk, VkQueryPipelineStatisticFlags statistics, uint32_t count,
                                VkQueryPool *out);
/* A pipeline layout with one push-constant range of `push_size` bytes visible to all
 * graphics stages, and up to one descriptor set layout (may be VK_NULL_HANDLE). */
int relief_vk_pipeline_layout_create(struct relief_vk *vk, uint32_t push_size, VkDescriptorSetLayout set,
                                     VkPipelineLayout *out);

/* Upper bound on tessellated vertices in one draw. lavapipe (Mesa 22.3) corrupts and slows
 * down draws that generate more than 65,536 tessellated vertices (docs/platform.md); the
 * renderers split their draws to stay at or below it on every device. */
#define RELIEF_VK_MAX_TESS_VERTICES_PER_DRAW 65536u
/* How many quad patches of equal tessellation factor `factor` (1..64) fit in one draw. */
uint32_t relief_vk_quads_per_draw(uint32_t factor);
