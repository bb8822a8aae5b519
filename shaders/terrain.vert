#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "terrain_draw.glsl"
// No vertex buffer. Instance i is quad patch (i mod per_patch) of drawn patch (i div
// per_patch) (quad_corner() has the layout); vertex v is a corner. The quad's factors were
// computed by lod_factors.comp at index i.
layout(location = 0) out flat uint out_slot;
layout(location = 1) out flat uint out_quad;
layout(location = 2) out vec2 out_s;         // sample coordinates in the patch
layout(location = 3) out float out_down;     // 1 at the bottom of a skirt
void main()
{
	uint i = uint(gl_InstanceIndex);
	out_slot = i / pc.per_patch;
	out_quad = i;
	out_s = quad_corner(i % pc.per_patch, uint(gl_VertexIndex), out_down);
	gl_Position = vec4(0.0);
}
