#version 450
// Transition strip bounds of one decoded patch (docs/lod.md, "Transition triangles: what
// bounds them"). Where a block edge's factor differs from the interior's, the
// tessellator fills the strip along that edge with triangles that lie, each, in one
// column of the strip: a square Q of side c on the edge, c the larger of the edge's
// segment and the interior's cell (checked on every captured frame by test_lod_mesh).
// Such a triangle T is then within D(T) + eps_c of the finest surface, where eps_c, the
// block's stored error at Q's level, bounds either triangulation L of Q, and D(T) is the
// largest |T - L| on T, which the patch's own samples give. A coarse-edge strip's T is
// also within D_i(T) + eps_i, with L_i the finer interior's triangulation (cells of 2^i):
// its corners are L_i's vertices, and D_i(T), the largest |T - L_i| on T, again comes from
// the samples. Per block and edge (west, north, east, south) this pass stores, in metres:
// [0..3] for an edge at level e = 1..4 (segments of 2^e samples), the charge of its
//        coarse-edge strips: over every finer interior level i, the smaller of the two
//        bounds (eps_0, the full resolution's: at the file's finest level half the largest
//        twist of the edge's first row of cells, above it the patch's drawn error E0(P)
//        where the file stores it);
// [4..6] for an edge at level e = 0..2 against an interior one level coarser (e = 2 and an
//        inner factor of 2 is a fan from the block's centre): the charge of its fine-edge
//        strips, the smaller of eps_(e+1) + D and eps_e + D_e (fine_edge_level_<so>;
//        eps_0 at the finest level from the first two rows, above it E0(P));
// [7]    0.
// The LOD projects them (terrain_factors.glsl). No-data samples count with their decoded
// heights: a triangle with a no-data corner still draws wherever its nearest sample is
// valid (leaving such points out let a fan at Mont Blanc's raster edge pass tau). Heights
// are read in quanta and differenced as integers before any rounding.
#extension GL_GOOGLE_include_directive : require
#include "block_record.glsl"

layout(local_size_x = 64) in;

layout(binding = 0, r32i) uniform readonly iimage2DArray heights;

#include "patch_job.glsl"
// The layers' block records: the file's part (copied before this pass) is read, the strip
// bounds' part written.
layout(std430, binding = 5) buffer Records { float rec[]; };
ivec2 origin; // the block's first sample
int edge;     // 0 west, 1 north, 2 east, 3 south

// The sample `along` the edge and `depth` in from it.
ivec2 at(int along, int depth)
{
	const int n = int(BLOCK_CELLS);
	return origin + (edge == 0 ? ivec2(depth, along) : edge == 1 ? ivec2(along, depth)
	               : edge == 2 ? ivec2(n - depth, along) : ivec2(along, n - depth));
}

int sample_height(int along, int depth) { return imageLoad(heights, ivec3(at(along, depth) + 1, pc.layer)).x; }

// The bounds, written out term by term by shaders/strip_terms_gen.c at build time (it says
// why); what they compute, for an edge with segments of `so` samples:
//
// coarse_edge_<so>_<si>: coarse-edge strips against an interior of cells si < so (a
// power of two): every ring vertex v (at depth si, every si along, inset by si at both
// ends) against each half of its column's square that touches the edge and holds v; a
// triangle of such a strip lies in one of those halves (the ring is at most so / 2 deep),
// where T - L is linear and vanishes at the edge's vertices, so |T - L| peaks at a ring
// vertex.
//
// interior_edge_<so>_<si>: the same strips against the interior's own triangulation L_i,
// either diagonal in every cell: T spans one row of its cells (depth 0 to si), and T - L_i
// is linear on each piece of T that the cells' sides and diagonals cut, so it peaks at the
// cuts on T's sides (relief_strip_interior_points() lists them) or at the samples on the
// edge segment.
//
// interior_full_<so>_<si> (si > 1): the same strips against full resolution L_0 with every
// choice of diagonals at once (as fine_edge_full below: relief_strip_interior_full_points()
// lists the points), a third bound with eps_0 (0 at the finest level, E0(P) above it); at
// si = 1 interior_edge_<so>_1 is that bound already. Since the twenty-fourth December session.
//
// row_eps_<r>: half the largest twist of the cells from depth r to r + 1; at the finest
// level, how far the full resolution with either diagonal lies from the finest surface there
// (a fine-edge strip at level 0 spans rows 0 and 1). interior_edge_<so>_1 needs none: it
// takes every diagonal, so at the finest level it is the distance from the finest surface
// itself (until the twenty-fourth December session row 0's was added to it).
//
// strip_charges: their combination per level (relief_strip_bounds()).
//
// fine_edge_<so>: fine-edge strips (and fans) against an interior of cells of c = 2 so:
// per column square Q of side c, the triangles joining an edge segment to a corner of Q's
// far side lie in one half of Q with only the edge's middle vertex M off it (|T - L| = its
// deviation from Q's edge); a triangle joining Q's far side (a ring segment, where the
// ring has both ends) to M crosses both diagonals, and with L the better of Q's two
// triangulations, |T - L| peaks at M or where T's edge meets L's diagonal, a third of the
// way up: (hB + 2 hM - hA - 2 hC) / 3 with the diagonal A-C, (hA + 2 hM - 2 hO - hB) / 3
// with O-B (O, C the edge's ends, A, B the far side's, A above O).
//
// fine_edge_level_<so>: the same triangles against the edge's own level L_e (cells of so,
// 2 x 2 in Q): their corners are L_e's vertices, and no side of theirs crosses both
// diagonals of a cell, so with the diagonal no side crosses in each cell (eps_e bounds
// either), T - L_e peaks at L_e's vertices on or in T or where T's sides cross a cell's
// side (relief_strip_fine_points() lists them). Until the twenty-third December session
// only the bound through Q was stored, and an interior was raised where it failed though
// the edge's own level would have held.
//
// fine_edge_full_<so>: the same triangles against full resolution L_0 with every choice of
// diagonals at once: T - L_0 is linear on each piece of T that the cells' sides and the
// chosen diagonals cut, so it peaks at the samples in or on T or where T's sides cross a
// cell's side or either diagonal (relief_strip_full_points() lists them). At the finest
// level L_0 is the finest surface with some diagonals, so eps_0 is 0 there (twenty-fourth
// December session).
#include "strip_terms.glsl"

void main()
{
	if (!job_begin())
		return;
	uint blocks = uint(pc.P - 1) / BLOCK_CELLS, items = blocks * blocks * 4u;
	for (uint i = gl_LocalInvocationID.x; i < items; i += gl_WorkGroupSize.x) {
		uint b = i / 4u;
		ivec2 bl = ivec2(b % blocks, b / blocks);
		origin = bl * int(BLOCK_CELLS);
		edge = int(i % 4u);
		uint base = block_strip_index(pc.layer, bl, uint(edge), blocks);
		strip_load();
		uint ei = block_eps_index(pc.layer, bl, blocks);
		vec4 eps = vec4(rec[ei], rec[ei + 1u], rec[ei + 2u], rec[ei + 3u]);
		// eps_0 for the strips against full resolution: at the finest level 0 where D is taken
		// against every diagonal (the finest surface is one of them), half the twist where
		// it is taken against one (fine_edge_level_1: rows 0 and 1); above it, E0(P).
		float e0 = pc.finest != 0 ? 0.0 : pc.e0;
		vec4 charge = strip_charges(eps, e0, pc.q2);
		float e0_2 = pc.finest != 0 ? max(pc.q2 * row_eps_0(), pc.q2 * row_eps_1()) : pc.e0;
		vec3 fine = fine_charges(eps, e0_2, e0, pc.q2);
		rec[base + 0u] = charge.x;
		rec[base + 1u] = charge.y;
		rec[base + 2u] = charge.z;
		rec[base + 3u] = charge.w;
		rec[base + 4u] = fine.x;
		rec[base + 5u] = fine.y;
		rec[base + 6u] = fine.z;
		rec[base + 7u] = 0.0;
	}
}
