#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
// Run after lod_factors.comp, it lists the quads that draw something (factors not all 0):
// the shown list from the front of the lists buffer, and, in a frame that culls back faces,
// the clipped list (the quads that pipeline draws with back faces kept, docs/lod.md "Back
// faces"; factors[].w = 1) from its back, both in quad order, so the draws keep the order of
// the quads from frame to frame. Quads that draw nothing (unseen blocks, blocks without
// data, curtains inside the terrain) then cost no vertex or control shader. Each list is
// cut into indirect draw records of at most per_draw quads (the lavapipe bound on
// tessellated vertices per draw): the shown list's from cmds[0], counted in draws and in
// draw_split[0] (culling pipeline) or [1] (the other), the clipped list's from
// cmds[max_draws], counted in draw_split[2], its quads in draw_split[3]. One workgroup.
// (Until the thirty-second December 2026 session a first phase, before the factors, decided
// about back faces and sized the factor and border passes: the selection and
// lod_borders.comp do that now, one dispatch and barrier fewer: lod_eye.glsl.)
layout(local_size_x = 64) in;

struct DrawCmd { uint vertex_count, instance_count, first_vertex, first_instance; };
#include "lod_counters.glsl"
layout(std430, binding = 8) writeonly buffer Cmds { DrawCmd cmds[]; };

layout(push_constant) uniform Push {
	uint per_patch; // block quads per drawn patch (blocks^2)
	uint blocks;    // curtain quads per curtain
	uint per_draw;  // quad patches per draw record
	uint max_draws;
} pc;
// lod_factors.comp's factors (binding 13) as RGBA32_UINT texels (terrain_internal.h says why).
layout(binding = 26) uniform usamplerBuffer factor_texels;
layout(std430, binding = 19) writeonly buffer Lists { uint lists[]; };

// Per lane, its run's shown and clipped quads, then where its run's go in each list, and
// their totals.
shared uvec2 s_counts[64];
shared uvec2 s_total;

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

// Each lane takes a run of consecutive quads, counts what each list gets from it, then
// writes its quads after those of the runs before it.
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
	// pass on lavapipe (docs/lod-performance.md, "The draw camera and the per-patch tables
	// read as texels").
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
	lists_write(counters.drawn * pc.per_patch + counters.curtains * pc.blocks);
}
