#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "terrain_draw.glsl"
// No vertex buffer. Instance i is quad patch (i mod per_patch) of drawn patch (i div
// per_patch): blocks^2 tessellation blocks of 16 x 16 cells, then 4 * blocks skirt quads
// hanging from the patch's border (north, south, west, east). Vertex v is a corner.
layout(location = 0) out flat uint out_slot;
layout(location = 1) out flat uint out_kind; // 0 block (block index), 1.. skirt: 1 + side * blocks + i
layout(location = 2) out vec2 out_s;         // sample coordinates in the patch
layout(location = 3) out float out_down;     // 1 at the bottom of a skirt
void main()
{
	uint slot = uint(gl_InstanceIndex) / pc.per_patch, k = uint(gl_InstanceIndex) % pc.per_patch;
	vec2 c = vec2(float(gl_VertexIndex & 1), float(gl_VertexIndex >> 1));
	uint b = pc.blocks;
	out_slot = slot;
	if (k < b * b) {
		out_kind = 0u;
		out_s = (vec2(float(k % b), float(k / b)) + c) * float(BLOCK_CELLS);
		out_down = 0.0;
	} else {
		uint j = k - b * b, side = j / b, i = j % b;
		float along = (float(i) + c.x) * float(BLOCK_CELLS), last = float(pc.P - 1u);
		out_s = side == 0u ? vec2(along, 0.0) : side == 1u ? vec2(along, last)
		      : side == 2u ? vec2(0.0, along) : vec2(last, along);
		out_kind = 1u + j;
		out_down = c.y;
	}
	gl_Position = vec4(0.0);
}
