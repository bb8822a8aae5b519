#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
// Cuts the drawn patches' quad-patch instances into indirect draw records of at most
// per_draw instances each (the lavapipe bound on tessellated vertices per draw), writes
// the record count for vkCmdDrawIndirectCount and the workgroup counts of lod_factors.comp
// (64 quads per group) and lod_borders.comp (64 border items per group) for
// vkCmdDispatchIndirect.
//
// And decides whether back faces are culled (docs/lod.md, "Back faces"): the drawing
// camera must be above the surface drawn under it. That surface, at the eye's x, y, is a
// triangle of the drawn block b containing the point, with vertices among b's samples,
// blends of them, or a coarser patch's samples on b's border, which lie in that patch's
// block touching b. Every drawn block within its own side of the eye (Chebyshev distance)
// includes b and those coarser blocks (each at least b's side), so the largest height
// range over them bounds the surface there. If no drawn block holds the eye (the patch
// under it is outside the frustum), the CPU's conservative decision stands (cpu_cull).
// The record count goes to draw_split[0] (culled pipeline) or [1] (back faces drawn).
//
// Run again after lod_factors.comp (phase 1), it cuts the clipped list (the quads that
// pipeline draws with back faces kept, docs/lod.md "Back faces") into records of its own,
// after the first max_draws, and counts them in draw_split[2].
layout(local_size_x = 64) in;

struct DrawCmd { uint vertex_count, instance_count, first_vertex, first_instance; };
layout(std430, binding = 4) readonly buffer Instances { Instance inst[]; };
layout(std430, binding = 5) buffer Counters {
	uint drawn; uint draws; uint wants; uint curtains;
	uvec4 factor_groups, border_groups;
	uint face_culled; uint found; float near_high; uint draw_culled;
	uvec4 draw_split;
} counters;
layout(std430, binding = 8) writeonly buffer Cmds { DrawCmd cmds[]; };
layout(std430, binding = 11) readonly buffer Errors { float block_err[]; };
layout(std430, binding = 15) readonly buffer DrawCamera { mat4 draw_vp; vec4 draw_eye; };

layout(push_constant) uniform Push {
	uint per_patch; // block quads per drawn patch (blocks^2)
	uint blocks;    // curtain quads per curtain
	uint per_draw;  // quad patches per draw record
	uint max_draws;
	uint cpu_cull;  // the CPU's decision (relief_surface_height_bound()), used when no block holds the eye
	float margin;   // metres above the bound for culling (FACE_CULL_MARGIN)
	uint gpu_decides; // this decision splits the draws; else cpu_cull is the one drawn with
	uint phase;     // 0: the frame's records and the decision; 1: the clipped list's records
} pc;
layout(std430, binding = 19) readonly buffer Clipped { uint clipped_count; uint clipped[]; };

shared uint s_high; // largest block height near the eye, as an ordered key (height_key)
shared uint s_found;

// Float bits as an unsigned key that orders like the floats (for atomicMax).
uint height_key(float h)
{
	uint b = floatBitsToUint(h);
	return (b & 0x80000000u) != 0u ? ~b : b | 0x80000000u;
}

float key_height(uint k) { return uintBitsToFloat((k & 0x80000000u) != 0u ? k & 0x7fffffffu : ~k); }

// Drawn patch it's blocks within their own side of the eye: their largest height range
// goes to s_high, and whether one holds the eye (within half a finest cell) to s_found.
void blocks_near_eye(Instance it, vec2 eye)
{
	// Positions relative to the LOD camera, x east, y south (rows), metres.
	vec2 side = it.spacing * float(it.scale * int(BLOCK_CELLS));
	vec2 origin = (vec2(it.base) - it.frac) * it.spacing;
	vec2 f = (eye - origin) / side; // the eye in block units of this patch
	if (any(lessThan(f, vec2(-1.0))) || any(greaterThan(f, vec2(float(pc.blocks) + 1.0))))
		return;
	ivec2 c = ivec2(floor(f));
	for (int by = c.y - 2; by <= c.y + 2; by++)
		for (int bx = c.x - 2; bx <= c.x + 2; bx++) {
			if (bx < 0 || by < 0 || bx >= int(pc.blocks) || by >= int(pc.blocks))
				continue;
			vec2 lo = origin + vec2(bx, by) * side, hi = lo + side;
			vec2 d = max(max(lo - eye, eye - hi), vec2(0.0));
			if (max(d.x, d.y) > max(side.x, side.y))
				continue;
			atomicMax(s_high, height_key(block_err[block_range_index(it.layer, ivec2(bx, by), pc.blocks) + 1u]));
			if (all(lessThanEqual(d, 0.5 * it.spacing)))
				atomicOr(s_found, 1u);
		}
}

// Records at cmds[at ..] of `total` quads, per_draw each; returns how many.
uint write_records(uint at, uint total)
{
	uint draws = min((total + pc.per_draw - 1u) / pc.per_draw, pc.max_draws);
	for (uint g = gl_GlobalInvocationID.x; g < draws; g += gl_WorkGroupSize.x) {
		uint first = g * pc.per_draw;
		// The first quad goes in first_vertex (4 per quad), not first_instance: a non-zero
		// first_instance needs the optional drawIndirectFirstInstance feature.
		cmds[at + g] = DrawCmd(4u, min(pc.per_draw, total - first), 4u * first, 0u);
	}
	return draws;
}

void main()
{
	if (pc.phase == 1u) {
		uint draws = write_records(pc.max_draws, clipped_count);
		if (gl_LocalInvocationIndex == 0u)
			counters.draw_split.zw = uvec2(draws, clipped_count);
		return;
	}
	uint total = counters.drawn * pc.per_patch + counters.curtains * pc.blocks;
	uint draws = write_records(0u, total);
	if (gl_LocalInvocationIndex == 0u) {
		s_high = 0u;
		s_found = 0u;
	}
	barrier();
	vec2 eye = vec2(draw_eye.x, -draw_eye.y);
	for (uint i = gl_LocalInvocationIndex; i < counters.drawn; i += gl_WorkGroupSize.x)
		blocks_near_eye(inst[i], eye);
	barrier();
	if (gl_LocalInvocationIndex == 0u) {
		bool cull = s_found != 0u ? draw_eye.z > key_height(s_high) + pc.margin : pc.cpu_cull != 0u;
		counters.draws = draws;
		counters.face_culled = cull ? 1u : 0u;
		counters.found = s_found;
		counters.near_high = key_height(s_high);
		counters.draw_culled = (pc.gpu_decides != 0u ? cull : pc.cpu_cull != 0u) ? 1u : 0u;
		counters.draw_split = uvec4(cull ? draws : 0u, cull ? 0u : draws, 0u, 0u);
		counters.factor_groups = uvec4((total + 63u) / 64u, 1u, 1u, 0u);
		counters.border_groups = uvec4((counters.drawn * (4u * pc.blocks + 4u) + 63u) / 64u, 1u, 1u, 0u);
	}
}
