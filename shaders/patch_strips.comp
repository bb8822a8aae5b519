#version 450
// Transition strip bounds of one decoded patch (docs/lod.md, "Transition triangles: what
// bounds them"). Where a block edge's factor differs from the interior's, the
// tessellator fills the strip along that edge with triangles that lie, each, in one
// column of the strip: a square Q of side c on the edge, c the larger of the edge's
// segment and the interior's cell (checked on every captured frame by test_lod_mesh).
// Such a triangle T is then within D(T) + eps_c of the finest surface, where eps_c, the
// block's stored error at Q's level, bounds either triangulation L of Q, and D(T) is the
// largest |T - L| on T, which the patch's own samples give. Per block and edge (west,
// north, east, south) this pass stores, in metres:
// [0..3] for an edge at level e = 1..4 (segments of 2^e samples) against any finer
//        interior: the largest D of any triangle such a strip can hold;
// [4..6] for an edge at level e = 0..2 against an interior one level coarser (e = 2 and an
//        inner factor of 2 is a fan from the block's centre): likewise;
// [7]    0.
// The LOD adds eps_c and projects the sum (terrain_factors.glsl). A point whose samples
// include a no-data one is left out (nothing is drawn there). Heights are read in quanta
// and differenced as integers before any rounding.
#extension GL_GOOGLE_include_directive : require
#include "block_record.glsl"

layout(local_size_x = 64) in;

layout(binding = 0, r32i) uniform readonly iimage2DArray heights;
layout(binding = 2, r32i) uniform readonly iimageBuffer staging; // texels: see patch_decode.comp

struct Job {
	int layer;
	int parent_layer, quadrant, ratio;
	uint slot, flag;
	int mode; // 2: nothing to do (warm-up)
	int P;
	uint mask; // staging int offset of the patch's validity bytes, or ~0u: all valid
	float q2;  // metres per quantum at the patch's level
	float inv_2sx, inv_2sy;
};
layout(std430, binding = 4) readonly buffer Jobs { Job jobs[]; };
layout(std430, binding = 5) writeonly buffer Records { float rec[]; };
layout(push_constant) uniform Push { uint first_job; } push;
Job pc;
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

bool sample_valid(int along, int depth)
{
	if (pc.mask == ~0u)
		return true;
	ivec2 s = at(along, depth);
	uint i = uint(s.y * pc.P + s.x);
	return ((uint(imageLoad(staging, int(pc.mask + i / 4u)).x) >> (8u * (i % 4u))) & 0xffu) != 0u;
}

// The bounds, written out term by term by shaders/strip_terms_gen.c at build time (it says
// why); what they compute, for an edge with segments of `so` samples:
//
// coarse_edge_<so>: coarse-edge strips against any finer interior: every ring vertex v
// (at depth si < so, si a power of two, every si along, inset by si at both ends) against
// each half of its column's square that touches the edge and holds v; a triangle of such
// a strip lies in one of those halves (the ring is at most so / 2 deep), where T - L is
// linear and vanishes at the edge's vertices, so |T - L| peaks at a ring vertex.
//
// fine_edge_<so>: fine-edge strips (and fans) against an interior of cells of c = 2 so:
// per column square Q of side c, the triangles joining an edge segment to a corner of Q's
// far side lie in one half of Q with only the edge's middle vertex M off it (|T - L| = its
// deviation from Q's edge); a triangle joining Q's far side (a ring segment, where the
// ring has both ends) to M crosses both diagonals, and with L the better of Q's two
// triangulations, |T - L| peaks at M or where T's edge meets L's diagonal, a third of the
// way up: (hB + 2 hM - hA - 2 hC) / 3 with the diagonal A-C, (hA + 2 hM - 2 hO - hB) / 3
// with O-B (O, C the edge's ends, A, B the far side's, A above O).
#include "strip_terms.glsl"

void main()
{
	pc = jobs[push.first_job + gl_WorkGroupID.z];
	if (pc.mode == 2)
		return;
	uint blocks = uint(pc.P - 1) / BLOCK_CELLS, items = blocks * blocks * 4u;
	for (uint i = gl_LocalInvocationID.x; i < items; i += gl_WorkGroupSize.x) {
		uint b = i / 4u;
		ivec2 bl = ivec2(b % blocks, b / blocks);
		origin = bl * int(BLOCK_CELLS);
		edge = int(i % 4u);
		uint base = block_strip_index(pc.layer, bl, uint(edge), blocks);
		strip_load();
		rec[base + 0u] = pc.q2 * coarse_edge_2();
		rec[base + 1u] = pc.q2 * coarse_edge_4();
		rec[base + 2u] = pc.q2 * coarse_edge_8();
		rec[base + 3u] = pc.q2 * coarse_edge_16();
		rec[base + 4u] = pc.q2 * fine_edge_1();
		rec[base + 5u] = pc.q2 * fine_edge_2();
		rec[base + 6u] = pc.q2 * fine_edge_4();
		rec[base + 7u] = 0.0;
	}
}
