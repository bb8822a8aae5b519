#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
// Run after lod_factors.comp, it lists the quads that draw something (factors not all 0):
// the shown list from the front of the lists buffer, and, in a frame that culls back faces,
// the clipped list (the quads that pipeline draws with back faces kept, docs/lod.md "Back
// faces"; factors[].w bit 0) from its back. Each list holds first the quads without seals,
// drawn by pipelines without the seal code, then those with (factors[].w bit 1;
// SEAL_CODE in terrain_draw.glsl), each part in quad order, so the draws keep the order of
// the quads from frame to frame. Quads that draw nothing (unseen blocks, blocks without
// data, curtains inside the terrain) then cost no vertex or control shader. Each part is
// cut into indirect draw records of at most per_draw quads (the lavapipe bound on
// tessellated vertices per draw), at cmds[0], [max_draws], [2 max_draws] and
// [3 max_draws] for the shown list's two parts and the clipped list's: the shown parts
// counted in draws / draw_sealed[3] and in draw_split[0] / draw_sealed[0] (culling
// pipeline) or [1] (the other), the clipped parts in draw_split[2] / draw_sealed[2]; the
// clipped quads in draw_split[3], the sealed ones in sealed_quads. One workgroup.
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

// Per lane, its run's quads of each kind (shown without seals, shown with, clipped without,
// clipped with), then where its run's go in each part, and the parts' totals.
shared uvec4 s_counts[64];
shared uvec4 s_total;

// Records at cmds[at ..] for `total` quads from position `first` of a list, per_draw each;
// returns how many.
uint write_records(uint at, uint first, uint total)
{
	uint draws = min((total + pc.per_draw - 1u) / pc.per_draw, pc.max_draws);
	for (uint g = gl_GlobalInvocationID.x; g < draws; g += gl_WorkGroupSize.x) {
		uint q = g * pc.per_draw;
		// The first quad goes in first_vertex (4 per quad), not first_instance: a non-zero
		// first_instance needs the optional drawIndirectFirstInstance feature.
		cmds[at + g] = DrawCmd(4u, min(pc.per_draw, total - q), 4u * (first + q), 0u);
	}
	return draws;
}

// Each lane takes a run of consecutive quads, counts what each part gets from it, then
// writes its quads after those of the runs before it. The shown list holds its quads
// without seals, then those with; the clipped list likewise from the back.
void lists_write(uint total)
{
	uint lane = gl_LocalInvocationIndex, per = (total + 63u) / 64u;
	uint q0 = min(lane * per, total), q1 = min(q0 + per, total);
	uvec4 n = uvec4(0u);
	for (uint q = q0; q < q1; q++) {
		uvec4 f = texelFetch(factor_texels, int(q));
		uint k = f.w & 3u; // bit 0 clipped, bit 1 sealed
		if (f.x != 0u) // the parts in list order: shown, shown sealed, clipped, clipped sealed
			n += uvec4(k == 0u ? 1u : 0u, k == 2u ? 1u : 0u, k == 1u ? 1u : 0u, k == 3u ? 1u : 0u);
	}
	s_counts[lane] = n;
	barrier();
	// The exclusive prefix sums by one lane: a CPU implementation runs a loop in every lane
	// (64 x 64 shared loads) however few lanes need it, and this took three quarters of the
	// pass on lavapipe (docs/lod-performance.md, "The draw camera and the per-patch tables
	// read as texels").
	if (lane == 0u) {
		uvec4 sum = uvec4(0u);
		for (uint j = 0u; j < 64u; j++) {
			uvec4 c = s_counts[j];
			s_counts[j] = sum;
			sum += c;
		}
		s_total = sum;
	}
	barrier();
	uvec4 at = s_counts[lane], all = s_total;
	uint back = uint(lists.length()) - 1u;
	for (uint q = q0; q < q1; q++) {
		uvec4 f = texelFetch(factor_texels, int(q));
		if (f.x == 0u)
			continue;
		switch (f.w & 3u) {
		case 0u: lists[at.x++] = q; break;
		case 2u: lists[all.x + at.y++] = q; break;
		case 1u: lists[back - at.z++] = q; break;
		default: lists[back - (all.z + at.w++)] = q; break;
		}
	}
	uint d = pc.max_draws;
	uint shown = write_records(0u, 0u, all.x), shown_sealed = write_records(d, all.x, all.y);
	uint clipped = write_records(2u * d, 0u, all.z), clipped_sealed = write_records(3u * d, all.z, all.w);
	if (lane == 0u) {
		bool cull = counters.face_culled != 0u;
		counters.draws = shown;
		counters.draw_split = uvec4(cull ? shown : 0u, cull ? 0u : shown, clipped, all.z + all.w);
		counters.draw_sealed = uvec4(cull ? shown_sealed : 0u, cull ? 0u : shown_sealed, clipped_sealed, shown_sealed);
		counters.sealed_quads = all.y + all.w;
	}
}

void main()
{
	lists_write(counters.drawn * pc.per_patch + counters.curtains * pc.blocks);
}
