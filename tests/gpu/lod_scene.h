/* Scenes for the LOD tests (test_lod_*.c): a bundled DEM packed in memory, a patch cache,
 * a render target and one view on the test group's Vulkan context; rendering until the
 * view asks for nothing more; and the comparison of a LOD render with a full-resolution
 * one (cracks and vertical error in pixels against the finest decoded surface). */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../data_load.h"
#include "format.h"
#include "lod.h"
#include "mesh_seams.h"
#include "patch_cache.h"
#include "terrain.h"

struct scene {
	struct relief_vk *ctx; /* the test group's context */
	uint8_t *img;
	size_t size;
	struct relief_file *f;
	struct relief_patch_cache *cache;
	struct relief_vk_target target;
	struct relief_terrain *terrain;
	struct relief_terrain_view *view;
	uint32_t mesh_room; /* triangles the view's mesh capture holds (0: not enabled) */
	/* scene_residency(): each cache layer's border charges and the patch they were read
	 * for (UINT32_MAX: none yet); a patch decodes to the same record in any layer, so they
	 * hold while it stays there. */
	float *layer_border;
	uint32_t *layer_owner;
	/* render_with() numbers its frames from 100 + frame_base (0 unless the test sets it). A
	 * test that draws many far-apart views one after another raises it for each, so that
	 * the cache sees time go on and may evict what the views before used (it keeps what
	 * was used within its keep_frames of the current frame). */
	uint64_t frame_base;
};

/* A DEM packed at tolerance tol and moved by (dx, dy), in a 128 MiB cache of at most
 * max_layers layers (0: as many as the budget holds), a w x h target and one view. (64 MiB
 * until December 2026: 1,460 layers of 65-sample patches, fewer than some views of
 * test_lod_sweep's 4097 coast want; 128 MiB gives lavapipe's most, 2,048.) */
void scene_open_at(struct scene *s, struct relief_vk *vk, enum test_dem d, double tol, uint32_t w, uint32_t h,
                   double dx, double dy, uint32_t max_layers);
void scene_open(struct scene *s, struct relief_vk *vk, enum test_dem d, double tol, uint32_t w, uint32_t h);
/* The same for a DEM of the test's own (the caller keeps it). */
void scene_open_dem(struct scene *s, struct relief_vk *vk, const struct relief_dem *dem, double tol, uint32_t w,
                    uint32_t h, uint32_t max_layers);
/* The same with patches of `patch` samples (65, 129 or 257) instead of 129. */
void scene_open_dem_patch(struct scene *s, struct relief_vk *vk, const struct relief_dem *dem, uint32_t patch,
                          double tol, uint32_t w, uint32_t h, uint32_t max_layers);
/* Also for a scene whose parts were made by hand (ctx set, img NULL). */
void scene_close(struct scene *s);

/* Everything resident, so that selection is the only variable. */
void load_everything(struct scene *s);

/* resident[id] for every patch (the cache's state), and where relief_lod_select() finds
 * the resident ones' border charges (relief_lod_border_charges() of their layers' block
 * records, read back once per patch and layer; held by the scene). */
struct relief_lod_borders scene_residency(struct scene *s, uint8_t *resident);

int cmp_u32(const void *a, const void *b);

/* Renders v and copies out depth (Vulkan [0, 1]). Converges: draws until nothing is asked
 * (at most 40 frames, from frame 100 + s->frame_base). */
void render_with(struct scene *s, struct relief_view *v, const struct relief_draw_options *opts, float *depth,
                 struct relief_terrain_stats *st);
/* The same, but false where the view wants more patches than the cache's layers hold
 * (all in use by it, relief_patch_cache_flush() -ENOSPC): it is then drawn with parents
 * for the patches that have no layer, not at its own level of detail. */
bool render_fits(struct scene *s, struct relief_view *v, const struct relief_draw_options *opts, float *depth,
                 struct relief_terrain_stats *st);
void render(struct scene *s, struct relief_view *v, float *depth, struct relief_terrain_stats *st);

/* A captured mesh is watertight (relief_mesh_seams()): no position drawn at two heights (a
 * crack at a shared corner) and no T-junction at all (a corner inside another triangle's
 * edge, which a rasteriser does not close even when the corner is on the edge's line),
 * since the seals draw a finer patch's border with the coarser patch's vertices and a
 * border edge has a vertex at every corner of the finer blocks across it (docs/lod.md,
 * "Between patches"). Unlike a background pixel, this finds a crack from any camera that
 * draws the border, whatever lies behind it. Prints the counts.
 * Negative controls, run when this check was written (thirty-ninth December 2026
 * session): the evaluation shader ignoring the side seal records fails 7 of
 * test_lod_mesh's 11 tests (Puget Sound pose 0 at tau 4: 6 positions split) and
 * test_lod_bound's sealed-border, sealed-corner and deep-jump tests by split positions
 * (10 in test_sealed_borders' first frame, which its pixels alone no longer catch);
 * ignoring the corner records 6 and the same 3 (1-2 split); the factor pass marking no
 * quad as sealed, so that every quad is drawn without the seal code (the capture draws
 * with the same twin pipelines as a frame), 7 and the same 3 (6-12 split); a border edge
 * not raised for a finer patch across it (drawn_border_factor() without its rule), 8 and
 * the same 3 by T-junctions (10-27 in the first failing frame of each, every one exactly
 * on its edge's line: only counting the junctions catches it); no forced splits
 * (lod_force.comp) in test_level_jumps_of_five, 4 T-junctions in its first view. */
void assert_seamless(const struct relief_mesh_vertex *tri, uint64_t n);
/* Draws v (converged) with opts (NULL: relief's defaults) and the view's mesh capture on
 * (room made at first use, and again when a frame draws more) and asserts the frame's mesh
 * seamless; returns its triangle count. The test group's context must have the capture
 * (gpu_test_mesh_capture). */
uint64_t render_seamless(struct scene *s, struct relief_view *v, const struct relief_draw_options *opts);

struct comparison {
	uint32_t holes, both; /* background inside the reference's silhouette; terrain in both */
	double worst_px, worst_m; /* largest vertical error against the finest decoded surface */
	/* pixels over tau that see through the surface all eight neighbours show, left out of
	 * worst_px: the rasteriser's pinholes (below) */
	uint32_t pinholes;
	/* pixels where the reference itself is over REF_OFF_PX off the finest surface, left out
	 * of worst_px: a terrain-edge curtain seen from outside, a near edge-on triangle whose
	 * depth the rasteriser interpolates badly (relief bench lod leaves them out too) */
	uint32_t off_surface;
};
#define REF_OFF_PX 0.1

/* A LOD render (depth `lod`) against the full-resolution one (`ref`) of the same view. A
 * pixel is inside the silhouette when the reference shows terrain within ceil(tau) + 1
 * pixels all around it. A pixel over tau that shows something farther than the reference
 * and than all eight of its neighbours, which are within tau, is a pinhole: lavapipe's
 * rasteriser leaves such single pixels uncovered between triangles that share their
 * vertices bit for bit (seen, December 2026, where the mesh capture found that frame's
 * mesh within tau everywhere and without a T-junction); a crack is a line of pixels, which
 * this does not leave out, and test_sealed_borders looks for cracks with nothing behind.
 * `drawn`, `valid`: the finest level (relief_surface_vertical_error()). */
struct comparison compare(const struct scene *s, const struct relief_view *v, const float *ref, const float *lod,
                          const float *drawn, const uint8_t *valid, uint32_t fw, uint32_t fh);

/* View tv's last frame's drawn patch ids (relief_terrain_view_drawn(), which must succeed). */
uint32_t view_drawn(struct relief_terrain_view *tv, uint32_t *ids, uint32_t cap);
/* View tv's last frame: its drawn patches (ids[], *n of them) and the mask of their
 * levels; if counts is not NULL, each level's number of patches is added to
 * counts[RELIEF_MAX_LEVELS]. */
uint32_t view_levels(const struct scene *s, struct relief_terrain_view *tv, uint32_t *ids, uint32_t *n,
                     uint32_t *counts);
/* The scene's own view's last frame (view_levels()). */
uint32_t drawn_levels(const struct scene *s, uint32_t *ids, uint32_t *n);

/* The scene's view's last frame, drawn by a view with nothing split before (a new one),
 * against the CPU reference (relief_lod_select(), nothing split, the cache's resident
 * patches): the same patches and as many requests (st: that frame's stats). Returns the
 * patch count. */
uint32_t gpu_matches_cpu(struct scene *s, const struct relief_view *v, const struct relief_terrain_stats *st);
/* The same for v drawn (frame `frame`, options `opts`) by a new view that replaces the
 * scene's, so that nothing is split before. */
uint32_t fresh_view_matches_cpu(struct scene *s, const struct relief_view *v, uint64_t frame,
                                const struct relief_draw_options *opts);
/* The largest level difference between two drawn patches (ids[], n of them) that share a
 * border. */
uint32_t max_level_jump(const struct scene *s, const uint32_t *ids, uint32_t n);

struct pose {
	double eye[3], at[3];
};

/* An N x N grid 30 m apart whose north-west sample is at (0, 30 (N - 1)), so that its
 * south-west one is at the origin: heights 0, every sample valid (the caller finishes it). */
struct relief_dem grid_dem(int N);
/* A 32-bit integer hash (mixing constants of the "lowbias32" family): the test terrains'
 * noise and the sweeps' camera positions, the same on every machine. */
uint32_t hash32(uint32_t x);
/* N x N samples of that grid: a flat sea west of the middle column, land east of it (a 5 m
 * per sample rise), rough from `band` samples inland (up to 200 m of per-sample noise,
 * ramped in over 16 samples). Packed with 65-sample patches, the sea's coarse patches
 * border land drawn several levels finer. With band 0 the land is rough at the shore,
 * and a patch drawn there can rarely draw its border with a coarse sea patch's vertices
 * within tau (lod_force.comp splits the sea instead); with band 32 (COAST_BAND) its border
 * blocks are smooth at the two finest levels, so the sea stays coarse beside them: the
 * level jumps the seals are tested with. */
#define COAST_BAND 32
struct relief_dem coast_dem(int N, int band);
/* View i of the coast sweep: along the coast, 300-6,300 m up, looking down at the sea or
 * the land. */
struct pose coast_sweep_pose(int N, uint32_t i);
/* View i of the steep sweep over an N x N grid: 800-4,800 m over the middle column,
 * looking down at a point within 1 km, so that the terrain fills the frame and any
 * background pixel is a hole. */
struct pose steep_sweep_pose(int N, uint32_t i);
/* 513 x 513 of that grid on a slope, with a 1,000 m step between two samples along a
 * patch border (x = 256) and a 300 m diagonal step (x + y = 600), and poses at both. */
struct relief_dem cliffs_dem(void);
enum { CLIFFS_POSES = 5 };
extern const struct pose cliffs_poses[CLIFFS_POSES];

/* The poses the bound is checked from, pixel by pixel (test_lod_bound) and triangle by
 * triangle (test_lod_mesh): Puget Sound's and Mont Blanc's. */
enum { PUGET_BOUND_POSES = 4, ALPS_BOUND_POSES = 3 };
extern const struct pose puget_bound_poses[PUGET_BOUND_POSES], alps_bound_poses[ALPS_BOUND_POSES];

enum { BW = 320, BH = 180 }; /* bound_scene size */

/* A BW x BH scene of a DEM packed at 1 m, its finest level decoded, two depth images. */
struct bound_scene {
	struct scene s;
	uint32_t fw, fh;
	float *ref, *lod;
	/* the finest level's every decoded height, no-data ones too, and which are valid: what
	 * compare() and relief_mesh_error() measure against */
	float *drawn;
	uint8_t *valid;
};

void bound_open(struct bound_scene *b, struct relief_vk *vk, enum test_dem dem);
/* The same for a DEM of the test's own (the caller keeps it). */
void bound_open_dem(struct bound_scene *b, struct relief_vk *vk, const struct relief_dem *dem);
void bound_open_dem_patch(struct bound_scene *b, struct relief_vk *vk, const struct relief_dem *dem, uint32_t patch);
/* The N x N coast with a smooth band (coast_dem(N, COAST_BAND)) packed with 65-sample
 * patches. */
void bound_open_coast(struct bound_scene *b, struct relief_vk *vk, int N);
/* The finest level and the depth images for a scene opened otherwise (scene_open_at()). */
void bound_buffers(struct bound_scene *b);
/* Also fails the test if the validation layer spoke. */
void bound_close(struct bound_scene *b);
/* The finest sample nearest world (x, y): its column and row in b->drawn and b->valid.
 * False where it lies outside the raster or is no-data (then *c and *r are left). */
bool bound_sample_at(const struct bound_scene *b, double x, double y, long *c, long *r);

/* The view of a pose, with a tau fine enough for a full-resolution reference. */
struct relief_view pose_view(const struct pose *p);

/* Renders v at full resolution and at each of `taus`, and checks every LOD frame against
 * the reference: no cracks, at least min_pixels showing terrain in both, the vertical error
 * within tau at every one of them. */
void within_tau_of_reference(struct scene *s, struct relief_view *v, const double *taus, size_t n, const char *what,
                             uint32_t min_pixels);

/* One frame a benchmark flight found over tau, on a file packed at 1 m: within tau now, at
 * at least a quarter of the pixels showing terrain in both renders. */
void benchmark_frame_within_tau(struct relief_vk *vk, enum test_dem dem, struct relief_view *v, double tau,
                                const char *what);
