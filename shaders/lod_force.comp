#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
// Forced splits, a pre-pass of the selection for trees of 7 levels or more (common/lod.c,
// force_splits(), is the CPU reference). A border block edge can take every block
// corner of a patch up to 4 levels finer drawn across it (16 segments, terrain_seal.glsl);
// a patch 5 or more levels finer leaves T-junctions that the rasteriser opens (docs/lod.md,
// known issues). So a patch P of level l <= L - 6 is made to split when, beside one of its
// sides, a chain of patches of levels l .. l + 4 along that border each wants to split by
// the usual rule or is itself forced (the one of level l + 4 splitting puts level l + 5
// there). Culling and residency are ignored: more splits than needed, never fewer. It sets
// bit 1 of P's split state, which the selection reads as "wants to split".
//
// A forced split counts in other patches' chains: forcing P at level l >= 5 puts level
// l + 1 beside patches of level l - 4, which may then need forcing too. In general a chain
// through a patch that is forced without wanting to split runs on through its descendants,
// which then want to split only if they are forced themselves or if their error exceeds
// their ancestor's (Err(P) is measured against the original, not made monotone), so with
// monotone errors a cascade needs the chain's last link, 4 levels below the patch forced,
// at level <= L - 6: 11 levels or more. The pass does not rely on that: it sweeps the
// patches of levels 1 .. L - 6 until a sweep forces nothing more. Forcing only adds
// splits, so the result is the least fixed point whatever order the invocations run in,
// the set the CPU twin reaches. One workgroup, so that a barrier ends each sweep (levels
// 1 .. L - 6 have at most 4, 20, 84, 340, 1,364 entries for 7 .. 11 levels); a sweep that
// forces nothing ends it: one sweep when nothing is forced, two without a cascade. Patches
// without an entry (EMPTY, outside their level's window) neither want to split nor are
// forced: nothing is drawn there.
layout(local_size_x = 256) in;

// Bit 0 read; bit 1 set here and read by the other invocations within the sweep after it.
layout(std430, binding = 2) coherent buffer SplitPrev { uint split_prev[]; };

#include "lod_select_common.glsl"

shared uint forced_now;

// Patch (l, x, y) wants to split by the usual rule (with its hysteresis bit) or is forced.
bool wants(uint l, uint x, uint y)
{
	uint e = entry_at(l, ivec2(x, y));
	if (e == NO_ENTRY)
		return false;
	vec3 bmin, bmax;
	box(l, x, y, e, bmin, bmax);
	return wants_split_by(l, e, distance_to(bmin, bmax), split_prev[e]);
}

// Whether the patch of entry e (level 1 .. L - 6) must split: a chain beside one of its
// sides.
bool chain_beside(uint e)
{
	uint l = 1u;
	while (window_at(l + 1u).z <= e)
		l++;
	uint side_n = 1u << l, local = e - window_at(l).z;
	ivec2 p = ivec2(local % window_at(l).x, local / window_at(l).x);
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
		if (chain != 0u)
			return true;
	}
	return false;
}

void main()
{
	if (pc.levels < 7u)
		return;
	uint end = window_at(pc.levels - 5u).z; // entries of levels 1 .. L - 6 from window_at(1).z
	for (;;) {
		if (gl_LocalInvocationIndex == 0u)
			forced_now = 0u;
		barrier();
		for (uint e = 1u + gl_LocalInvocationIndex; e < end; e += gl_WorkGroupSize.x)
			if ((split_prev[e] & 2u) == 0u && chain_beside(e)) {
				atomicOr(split_prev[e], 2u);
				atomicAdd(forced_now, 1u);
			}
		memoryBarrierBuffer();
		memoryBarrierShared();
		barrier();
		bool done = forced_now == 0u;
		barrier(); // every invocation has read forced_now before the next sweep clears it
		if (done)
			break;
	}
}
