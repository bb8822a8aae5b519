#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
#include "terrain_factors.glsl"
#include "terrain_seal.glsl"
#include "lod_counters.glsl"
#include "lod_eye.glsl"
// The border work of the factor pass, apart: for every drawn patch, each block edge on its
// border (4 x blocks) and each of its corners (4), one invocation. An edge gets the outer
// factor the patch draws it with (matched to a coarser patch across, or at least 2^j
// segments for a patch j levels finer, terrain_seal.glsl) and its seal record; a corner
// the height sealed_height() gives there. lod_factors.comp reads them. Apart, because a
// CPU implementation (lavapipe) runs a shader's searches, masked, for every lane: in the
// factor pass they cost every quad, here only the border's.
// Its first invocation also decides whether back faces are culled (lod_eye.glsl) and sizes
// the factor pass (64 quads a group), which runs after it.
layout(local_size_x = 64) in;

layout(std430, binding = 17) writeonly buffer Borders { uvec2 borders[]; };

void main()
{
	uint per = border_items(pc.blocks), i = gl_GlobalInvocationID.x, slot = i / per, r = i % per;
	if (i == 0u) {
		eye_decide();
		counters.factor_groups = uvec4((counted_quads() + 63u) / 64u, 1u, 1u, 0u);
	}
	if (slot >= counted_patches())
		return;
	Instance it = inst_at(slot);
	int last = int(pc.P) - 1;
	if (r < 4u * pc.blocks) {
		uint side = r / pc.blocks; // 0 north, 1 south, 2 west, 3 east
		ivec2 bl = border_block(side, int(r % pc.blocks));
		float fc;
		int clayer;
		uint cmorph, morph = MORPH_FULL; // sealed: the vertices are the coarser patch's
		uint j = coarser_edge(it, bl, side, fc, clayer, cmorph);
		float f = j != 0u ? max(1.0, fc / float(1u << j)) : drawn_border_factor(it, bl, side, morph);
		borders[i] = uvec2(uint(f) | (morph << 8u), seal_side(j, fc, clayer, cmorph));
	} else {
		uint c = r - 4u * pc.blocks; // bit 0 east, bit 1 south
		float hs;
		bool sealed = sealed_height(it, ivec2((c & 1u) != 0u ? last : 0, (c & 2u) != 0u ? last : 0), hs);
		borders[i] = uvec2(floatBitsToUint(hs), sealed ? 1u : 0u);
	}
}
