/* Geometry of the patch quadtree (docs/format.md §Layout).
 *
 * Level 0 is the root (one patch), level L = levels - 1 the full resolution. Level l has
 * 2^l x 2^l patches and S_l = 2^l (P - 1) + 1 samples per side; h_(l-1)[y][x] = h_l[2y][2x]
 * (decimation). Patch (l, px, py) covers level-l samples [px (P-1), px (P-1) + P - 1] in x
 * (east) and likewise in y (rows, southwards); neighbours share their border samples.
 * Patch ids are level-major: id = (4^l - 1) / 3 + py 2^l + px.
 *
 * Tolerances: delta_L = the user's tolerance, delta_(l-1) = ratio * delta_l.
 * Tessellation blocks: RELIEF_BLOCK_CELLS x RELIEF_BLOCK_CELLS cells, (P-1)/16 per side.
 */
#pragma once

#include <stdbool.h>
#include <stdint.h>

#include "codec.h"

#define RELIEF_MAX_LEVELS 16
#define RELIEF_BLOCK_CELLS 16
#define RELIEF_BLOCK_LEVELS 4 /* simplification by 2^d, d = 1..4 */
#define RELIEF_MAX_BLOCKS (16 * 16) /* blocks per patch at the largest patch size, 257 */

struct relief_layout {
	struct relief_patch_geom geom;
	uint32_t levels;
	uint32_t size;        /* S_L, finest samples per side */
	uint32_t ratio;       /* 2 or 3 */
	uint32_t blocks;      /* blocks per patch side */
	uint32_t patch_count; /* (4^levels - 1) / 3 */
	double tolerance;     /* delta_L in metres */
	double delta[RELIEF_MAX_LEVELS];
};

/* -EINVAL for a patch size other than 65/129/257, levels outside 1..16, ratio other than
 * 2 or 3, or a tolerance outside [1e-4, 1e4] m. */
int relief_layout_init(struct relief_layout *lay, uint32_t patch, uint32_t levels, uint32_t ratio, double tolerance);
/* Levels needed so that a W x H raster fits: the smallest L with 2^L (P-1) + 1 >= max(W, H). */
uint32_t relief_layout_levels_for(uint32_t patch, uint32_t width, uint32_t height);

static inline uint32_t relief_level_size(const struct relief_layout *lay, uint32_t l)
{
	return (lay->geom.P - 1) * (1u << l) + 1;
}

static inline uint32_t relief_level_first_id(uint32_t l)
{
	return (uint32_t)(((1ull << (2 * l)) - 1) / 3);
}

static inline uint32_t relief_patch_id(uint32_t l, uint32_t px, uint32_t py)
{
	return relief_level_first_id(l) + py * (1u << l) + px;
}

/* Inverse of relief_patch_id; false for an id outside the tree. */
bool relief_patch_coords(const struct relief_layout *lay, uint32_t id, uint32_t *l, uint32_t *px, uint32_t *py);

/* The samples patch (l, px, py)'s stream codes (format version 3) for a raster whose valid
 * extent is width x height finest samples. Skipped: the patch's samples inside the level
 * grid (global 0..S_l - 1) from the first even column (row) at or beyond n, the extent's
 * level-l width (height) ceil(width / 2^(L-1-l)), plus one with `rim` (format version 9:
 * the first column past the extent is coded, so that the packer can put it at the edge's
 * height at every level: docs/codec.md, "No-data"). The packer gives the skipped samples
 * label 0 and residual 0 (they take the prediction; relief_level_coded() below), and the
 * patch-local prediction equals that global one there because every refined value it uses
 * is skipped too, where labels are 0 (hence the even column). The grid's outer ring
 * (global -1 and S_l) stays coded: its values are clamped copies, not the patch-local
 * prediction (ring_west, ring_north, and a full window for the last patch column and
 * row). The root (l = 0) codes exactly the samples inside the extent (and with `rim` the
 * first past it): its prediction is causal (MED in raster order), and the packer gives
 * every sample outside, its ring included, the prediction. */
void relief_patch_window(const struct relief_layout *lay, uint32_t width, uint32_t height, uint32_t l, uint32_t px,
                         uint32_t py, bool rim, struct relief_window *win);

/* The level-l samples [0, n) along an axis of `extent` finest samples, n = ceil(extent /
 * 2^(L-1-l)) (+ 1 with `rim`) rounded up to even below the root: every patch stream whose
 * block holds such a sample codes it (the windows above), so the packer may give it any
 * value, and those past the extent are what it fills (common/fill.h). The grid's west and
 * north ring (global -1) is coded too but left to the prediction. */
uint32_t relief_level_coded(const struct relief_layout *lay, uint32_t extent, uint32_t l, bool rim);

/* A level's quantised values with a one-sample ring, over a window of the level that
 * starts at its sample 0 (the raster lies at the grid's origin, padding east and south):
 * samples (x, y) for x in [-1, w], y in [-1, h] (w, h <= size, the level's side; the whole
 * level when both equal it), (w + 2)(h + 2) values, relief_qgrid_index() of each. */
struct relief_qgrid {
	uint32_t size, w, h;
	int32_t *q;
};

static inline size_t relief_qgrid_index(const struct relief_qgrid *g, int x, int y)
{
	return (size_t)(y + 1) * (g->w + 2) + (size_t)(x + 1);
}

int relief_qgrid_init(struct relief_qgrid *g, uint32_t size, uint32_t w, uint32_t h);
void relief_qgrid_finish(struct relief_qgrid *g);
/* Copies patch (px, py)'s E x E block (with ring) out of a level grid. */
void relief_qgrid_get_patch(const struct relief_qgrid *g, const struct relief_patch_geom *geom,
                            uint32_t px, uint32_t py, int32_t *block);
