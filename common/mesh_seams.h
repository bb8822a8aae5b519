/* Whether a captured mesh is watertight: where two triangles meet, they meet at the same
 * points. Pixel checks (a background pixel inside the silhouette) see a crack only where
 * something far enough lies behind it and the rasteriser happens to land a pixel centre in
 * it; this looks at the triangles themselves (relief_terrain_view_mesh()), so a crack is
 * found from any camera that draws the border it opens on. For tests. */
#pragma once

#include <stdint.h>

#include "mesh_error.h"

struct relief_mesh_seams {
	uint64_t positions; /* distinct (column, row) drawn by some non-vertical triangle */
	/* Positions drawn at two different heights (bit patterns) by triangles that each have
	 * a corner there: a crack opens at a shared corner. */
	uint64_t split;
	/* T-junctions: a corner of some triangle strictly inside an edge of another along a
	 * grid row or column (where quads, and so patches, meet), and of those the ones off that
	 * edge's line by more than the tolerance: a crack (or an overlap) along the edge. */
	uint64_t junctions, open;
	double max_gap_m; /* the largest distance off the edge's line over all junctions, metres */
	struct relief_mesh_vertex worst;         /* the corner at max_gap_m (patch 0) */
	struct relief_mesh_vertex worst_edge[2]; /* and the edge it lies inside */
	struct relief_mesh_vertex split_at;      /* the first split position found, one of its heights */
};

/* A tolerance for corners the shaders put on an edge's line with float arithmetic: far
 * below a pixel from any camera the tests and benchmarks use, above the float rounding of
 * terrain heights (at most 1e-3 m below 16,384 m). */
#define RELIEF_MESH_SEAM_TOL_M 1e-3

/* Checks n triangles (3 n vertices, as captured). Vertical triangles (the terrain edge's
 * curtain, which hangs below its top corners) are left out. Only edges along a grid row or
 * column are searched for corners inside them: the tessellator makes each quad's
 * triangulation conforming inside it, and quads meet only along their borders, which run
 * along rows and columns. A junction's gap is |h - h_edge|, h_edge the edge's linear height
 * at the corner, computed in double; a corner counts once for each edge drawn through it.
 * tol_m absorbs the float rounding of a corner that the shaders put on the edge
 * (RELIEF_MESH_SEAM_TOL_M). 0 or -ENOMEM. */
int relief_mesh_seams(const struct relief_mesh_vertex *tri, uint64_t n, double tol_m, struct relief_mesh_seams *out);
