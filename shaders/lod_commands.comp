#version 450
// Cuts the drawn patches' quad-patch instances into indirect draw records of at most
// per_draw instances each (the lavapipe bound on tessellated vertices per draw), writes
// the record count for vkCmdDrawIndirectCount and the workgroup counts of lod_factors.comp
// (64 quads per group) and lod_borders.comp (64 border items per group) for
// vkCmdDispatchIndirect.
layout(local_size_x = 64) in;

struct DrawCmd { uint vertex_count, instance_count, first_vertex, first_instance; };
layout(std430, binding = 5) buffer Counters {
	uint drawn; uint draws; uint wants; uint curtains;
	uvec4 factor_groups, border_groups;
} counters;
layout(std430, binding = 8) writeonly buffer Cmds { DrawCmd cmds[]; };

layout(push_constant) uniform Push {
	uint per_patch; // block quads per drawn patch (blocks^2)
	uint blocks;    // curtain quads per curtain
	uint per_draw;  // quad patches per draw record
	uint max_draws;
} pc;

void main()
{
	uint total = counters.drawn * pc.per_patch + counters.curtains * pc.blocks;
	uint draws = min((total + pc.per_draw - 1u) / pc.per_draw, pc.max_draws);
	for (uint g = gl_GlobalInvocationID.x; g < draws; g += gl_WorkGroupSize.x) {
		uint first = g * pc.per_draw;
		cmds[g] = DrawCmd(4u, min(pc.per_draw, total - first), 0u, first);
	}
	if (gl_GlobalInvocationID.x == 0u) {
		counters.draws = draws;
		counters.factor_groups = uvec4((total + 63u) / 64u, 1u, 1u, 0u);
		counters.border_groups = uvec4((counters.drawn * (4u * pc.blocks + 4u) + 63u) / 64u, 1u, 1u, 0u);
	}
}
