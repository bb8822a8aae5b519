#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
// Forced splits, a pre-pass of the selection for trees of 7 levels or more (common/lod.c,
// forced_split(), is the CPU reference). A border block edge can take every block
// corner of a patch up to 4 levels finer drawn across it (16 segments, terrain_seal.glsl);
// a patch 5 or more levels finer leaves T-junctions that the rasteriser opens (docs/lod.md,
// known issues). So a patch P of level l <= L - 6 is made to split when, beside one of its
// sides, a chain of patches of levels l .. l + 4 along that border each wants to split by
// the usual rule (the one of level l + 4 splitting puts level l + 5 there). Culling and
// residency are ignored: more splits than needed, never fewer. One invocation per patch of
// levels 1 .. L - 6 (the root borders nothing); it sets bit 1 of P's split state, which the
// selection reads as "wants to split". Exact for up to 10 levels: beyond, a forced split
// could force another patch 4 levels coarser still, which this single pass does not see.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Info { PatchInfo info[]; };
layout(std430, binding = 2) buffer SplitPrev { uint split_prev[]; }; // bit 0 read, bit 1 set here

#include "lod_select_common.glsl"

// Patch (l, x, y) wants to split by the usual rule (its own hysteresis bit only).
bool wants(uint l, uint x, uint y)
{
	uint id = first_id(l) + y * (1u << l) + x;
	vec3 bmin, bmax;
	box(l, x, y, id, bmin, bmax);
	return wants_split_by(l, id, distance_to(bmin, bmax), split_prev[id] & 1u);
}

void main()
{
	uint id = gl_GlobalInvocationID.x + 1u; // level 1 onwards
	if (pc.levels < 7u || id >= first_id(pc.levels - 5u))
		return;
	uint l = 1u;
	while (first_id(l + 1u) <= id)
		l++;
	uint side_n = 1u << l, local = id - first_id(l);
	ivec2 p = ivec2(local % side_n, local / side_n);
	const ivec2 dirs[4] = ivec2[4](ivec2(0, -1), ivec2(0, 1), ivec2(-1, 0), ivec2(1, 0)); // north, south, west, east
	for (uint s = 0u; s < 4u; s++) {
		ivec2 q = p + dirs[s];
		if (q.x < 0 || q.y < 0 || q.x >= int(side_n) || q.y >= int(side_n))
			continue;
		// Bit i of `chain`: the i-th patch of level l + k along the border (in q's
		// subtree, on its side facing p) and every one above it in the chain want to split.
		uint chain = wants(l, uint(q.x), uint(q.y)) ? 1u : 0u;
		for (uint k = 1u; k <= 4u && chain != 0u; k++) {
			uint m = 1u << k, next = 0u;
			for (uint i = 0u; i < m; i++) {
				if ((chain & (1u << (i >> 1u))) == 0u)
					continue;
				ivec2 c = facing_cell(q, int(m), s, int(i));
				if (wants(l + k, uint(c.x), uint(c.y)))
					next |= 1u << i;
			}
			chain = next;
		}
		if (chain != 0u) {
			atomicOr(split_prev[id], 2u);
			return;
		}
	}
}
