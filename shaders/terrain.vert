#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
// No vertex buffer. Entry n of a list of quads (lod_commands.comp: the shown list from the
// front of the lists buffer, the clipped list, MODE_CLIPPED_LIST, from its back) is
// instance gl_InstanceIndex of the draw record whose first_vertex is 4 x its first entry;
// vertex v (gl_VertexIndex mod 4) is a corner. The entry is the quad's index i (quad_of():
// the drawn patches' blocks, then the terrain-edge curtains), at which lod_factors.comp
// computed its factors.
// The lists (binding 19) as R32_UINT texels (terrain_internal.h says why).
layout(binding = 28) uniform usamplerBuffer list_texels;
layout(location = 0) out flat uint out_slot;
layout(location = 1) out flat uint out_quad;
layout(location = 2) out vec2 out_s;         // sample coordinates in the patch
layout(location = 3) out float out_down;     // 1 at the bottom of a skirt
void main()
{
	uint n = uint(gl_VertexIndex) / 4u + uint(gl_InstanceIndex), k;
	uint i = texelFetch(list_texels, int((pc.mode & MODE_CLIPPED_LIST) != 0u ? uint(textureSize(list_texels)) - 1u - n : n)).x;
	quad_of(i, out_slot, k);
	out_quad = i;
	out_s = quad_corner(k, uint(gl_VertexIndex) & 3u, out_down);
	gl_Position = vec4(0.0);
}
