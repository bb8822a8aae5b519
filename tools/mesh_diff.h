/* What changed between two captured meshes of the same camera (relief bench lod, popping
 * events): the tessellation quads compared place by place. For the benchmark only. */
#pragma once

#include <stdint.h>
#include <stdio.h>

#include "mesh_error.h"

/* A mesh's quads, one per place: the distinct relief_mesh_quad records of a capture (which
 * holds one per triangle), sorted by place (side in finest cells, row, column). */
struct mesh_quads {
	struct relief_mesh_quad *q;
	uint64_t n;
};

/* Quads of the second mesh against the first, counted by place:
 * - interiors: a place both draw, at another inner factor (the outer ones may differ too);
 * - edges: a place both draw, the inner factor the same and some outer factor not;
 * - coarse: a place only one draws (the coarse selection differs there: a patch split or
 *   merged, or a curtain quad that comes or goes; or the block is culled in one mesh
 *   only), counted in either mesh. */
struct mesh_quad_changes {
	uint64_t interiors, edges, coarse;
};

/* Fills qs from n captured triangles' quads; 0 or -ENOMEM. mesh_quads_finish() frees it
 * (accepts a zeroed one). */
int mesh_quads_init(struct mesh_quads *qs, const struct relief_mesh_quad *tri_quads, uint64_t n);
void mesh_quads_finish(struct mesh_quads *qs);

/* Counts the changes from a to b into out (added to what it holds). With `trace`, also
 * writes one line per changed place: where, and both factor sets ("-" for a place one
 * mesh does not draw). */
void mesh_quads_compare(const struct mesh_quads *a, const struct mesh_quads *b, FILE *trace,
                        struct mesh_quad_changes *out);
