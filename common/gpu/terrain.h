/* The terrain renderer: per view, compute shaders select the patches (coarse LOD, frustum
 * culling, requests for missing patches) and write indirect draw records; the tessellator
 * refines each patch per block from its block errors (fine LOD); skirts close the gaps
 * between patches of different levels. No per-patch work on the CPU per frame.
 *
 * Ownership: struct relief_terrain owns its pipelines and the static per-patch buffer;
 * struct relief_terrain_view owns one view's buffers (hysteresis state, instances, draw
 * records, counters, requests). Both borrow the Vulkan context, the file and the cache,
 * which must outlive them. Any number of views may draw from one terrain and one cache. */
#pragma once

#include <stdbool.h>
#include <stdint.h>

#include "format.h"
#include "lod.h"
#include "mesh_error.h"
#include "patch_cache.h"
#include "target.h"

struct relief_terrain;
struct relief_terrain_view;

/* The passes of a frame's LOD compute, in order (docs/lod-performance.md, "Where the LOD
 * compute's time goes"): the buffers cleared and the camera uploaded; the coarse selection
 * (forced splits, one pass for the top levels, then one per level); the patch borders'
 * factors and seals, and the back-face decision; every quad's factors; the lists of quads
 * that draw something with their draw records. */
enum relief_lod_pass {
	RELIEF_LOD_PASS_SETUP,
	RELIEF_LOD_PASS_SELECT,
	RELIEF_LOD_PASS_BORDERS,
	RELIEF_LOD_PASS_FACTORS,
	RELIEF_LOD_PASS_LISTS,
	RELIEF_LOD_PASSES
};

/* The passes' names as `relief bench lod` prints them ("setup", "select", ...). */
const char *relief_lod_pass_name(enum relief_lod_pass pass);

struct relief_terrain_stats {
	uint32_t patches;       /* drawn */
	/* indirect draw records, of both lists (shown and clipped), with and without seals; each
	 * holds 1 .. relief_vk_quads_per_draw(RELIEF_BLOCK_CELLS) quads */
	uint32_t draws;
	uint32_t requests;      /* missing patches asked for this frame */
	uint64_t triangles;     /* primitives reaching the clipper (pipeline statistics), 0 if unsupported */
	/* quad patches the control shader ran for (pipeline statistics), 0 if unsupported: the
	 * quads that draw something, listed after the factor pass (lod_commands.comp) */
	uint64_t quads;
	uint64_t gpu_ns;        /* whole frame (LOD compute, draw, copy-out) */
	uint64_t select_ns;     /* coarse LOD compute: patch selection and draw records */
	uint64_t lod_ns;        /* all LOD compute: select_ns plus the tessellation-factor pass */
	/* With relief_draw_options.pass_timing, lod_ns split by pass (else all 0): consecutive
	 * intervals between timestamps, so they add up to lod_ns, and the first three to
	 * select_ns (to within a nanosecond of rounding each). */
	uint64_t pass_ns[RELIEF_LOD_PASSES];
	bool face_culled;       /* back faces were culled: the camera is above the surface */
	/* The height the GPU compared the eye with (lod_commands.comp): the highest block drawn
	 * around it, as relief_drawn_height_bound(); NaN when no drawn block holds the eye or
	 * the CPU decided (relief_surface_height_bound()) */
	float cull_height;
	/* With back faces culled: the quads drawn with them kept because the rasteriser may
	 * clip them (their box is not well inside the clip volume; docs/lod.md, "Back faces") */
	uint32_t clipped_quads;
	/* The quads drawn with a seal (a vertex on a coarser patch's drawn edge), through the
	 * pipelines with the seal code; the others' pipelines leave it out (docs/lod.md,
	 * "Between patches") */
	uint32_t sealed_quads;
};

int relief_terrain_create(struct relief_vk *vk, const struct relief_file *f, struct relief_patch_cache *cache,
                          const struct relief_vk_target *target, struct relief_terrain **out);
void relief_terrain_destroy(struct relief_terrain *t);

int relief_terrain_view_create(struct relief_terrain *t, struct relief_terrain_view **out);
void relief_terrain_view_destroy(struct relief_terrain_view *v);

/* Buffer memory a terrain holds besides its cache (patch info and index windows: 16 bytes
 * per index entry), and one view holds (its per-patch buffers, 20 bytes per entry, and
 * those sized by the cache's layers), in bytes. Per-patch buffers have one element per
 * index entry (relief_index_entry()), so both follow the data, not the square tree. */
uint64_t relief_terrain_bytes(const struct relief_terrain *t);
uint64_t relief_terrain_view_bytes(const struct relief_terrain_view *v);

/* How blocks are tessellated: relief's rule, or the baselines of `relief bench lod`. */
enum relief_fine_lod {
	RELIEF_FINE_ERRORS = 0,   /* block errors against tau (the method) */
	RELIEF_FINE_FULL = 1,     /* every block at full resolution: chunked LOD */
	RELIEF_FINE_DISTANCE = 2, /* factor from projected edge length, no error metric */
};

struct relief_draw_options {
	bool wire;                    /* overlay the wireframe */
	enum relief_fine_lod fine;
	float target_px;              /* RELIEF_FINE_DISTANCE: wanted triangle width, pixels */
	double select_tau;            /* > 0: tau for the coarse selection instead of view->tau */
	bool no_skirts;               /* tests: draw no skirt, so that any crack stays open */
	bool no_block_cull;           /* tests, bench lod --unculled: tessellate blocks the camera cannot see too */
	bool keep_empty_blocks;       /* tests: tessellate blocks without a valid sample too (they show nothing) */
	bool no_face_cull;            /* tests: draw back faces even when the camera is above the surface */
	/* Non-NULL: choose the level of detail (selection, tessellation) for this view and draw
	 * it from `view` (same viewport size): a frozen LOD, for measuring what LOD changes
	 * alone do to the picture (`relief bench lod` popping) and for inspecting a view's LOD
	 * from elsewhere. The view's hysteresis state is used and updated as for lod_view.
	 * Morphing follows the drawn view's `morph`; its blend is worked out for lod_view. */
	const struct relief_view *lod_view;
	/* Store the frame's triangles in the view's mesh capture (relief_terrain_view_mesh_enable()
	 * first; not with wire): -EINVAL otherwise. */
	bool mesh;
	/* With mesh and mesh_parts > 1: store only the triangles of the patches whose id %
	 * mesh_parts is mesh_part (< mesh_parts, or -EINVAL), and count only those; the frame is
	 * drawn whole all the same. A frame of more triangles than the capture holds is then
	 * captured in parts, drawn again for each (a converged view draws the same frame). */
	uint32_t mesh_parts, mesh_part;
	/* Choose the level of detail (selection, draw records, factors, requests) and draw
	 * nothing: `target` is not touched and may be NULL, the statistics count no triangles
	 * or quads. For carrying a view's hysteresis along frames nobody looks at (`relief bench
	 * lod --every-frame`), and for views whose draw records someone else draws. Not with
	 * wire or mesh (-EINVAL). */
	bool lod_only;
	/* Time each LOD pass (relief_terrain_stats.pass_ns): a timestamp after each, which costs
	 * a CPU implementation some time of its own (lavapipe finishes the work before each), so
	 * the frames whose times count are drawn without it (`relief bench lod --passes`). */
	bool pass_timing;
};

/* Selects and draws one frame of `view` into `target` (cleared first), waits for it, then
 * passes the view's requests for missing patches to the cache (coarse first). `opts` may be
 * NULL (relief's method, no wireframe). relief_terrain_draw_submit() and
 * relief_terrain_view_wait() in one call. */
int relief_terrain_draw(struct relief_terrain *t, struct relief_terrain_view *v, const struct relief_view *view,
                        struct relief_vk_target *target, uint64_t frame, const struct relief_draw_options *opts,
                        struct relief_terrain_stats *st);
/* The same in two halves, so that several views' frames are in flight at once (a GPU then
 * renders one while the CPU records the next): submit records and submits the frame
 * (-EBUSY while this view has one in flight); wait waits for it, fills *st (may be NULL)
 * and passes the requests on (-EINVAL when nothing was submitted, -EDEADLK while the frame
 * sits in a capture not yet submitted, relief_vk_capture_begin()). In between, the view
 * and `target` belong to the device: give each view in flight a target of its own, do not
 * read the target, and do not update the cache (relief_patch_cache_update() refuses, see
 * relief_patch_cache_hold()). Frames run in submission order. The first frame of a view
 * with morph set (or drawn with opts->wire or opts->mesh) makes the pipelines it needs,
 * once per terrain: views without morphing draw through pipelines without its code. */
int relief_terrain_draw_submit(struct relief_terrain *t, struct relief_terrain_view *v, const struct relief_view *view,
                               struct relief_vk_target *target, uint64_t frame, const struct relief_draw_options *opts);
int relief_terrain_view_wait(struct relief_terrain *t, struct relief_terrain_view *v, struct relief_terrain_stats *st);
/* The device time from the earliest start to the latest end of the views' last frames
 * (each waited for): what a round of frames costs when a GPU overlaps them, which the sum
 * of their gpu_ns would count more than once. -EBUSY while one is in flight, -ENODATA
 * when one has no timed frame (none waited for, or no timestamps on this queue). */
int relief_terrain_views_span_ns(struct relief_terrain *t, struct relief_terrain_view *const *views, uint32_t n,
                                 uint64_t *ns);

/* The last frame's drawn patch ids (unordered), at most cap, for tests and statistics:
 * copied out of device memory and waited for. Returns the count or a negative errno
 * (-EBUSY while the view has a frame in flight). */
int relief_terrain_view_drawn(struct relief_terrain_view *v, uint32_t *ids, uint32_t cap);
/* Mesh capture, for measuring a frame's error triangle by triangle (relief_mesh_error();
 * tests, `relief bench lod`): gives the view room for max_triangles (enabling again
 * changes it). A frame drawn with relief_draw_options.mesh then goes through pipelines
 * that also store each triangle the tessellator makes (a geometry shader that passes it
 * on unchanged: the same picture, at some cost). -ENOTSUP without geometry shaders that
 * store to buffers (vk->has.mesh_capture), -EBUSY while a frame is in flight, -E2BIG for
 * more than relief_terrain_mesh_limit() triangles. */
int relief_terrain_view_mesh_enable(struct relief_terrain_view *v, uint32_t max_triangles);
/* The most triangles a mesh capture holds on this device: its buffer is one storage
 * buffer binding, at most maxStorageBufferRange bytes (2^27 on lavapipe: about 2.1 million
 * triangles). */
uint32_t relief_terrain_mesh_limit(const struct relief_vk *vk);
/* The triangles of the view's last frame drawn with relief_draw_options.mesh (3 vertices
 * each in `out`, in drawing order, and, unless `quads` is NULL, the quad each was drawn
 * in; with mesh_parts, its part's), up to cap of them: returns the number that frame drew
 * (of its part), which may be more than cap or than the room enabled (only those that fit
 * were kept); -ENODATA if no such frame was drawn since the capture was enabled, -EBUSY
 * while a frame is in flight. */
int64_t relief_terrain_view_mesh(const struct relief_terrain_view *v, struct relief_mesh_vertex *out,
                                 struct relief_mesh_quad *quads, uint32_t cap);
/* The last frame's requests (patch ids, unordered; at most the frame's cap), for tests;
 * returns the count (0 while the view has a frame in flight). */
uint32_t relief_terrain_view_wants(const struct relief_terrain_view *v, uint32_t *ids, uint32_t cap);
