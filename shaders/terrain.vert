#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
// No vertex buffer. Quad patch i of the frame (quad_of(): the drawn patches' blocks, then
// the terrain-edge curtains) is instance gl_InstanceIndex of the draw record whose
// first_vertex is 4 x its first quad (lod_commands.comp); vertex v (gl_VertexIndex mod 4)
// is a corner. The quad's factors were computed by lod_factors.comp at index i. The
// clipped list's draw (MODE_CLIPPED_LIST) counts through that list instead.
layout(std430, binding = 19) readonly buffer Clipped { uint clipped_count; uint clipped[]; };
layout(location = 0) out flat uint out_slot;
layout(location = 1) out flat uint out_quad;
layout(location = 2) out vec2 out_s;         // sample coordinates in the patch
layout(location = 3) out float out_down;     // 1 at the bottom of a skirt
void main()
{
	uint i = uint(gl_VertexIndex) / 4u + uint(gl_InstanceIndex), k;
	if ((pc.mode & MODE_CLIPPED_LIST) != 0u)
		i = clipped[i];
	quad_of(i, out_slot, k);
	out_quad = i;
	out_s = quad_corner(k, uint(gl_VertexIndex) & 3u, out_down);
	gl_Position = vec4(0.0);
}
