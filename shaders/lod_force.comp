#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
// Forced splits, a pre-pass of the selection (common/lod.c, force_splits(), is the CPU
// reference). A patch P of level l is made to split for either of two reasons found beside
// one of its sides, along a chain of patches of levels l + 1 .. l + 4 in the neighbour's
// subtree along that border, each there because the one above it wants to split by the
// usual rule or is itself forced:
// - Five levels: the chain reaches level l + 4 and a patch there wants to split. A border
//   block edge can take every block corner of a patch up to 4 levels finer drawn across it
//   (16 segments, terrain_seal.glsl); a patch 5 or more levels finer leaves T-junctions
//   that the rasteriser opens (docs/lod.md, known issues). Trees of 7 levels or more.
// - The finer border: a resident patch F of level l + k in the chain, not wanting to split
//   by its own error (so drawn where it is resident, unless forced), whose border facing P,
//   drawn in segments of 2^k of its samples (what the seal gives it where P's block edge
//   has all 16 of its segments), is not within tau: its border charge at level k (the
//   largest over its border blocks of eps_k and the charge of a transition strip from that
//   edge to any finer interior, edge_charges_in()) projects beyond tau from F's box,
//   measured as the selection measures a patch (error kappa over the distance to the box,
//   the whole of tau, not its coarse share). Without it such a border's strips were
//   bounded by nothing that knew of tau, and one was 2.19 tau off (docs/lod.md, "Between
//   patches"). F's own wish ignores its forced bit, so that the rule only grows with the
//   forced set (below); a forced F is still looked at: more splits than needed, never
//   fewer. A patch P that wants to split anyway is not looked at: forcing it would change
//   nothing.
//   Only for relief's fine LOD with its strips bounded (pc.level, terrain_frame.c): the
//   baselines' selections and a view with loose_transitions go without it.
// Culling is ignored: more splits than needed, never fewer. It sets bit 1 of P's split
// state, which the selection reads as "wants to split".
//
// A forced split counts in other patches' chains: forcing P puts level l + 1 beside
// patches of level l and finer, which may then need forcing too. The pass sweeps the
// patches of levels 1 .. L - 2 until a sweep forces nothing more. Both rules only grow
// with the set of patches that want to split, so the result is the least fixed point
// whatever order the invocations run in, the set the CPU twin reaches. One workgroup, so
// that a barrier ends each sweep; a sweep that forces nothing ends it. Patches without an
// entry (EMPTY, outside their level's window) neither want to split nor are forced:
// nothing is drawn there.
layout(local_size_x = 256) in;

// Bit 0 read; bit 1 set here and read by the other invocations within the sweep after it.
layout(std430, binding = 2) coherent buffer SplitPrev { uint split_prev[]; };

#include "lod_select_common.glsl"
#include "terrain_texels.glsl"

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

// The border charge at level k of the patch resident in `layer` along its side `side`,
// projected from its box at distance d: pixels, as the selection's error.
float border_px(int layer, uint side, uint k, float d)
{
	uint blocks = (pc.P - 1u) / BLOCK_CELLS, edge = edge_of_side(side);
	float charge = 0.0;
	for (uint a = 0u; a < blocks; a++) {
		ivec2 bl = border_block_in(side, int(a), blocks);
		charge = max(charge, edge_charges_in(layer, bl, edge, blocks, block_eps_in(layer, bl, blocks))[k - 1u]);
	}
	if (!(charge > 0.0))
		return 0.0; // a border drawn exactly at any level: nothing to project
	precise float px = d > 0.0 ? charge * pc.kappa / d : 1.0 / 0.0;
	return px;
}

// Whether the patch of entry e (level 1 .. L - 2) must split: a chain beside one of its
// sides that ends five levels down or holds a finer border beyond tau.
bool chain_beside(uint e)
{
	uint l = 1u;
	while (window_at(l + 1u).z <= e)
		l++;
	uint side_n = 1u << l, local = e - window_at(l).z;
	ivec2 p = ivec2(local % window_at(l).x, local / window_at(l).x);
	if (wants(l, uint(p.x), uint(p.y)))
		return false; // it splits anyway
	precise float tau = pc.tau / COARSE_SHARE;
	bool border_rule = pc.level != 0u; // relief's own fine LOD with bounded strips (terrain_frame.c)
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
				uint ce = entry_at(l + k, c);
				if (ce == NO_ENTRY)
					continue;
				vec3 bmin, bmax;
				box(l + k, uint(c.x), uint(c.y), ce, bmin, bmax);
				float d = distance_to(bmin, bmax);
				int layer = layer_at(ce);
				// Its own wish (bit 0 alone) for the border rule, the chain's with bit 1.
				if (border_rule && layer >= 0 && !wants_split_by(l + k, ce, d, split_prev[ce] & 1u) &&
				    border_px(layer, s ^ 1u, k, d) > tau)
					return true;
				if (wants_split_by(l + k, ce, d, split_prev[ce]))
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
	if (pc.levels < 3u)
		return;
	uint end = window_at(pc.levels - 1u).z; // entries of levels 1 .. L - 2 from window_at(1).z
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
