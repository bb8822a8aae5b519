#version 450
#extension GL_GOOGLE_include_directive : require
#include "grid_common.glsl"
// No vertex buffer: instance i is patch (i mod n, i div n); vertex v is its corner.
layout(location = 0) out vec2 out_grid;
void main()
{
	int n = int(pc.grid.x);
	ivec2 patch_id = ivec2(gl_InstanceIndex % n, gl_InstanceIndex / n);
	ivec2 corner = ivec2(gl_VertexIndex & 1, gl_VertexIndex >> 1);
	out_grid = vec2(patch_id + corner) / float(n);
	gl_Position = vec4(0.0);
}
