#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
// Run before lod_factors.comp (phase 0), writes the workgroup counts of lod_factors.comp
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
//
// Run again after lod_factors.comp (phase 1), it lists the quads that draw something
// (factors not all 0): the shown list from the front of the lists buffer, and, in a frame
// that culls back faces, the clipped list (the quads that pipeline draws with back faces
// kept, docs/lod.md "Back faces"; factors[].w = 1) from its back, both in quad order, so the
// draws keep the order of the quads from frame to frame. Quads that draw nothing (unseen
// blocks, blocks without data, curtains inside the terrain) then cost no vertex or control
// shader. Each list is cut into indirect draw records of at most per_draw quads (the
// lavapipe bound on tessellated vertices per draw): the shown list's from cmds[0], counted
// in draws and in draw_split[0] (culling pipeline) or [1] (the other), the clipped list's
// from cmds[max_draws], counted in draw_split[2], its quads in draw_split[3].
layout(local_size_x = 64) in;

struct DrawCmd { uint vertex_count, instance_count, first_vertex, first_instance; };
layout(std430, binding = 5) buffer Counters {
	uint drawn; uint draws; uint wants; uint curtains;
	uvec4 factor_groups, border_groups;
	uint face_culled; uint found; float near_high; uint draw_culled;
	uvec4 draw_split;
} counters;
layout(std430, binding = 8) writeonly buffer Cmds { DrawCmd cmds[]; };
#include "terrain_texels.glsl"
#include "draw_camera.glsl"

layout(push_constant) uniform Push {
	uint per_patch; // block quads per drawn patch (blocks^2)
	uint blocks;    // curtain quads per curtain
	uint per_draw;  // quad patches per draw record
	uint max_draws;
	uint cpu_cull;  // the CPU's decision (relief_surface_height_bound()), used when no block holds the eye
	float margin;   // metres above the bound for culling (FACE_CULL_MARGIN)
	uint gpu_decides; // this decision splits the draws; else cpu_cull is the one drawn with
	uint phase;     // 0: the decision and the factor pass's size; 1: the lists and their records
} pc;
// lod_factors.comp's factors (binding 13) as RGBA32_UINT texels (terrain_internal.h says why).
layout(binding = 26) uniform usamplerBuffer factor_texels;
layout(std430, binding = 19) writeonly buffer Lists { uint lists[]; };

shared uint s_high; // largest block height near the eye, as an ordered key (height_key)
shared uint s_found;
// Per lane, its run's shown and clipped quads, then where its run's go in each list, and
// their totals (phase 1).
shared uvec2 s_counts[64];
shared uvec2 s_total;

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
			atomicMax(s_high, height_key(block_err(block_range_index(it.layer, ivec2(bx, by), pc.blocks) + 1u)));
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

// Phase 1, one workgroup: each lane takes a run of consecutive quads, counts what each list
// gets from it, then writes its quads after those of the runs before it.
void lists_write(uint total)
{
	uint lane = gl_LocalInvocationIndex, per = (total + 63u) / 64u;
	uint q0 = min(lane * per, total), q1 = min(q0 + per, total);
	uvec2 n = uvec2(0u);
	for (uint q = q0; q < q1; q++) {
		uvec4 f = texelFetch(factor_texels, int(q));
		if (f.x != 0u)
			n += f.w != 0u ? uvec2(0u, 1u) : uvec2(1u, 0u);
	}
	s_counts[lane] = n;
	barrier();
	// The exclusive prefix sums by one lane: a CPU implementation runs a loop in every lane
	// (64 x 64 shared loads) however few lanes need it, and this took three quarters of the
	// pass on lavapipe (docs/lod.md, "The draw camera and the per-patch tables read as texels").
	if (lane == 0u) {
		uvec2 sum = uvec2(0u);
		for (uint j = 0u; j < 64u; j++) {
			uvec2 c = s_counts[j];
			s_counts[j] = sum;
			sum += c;
		}
		s_total = sum;
	}
	barrier();
	uvec2 at = s_counts[lane], all = s_total;
	uint back = uint(lists.length()) - 1u;
	for (uint q = q0; q < q1; q++) {
		uvec4 f = texelFetch(factor_texels, int(q));
		if (f.x == 0u)
			continue;
		if (f.w != 0u)
			lists[back - at.y++] = q;
		else
			lists[at.x++] = q;
	}
	uint draws = write_records(0u, all.x), clipped_draws = write_records(pc.max_draws, all.y);
	if (lane == 0u) {
		bool cull = counters.face_culled != 0u;
		counters.draws = draws;
		counters.draw_split = uvec4(cull ? draws : 0u, cull ? 0u : draws, clipped_draws, all.y);
	}
}

void main()
{
	uint total = counters.drawn * pc.per_patch + counters.curtains * pc.blocks;
	if (pc.phase == 1u) {
		lists_write(total);
		return;
	}
	if (gl_LocalInvocationIndex == 0u) {
		s_high = 0u;
		s_found = 0u;
	}
	barrier();
	vec4 draw = draw_eye();
	vec2 eye = vec2(draw.x, -draw.y);
	for (uint i = gl_LocalInvocationIndex; i < counters.drawn; i += gl_WorkGroupSize.x)
		blocks_near_eye(inst_at(i), eye);
	barrier();
	if (gl_LocalInvocationIndex == 0u) {
		bool cull = s_found != 0u ? draw.z > key_height(s_high) + pc.margin : pc.cpu_cull != 0u;
		counters.face_culled = cull ? 1u : 0u;
		counters.found = s_found;
		counters.near_high = key_height(s_high);
		counters.draw_culled = (pc.gpu_decides != 0u ? cull : pc.cpu_cull != 0u) ? 1u : 0u;
		counters.factor_groups = uvec4((total + 63u) / 64u, 1u, 1u, 0u);
		counters.border_groups = uvec4((counters.drawn * (4u * pc.blocks + 4u) + 63u) / 64u, 1u, 1u, 0u);
	}
}
