/* What the terrain renderer's files share (terrain.c: the terrain and its pipelines;
 * terrain_view.c: views, their buffers and what the CPU reads back; terrain_frame.c: a
 * view's frame, submitted and waited for): the std430 twins of the shaders' structs and
 * push blocks, the descriptor bindings, the two objects. Not for other users. */
#pragma once

#include <stdbool.h>
#include <stdint.h>
#include <pthread.h>

#include "terrain.h"

/* Requests one view can make in a frame (id and distance each); the rest follow next frame. */
#define WANT_CAP 1024
struct want {
	uint32_t id;
	float distance; /* metres from the camera to the patch's box */
};
/* A view's timestamp slots: the frame's four, then one after each of the first LOD passes
 * when they are timed (relief_draw_options.pass_timing; struct relief_terrain_view.timer). */
#define FIRST_PASS_SLOT 4u
#define TIMER_SLOTS (FIRST_PASS_SLOT + RELIEF_LOD_PASSES - 2u)
/* Metres a camera must be above relief_surface_height_bound() for back faces to be culled:
 * drawn heights are floats of at most ~10 km, rounded to ~1 mm. */
#define FACE_CULL_MARGIN 0.01

/* Levels 0 .. SELECT_TOP_LEVELS - 1 are visited by the selection's first dispatch, an
 * invocation per patch (lod_select.comp's TOP_LEVELS, the same number). */
#define SELECT_TOP_LEVELS 4u

/* std430 twins of the shaders' push blocks and structs (shaders/terrain_*.glsl). */
struct select_push {
	float vp[16];
	int32_t cell[2];
	float frac[2], spacing[2];
	float cam_z, kappa, tau;
	uint32_t frame;
	uint32_t level; /* lod_select.comp: the level a dispatch visits (set per dispatch);
	                 * lod_force.comp: 1 where the border charges apply (relief's fine LOD,
	                 * strips bounded), else 0 */
	uint32_t levels, P, want_cap;
	float delta_finest;
	uint32_t ratio;
};
_Static_assert(sizeof(struct select_push) == 128, "select push block");

struct commands_push {
	uint32_t per_patch, blocks, per_draw, max_draws;
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
	float hmin, hmax, err, skirt; /* err: the selection's error, relief_patch_select_error() (lod.h) */
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
	/* Back faces (shaders/lod_eye.glsl): culled; a drawn block holds the eye; the highest
	 * block around it (metres once the frame is done; an ordered key during the selection) */
	uint32_t face_culled, found;
	float near_high;
	uint32_t draw_culled; /* the decision the frame draws with: the GPU's, or cpu_cull without a split */
	/* draws: the shown list's draw records of quads without seals. Those records for the
	 * culling pipeline, for the other, the clipped list's, and the quads in the clipped
	 * list; draw_sealed the same for the quads with seals, but its last word the shown
	 * list's records of them; the quads with seals (all lod_commands.comp) */
	uint32_t draw_split[4], draw_sealed[4], sealed_quads;
};
/* The words shaders/terrain_draw.glsl reads as texels: drawn, curtains, draw_culled. */
_Static_assert(offsetof(struct counters, drawn) == 0 && offsetof(struct counters, curtains) == 3 * 4 &&
                       offsetof(struct counters, draw_culled) == 15 * 4,
               "counter words");
/* The per-view camera buffer (binding 15): the drawing view-projection, then the drawing
 * eye relative to the LOD camera (x east, y north) and its absolute height (z), and (w)
 * the clip-space z of a point 0.1 % nearer than the far plane (lod_factors.comp,
 * block_inside(): reversed depth falls towards 0 there, so a margin relative to w would
 * reach far into the frustum). */
struct draw_camera {
	float vp[16];
	float eye[4];
	/* The back-face decision's other inputs (shaders/lod_eye.glsl, eye_decide()): the
	 * margin (FACE_CULL_MARGIN), the CPU's decision (relief_surface_height_bound(): 1 or
	 * 0), for when no drawn block holds the eye, and whether the GPU's decision splits the
	 * draws (vkCmdDrawIndirectCount: 1; else the CPU's is drawn with); 0 */
	float cull[4];
};
_Static_assert(sizeof(struct draw_camera) == 6 * 16, "six RGBA32F texels");

/* draw_push.mode: bit 0 wireframe pass, bit 3 no skirts, bit 4 no block culling, bit 6
 * blocks without data drawn, bit 9 the transition strips left unbounded
 * (relief_view.loose_transitions). The fine LOD and morphing (bits 1-2 and 5 until December
 * 2026) are the pipelines' specialization constants (struct lod_pipelines, draw_pipelines). */
#define MODE_NO_SKIRTS 8u
#define MODE_NO_BLOCK_CULL 16u
#define MODE_KEEP_EMPTY_BLOCKS 64u
/* The vertex shader reads quad indices from the clipped list, not the shown list (bit 8;
 * lod_commands.comp). docs/lod.md, "Back faces". */
#define MODE_CLIPPED_LIST 256u
#define MODE_LOOSE_STRIPS 512u

/* One descriptor set for every stage. Per-patch buffers have one element per entry, a
 * patch's record number in the file's index (relief_index_entry(); shaders/patch_entry.glsl).
 * Bindings are storage buffers unless said otherwise: 0 patch info (RGBA32_SFLOAT uniform
 * texels, t->info_view), 1 layer table (R32_SINT uniform texels, pool.layer_view), 2-3 split
 * state (this frame's input, output), 4 instances, 5 counters, 6 requests, 7 use table,
 * 8 draw records, 9 heights, 10 normals (storage images), 11 the layers' block records
 * (a uniform texel buffer, pool.block_view: patch_gpu.c says why), 12 drawn marks,
 * 13 tessellation factors and morph bytes (uvec4 per quad, lod_factors.comp), 14 curtains
 * (terrain-edge sides of drawn patches), 15 the draw camera (struct draw_camera as
 * RGBA32_SFLOAT uniform texels, v->camera_view; shaders/draw_camera.glsl),
 * 16 seal records (uvec4 per quad, terrain_seal.glsl),
 * 17 border records (uvec2 per drawn patch's border block edge and corner, lod_borders.comp),
 * 18 the cache's use distances (patch_cache.h, pool.use_dist),
 * 19 the quad lists (indices of the quads that draw something: the shown list from the
 * front, the clipped list, those the rasteriser may clip in a frame that culls back faces,
 * from the back; lod_commands.comp), 20 the selection's frontiers (uvec2 per patch, lod_select.comp),
 * 21 its passes (per level a VkDispatchIndirectCommand and the frontier's count),
 * 22 the index windows (per level: entry columns, rows, first entry, 0; RGBA32_UINT uniform
 * texels, t->windows_view),
 * 23 the mesh capture (terrain_mesh.geom; written only once a view enables it, and read
 * only by the capture's pipelines); what the shaders read per lane as uniform texel buffers
 * (relief_vk_texel_view_create() says why) over buffers the compute passes write as the
 * storage buffers named in brackets: 24 the instances (4, RGBA32_UINT), 25 the border
 * records (17, RG32_UINT), 26 the factors (13, RGBA32_UINT), 27 the seal records (16,
 * RGBA32_UINT), 28 the quad lists (19, R32_UINT), 29 the drawn marks (12, R32_UINT), 30 the
 * counters (5, R32_UINT), 31 the curtains (14, R32_UINT). No shader writes 0, 1, 15 or 22:
 * they are texels only. */
#define BINDINGS 32u
#define MESH_BINDING 23u
#define RECORDS_BINDING 11u
#define CAMERA_BINDING 15u
#define INFO_BINDING 0u
#define LAYERS_BINDING 1u
#define WINDOWS_BINDING 22u
#define FIRST_TEXELS_BINDING 24u /* 24-31: the views' texels */
#define VIEW_TEXELS (BINDINGS - FIRST_TEXELS_BINDING)
#define UNIFORM_TEXEL_BUFFERS (5u + VIEW_TEXELS) /* records, camera, info, layers, windows, the views' */
#define STORAGE_BUFFERS (BINDINGS - 2u - UNIFORM_TEXEL_BUFFERS) /* all but the images and texel buffers */

static inline VkDescriptorType binding_type(uint32_t i)
{
	return i == 9 || i == 10 ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE
	       : i == RECORDS_BINDING || i == CAMERA_BINDING || i == INFO_BINDING || i == LAYERS_BINDING ||
	                       i == WINDOWS_BINDING || i >= FIRST_TEXELS_BINDING
	               ? VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER
	               : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
}

/* One kind of frame's factor and border passes (lod_factors.comp, lod_borders.comp), made
 * with its fine LOD and geomorphing as specialization constants (terrain_draw.glsl), so the
 * compiler leaves out the other kinds' code. */
struct lod_pipelines {
	VkPipeline borders, factors;
};

/* The parts of a view's quad lists, in the order of their draw records (lod_commands.comp). */
enum list_part { LIST_SHOWN, LIST_SHOWN_SEALED, LIST_CLIPPED, LIST_CLIPPED_SEALED, LIST_PARTS };

/* One kind of view's draw pipelines. cull: fill with back faces culled, for cameras above
 * the surface; fill_open, cull_open: their twins without the seal code (SEAL_CODE,
 * terrain_draw.glsl), for the quads without seals; wire: the wireframe pass, where the
 * device has fill_mode_non_solid; the mesh capture's twins of fill and cull (with the seal
 * code, for every quad; terrain_mesh.c). wire and the capture's are made when a frame
 * first asks for them. */
struct draw_pipelines {
	VkPipeline fill, cull, fill_open, cull_open, wire, mesh_fill, mesh_cull, mesh_fill_open, mesh_cull_open;
};

/* The layouts and compute pipelines of the terrain's LOD passes: the same for every
 * terrain (nothing in them depends on the file, the cache or the target), so a device makes
 * them once, at its first terrain, and keeps them (relief_vk_shared(), terrain.c). */
struct terrain_program {
	VkDescriptorSetLayout set_layout;
	VkPipelineLayout select_layout, commands_layout, factors_layout, draw_layout;
	/* force: lod_force.comp, the selection's pre-pass (forced splits) for trees of 3 levels or more */
	VkPipeline select, force, commands;
	/* The factor and border passes per kind of frame: [0] relief's without and [1] with
	 * geomorphing, [2] chunked LOD's (RELIEF_FINE_FULL), [3] the distance baseline's; each
	 * made when a frame on the device first needs it (terrain_lod_pipelines_create()),
	 * under lock. */
	struct lod_pipelines lod[4];
	pthread_mutex_t lock;
	bool locked; /* lock was initialised */
};

struct relief_terrain {
	struct relief_vk *vk;
	const struct relief_file *file;
	struct relief_patch_cache *cache;
	struct relief_vk_buffer info, windows;
	VkBufferView info_view, windows_view; /* bindings 0 and 22 (RGBA32F, RGBA32UI texels) */
	struct terrain_program *prog; /* the device's */
	/* The draw pipelines, the terrain's own (they are made for the target's render pass),
	 * [0] for views without geomorphing, [1] for views with it (relief_view.morph: the
	 * evaluation shader's MORPH_CODE), each made when a frame first needs it
	 * (terrain_draw_pipelines_create()). */
	struct draw_pipelines draw[2];
	VkRenderPass pass; /* the target's, which every pipeline draws into */
	/* per_patch: block quads per drawn patch; max_quads: block and curtain quads of a frame
	 * at most (every layer drawn, each with four curtains: a loose bound) */
	/* count: entries (per-patch buffers' length) */
	uint32_t count, blocks, per_patch, per_draw, max_patches, max_quads, max_draws;
};

struct relief_terrain_view {
	struct relief_terrain *t;
	/* cmds: max_draws records for each part of the lists (the shown list's quads without
	 * seals, with seals, the clipped list's likewise: enum list_part); lists:
	 * both lists, max_quads entries (binding 19) */
	struct relief_vk_buffer split[2], instances, cmds, counters, wants, drawn, factors, seals, borders, curtains,
		lists, frontier, passes;
	/* struct draw_camera: the view-projection positions are drawn with (the LOD's own
	 * matrix is in the push constants), written by the frame's command buffer */
	struct relief_vk_buffer camera;
	VkBufferView camera_view; /* binding 15: its six RGBA32F texels (shaders/draw_camera.glsl) */
	/* What the CPU reads after a frame: counters and requests, copied at its end; the
	 * drawn instances, copied when asked for (relief_terrain_view_drawn()) */
	struct relief_vk_buffer read_counters, read_wants, read_instances;
	/* The mesh capture (relief_terrain_view_mesh_enable()): a header (count, capacity) and
	 * room for mesh_cap triangles, in memory the CPU reads; none until enabled */
	struct relief_vk_buffer mesh;
	uint32_t mesh_cap;
	/* the LOD camera's cell of the last frame drawn with it (the vertices are relative to
	 * it); mesh_frames: such frames recorded since the capture was enabled */
	int64_t mesh_cell[2];
	uint64_t mesh_frames;
	/* The memory of the buffers above: device (all but the last three), readback (those).
	 * Nothing the device reads or updates every frame lives in memory the CPU maps, which
	 * on a discrete GPU is system memory across the bus. */
	struct relief_vk_buffer_group local, readback;
	VkBufferView texels[VIEW_TEXELS]; /* bindings FIRST_TEXELS_BINDING.. */
	VkDescriptorPool pool;
	VkDescriptorSet set[2];
	uint32_t parity;
	uint32_t last_drawn;
	/* Per view, so that several views' frames can be in flight at once */
	VkQueryPool stats_pool;
	/* 0 frame start, 1 selection done, 2 factors and lists done, 3 frame done; with
	 * relief_draw_options.pass_timing also 4 setup done, 5 borders done, 6 factors done
	 * (from FIRST_PASS_SLOT) */
	struct relief_vk_timer timer;
	bool pass_timed; /* the frame in flight or last waited for wrote slots 4-6 */
	/* The last frame waited for: whether its timestamps were read, and its start and end
	 * (raw, relief_terrain_views_span_ns()) */
	bool timed;
	uint64_t start_ticks, end_ticks;
	/* The frame in flight (relief_terrain_draw_submit() to relief_terrain_view_wait()):
	 * its command buffer (VK_NULL_HANDLE: none), fence, and how back faces were culled */
	VkCommandBuffer pending;
	bool captured; /* pending is a capture's (relief_vk_capture_begin()), not this view's to free */
	bool drew;     /* the last frame drew (not relief_draw_options.lod_only): its statistics query ran */
	VkFence fence;
	bool gpu_cull; /* the GPU decided whether back faces were culled (lod_commands.comp) */
};

/* The mesh capture's header in its buffer (terrain_mesh.geom), then 4 uvec4 a triangle: 3
 * vertices (grid column and row relative to the camera's cell, height bits, patch id) and
 * its quad (outer factors a byte each, inner factor | log2 of the patch's scale << 8, the
 * grid column and row of its first corner relative to the camera's cell). */
struct mesh_header {
	uint32_t count, cap;
	uint32_t parts, part; /* relief_draw_options.mesh_parts and mesh_part, set each frame */
};
/* terrain.c: makes t->draw[morph]'s pipelines that are missing: fill and cull, wire if
 * `wire` (and the device has fill_mode_non_solid), the mesh capture's twins if `mesh`. 0
 * or a negative errno; what was made stays. */
int terrain_draw_pipelines_create(struct relief_terrain *t, bool morph, bool wire, bool mesh);
/* terrain.c: the factor and border passes for frames of fine LOD `fine` from views that
 * geomorph (`morph`; only relief's own method does), made if missing. 0 or a negative
 * errno (-EINVAL for an unknown `fine`); what was made stays. */
int terrain_lod_pipelines_create(struct relief_terrain *t, enum relief_fine_lod fine, bool morph,
                                 const struct lod_pipelines **out);
/* terrain_mesh.c: the pipelines a frame draws with (the capture's for a frame drawn with
 * relief_draw_options.mesh, each kind's twin: with and without the seal code), and such a
 * frame's part before and after its draws. */
struct draw_pipelines mesh_pipelines(const struct draw_pipelines *d, bool mesh);
void mesh_frame_begin(struct relief_terrain_view *v, VkCommandBuffer cmd, const struct relief_view_origin *o,
                      uint32_t parts, uint32_t part);
void mesh_frame_end(VkCommandBuffer cmd);

/* One global memory barrier between two stage masks. */
static inline void barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags sa, VkPipelineStageFlags dst,
                           VkAccessFlags da)
{
	VkMemoryBarrier m = { VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL, sa, da };
	vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &m, 0, NULL, 0, NULL);
}
