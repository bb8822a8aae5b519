/* Where a captured frame's triangles fall on the viewport (relief bench lod): how many a
 * rasteriser can throw away before it looks for pixels, how many cover no pixel centre, and
 * how many pixel centres the rest cover. On a CPU device the first two kinds cost little
 * beyond the vertex work, so a method's time per triangle depends on its mix of them
 * (docs/benchmarks.md, "What a triangle costs"). */
#pragma once

#include <stdint.h>

#include "format.h"
#include "lod.h"
#include "mesh_error.h"

enum mesh_cover_kind {
	MESH_COVER_OUTSIDE, /* all three corners beyond one plane of the view's frustum */
	MESH_COVER_EYE,     /* some corner at or behind the eye's plane (clipped, not counted further) */
	MESH_COVER_BACK,    /* facing away from the camera, or of no area, on the framebuffer */
	MESH_COVER_EMPTY,   /* facing the camera, no pixel centre of the viewport inside */
	MESH_COVER_PIXELS,  /* facing the camera, some pixel centre inside */
	MESH_COVER_KINDS
};

struct mesh_cover {
	uint64_t kind[MESH_COVER_KINDS];
	uint64_t centres; /* pixel centres inside the MESH_COVER_PIXELS triangles, each counted per triangle */
};

/* Adds the n triangles `tri` (3 n vertices, as captured for view v of file f) to *acc.
 * A centre on a triangle's edge counts as inside (the rasteriser's tie rule would give it to
 * one of the triangles sharing the edge): a triangle whose only centres lie on its edges is
 * counted with those that cover pixels. */
void mesh_cover_add(const struct relief_file *f, const struct relief_view *v, const struct relief_mesh_vertex *tri,
                    uint64_t n, struct mesh_cover *acc);
