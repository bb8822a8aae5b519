/* The error of a drawn mesh, triangle by triangle: what a frame's tessellated surface
 * (captured with relief_terrain_view_mesh()) is off the finest decoded surface, everywhere
 * on every triangle in the view's frustum, projected to pixels as the level of detail
 * promises it (docs/lod.md, "Measured error"). Pixel measurements (depth against a
 * full-resolution render) see a frame only at pixel centres, and through the rasteriser;
 * this sees every triangle whole, including the tessellator's transition strips, which no
 * stored block error bounds, and triangles hidden behind others. For tests and
 * `relief bench lod`. */
#pragma once

#include <stdint.h>

#include "format.h"
#include "lod.h"

/* One vertex as drawn: a finest-grid sample of the file (column and row, outside the
 * raster for curtains along its edge) and the height drawn there (metres); the patch it
 * belongs to. Vertices land on samples (docs/lod.md, "Fine LOD"). */
struct relief_mesh_vertex {
	int64_t col, row;
	float height;
	uint32_t patch;
};

/* The tessellation quad (a block, RELIEF_BLOCK_CELLS patch cells a side) a triangle was
 * drawn in: its corner sample of least column and row, its side in finest cells, and its
 * factors as drawn: segments of its west, north, east and south edges (the first and last
 * column and row) and of its interior (an inner factor of 1 is drawn as 2 unless every
 * edge has 1 segment). */
struct relief_mesh_quad {
	int64_t col, row;
	uint32_t cells;
	uint8_t outer[4], inner;
};

/* What a triangle is to the level of detail (relief_mesh_error(), with its quad):
 * - REGULAR: half of a square of side 2^k finest cells with corners on multiples of 2^k,
 *   a triangle of some level's own triangulation (the block errors bound it);
 * and the tessellator's transition triangles, in the strip along one edge of a quad whose
 * factor differs from the interior's, between the edge's segments and the inner ring:
 * - COARSE_EDGE: the edge's segments are longer than the interior's cells (the interior
 *   is finer);
 * - FINE_EDGE: they are shorter (the interior is coarser, with an inner ring);
 * - FAN: they are shorter and the interior is its centre alone (inner factor 2);
 * - OTHER: a transition triangle that is none of these: not within one strip, or not
 *   within one column of the strip as wide as the coarser of its edge's segments and its
 *   interior's cells (docs/lod.md, "Transition triangles");
 * - UNKNOWN: no quad given, or vertices off the quad's samples. */
enum relief_mesh_kind {
	RELIEF_MESH_REGULAR,
	RELIEF_MESH_COARSE_EDGE,
	RELIEF_MESH_FINE_EDGE,
	RELIEF_MESH_FAN,
	RELIEF_MESH_OTHER,
	RELIEF_MESH_UNKNOWN,
	RELIEF_MESH_KINDS
};

/* The kind of triangle c (3 vertices) drawn in quad q (see enum relief_mesh_kind). */
enum relief_mesh_kind relief_mesh_kind(const struct relief_mesh_vertex *c, const struct relief_mesh_quad *q);

struct relief_mesh_error {
	/* The largest projected vertical error (pixels) against the finest surface with the
	 * nearer of each finest cell's two triangulations at the point, the reference of the
	 * pixel measurements too (relief_surface_vertical_error(): either diagonal may be the
	 * one a full-resolution frame draws), and against the worse of the two, which counts
	 * the cell's own ambiguity (so it is large wherever full resolution is drawn near the
	 * camera, by the other diagonal) */
	double max_px, max_px_worse;
	double max_m;                          /* at max_px, metres */
	struct relief_vec3 worst;              /* where max_px was found: the drawn point, world metres */
	struct relief_mesh_vertex worst_tri[3]; /* and the triangle it lies on */
	/* Transition triangles (the tessellator's, between an edge and an interior of other
	 * factors: not part of any level's triangulation, so no block error bounds them) and
	 * their largest error (pixels, nearer diagonal); regular triangles above full
	 * resolution against the worse diagonal (block errors bound them so) */
	uint64_t transition;
	double max_px_transition, max_px_regular_worse;
	/* Triangles of each kind (not vertical, like `transition`: in the frustum or not) and
	 * their largest error (pixels, nearer diagonal); every triangle is UNKNOWN when no
	 * quads are given */
	uint64_t kind_triangles[RELIEF_MESH_KINDS];
	double kind_max_px[RELIEF_MESH_KINDS];
	uint64_t triangles; /* triangles measured: not vertical, some point in the frustum */
	uint64_t vertical;  /* vertical triangles left out (terrain-edge curtains, skirts) */
	uint64_t points;    /* points evaluated in the frustum */
};

/* Measures n triangles (3 n vertices; `quads`, the quad of each, may be NULL) drawn for
 * view v against the finest decoded surface (`finest`, w x h heights in metres at the
 * file's finest samples), every sample's decoded height, no-data ones too
 * (relief_decode_level_drawn()), and `valid` (w x h bytes, 1 = a valid sample; NULL: all
 * valid): a cell with a valid corner is measured whole, since a renderer keeps the part of
 * it nearest its valid corners and that part leans towards the others (the block errors
 * bound it so: docs/codec.md, "Errors"); a cell without one is skipped, as the pixel
 * measure (relief_surface_vertical_error()) skips it. The
 * difference of the flat triangle and the finest surface (either diagonal in each cell)
 * is linear between the points where the triangle's edges cross the finest grid's lines
 * and diagonals, the grid's samples and cells' centres inside it, and its corners, so its
 * largest magnitude is found exactly there. Each such point in the frustum counts; one
 * in a finest cell left out as above, or outside the samples, is skipped (nothing is
 * promised there). The projection to pixels is taken at the same points: between them it
 * varies with the depth, by at most the relative change of depth across a finest cell, so
 * the maximum stated may be short of the true one by that fraction. */
void relief_mesh_error(const struct relief_file *f, const struct relief_view *v, const float *finest,
                       const uint8_t *valid, uint32_t w, uint32_t h, const struct relief_mesh_vertex *tri,
                       const struct relief_mesh_quad *quads, uint64_t n, struct relief_mesh_error *out);
