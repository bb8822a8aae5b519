#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "terrain_draw.glsl"
#include "terrain_factors.glsl"
// Tessellation factors of every drawn quad patch of one view, once per frame, one
// invocation per quad (dispatched indirectly from the drawn count): the work the control
// shader would otherwise repeat per patch, here spread over all compute lanes. Factors are
// 0 or powers of two up to 16, stored as bytes: outer in x, inner in y.
layout(local_size_x = 64) in;

layout(std430, binding = 13) writeonly buffer Factors { uvec2 factors[]; };

void main()
{
	uint q = gl_GlobalInvocationID.x;
	if (q >= counters.drawn_count * pc.per_patch + counters.curtains * pc.blocks)
		return;
	uint slot, k;
	quad_of(q, slot, k);
	vec4 o;
	vec2 i;
	quad_factors(inst[slot], k, o, i);
	uvec4 ob = uvec4(o);
	uvec2 ib = uvec2(i);
	factors[q] = uvec2(ob.x | (ob.y << 8u) | (ob.z << 16u) | (ob.w << 24u), ib.x | (ib.y << 8u));
}
