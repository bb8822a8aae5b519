#version 450
#extension GL_GOOGLE_include_directive : require
#include "grid_common.glsl"
layout(vertices = 4) out;
layout(location = 0) in vec2 in_grid[];
layout(location = 0) out vec2 out_grid[];
void main()
{
	out_grid[gl_InvocationID] = in_grid[gl_InvocationID];
	if (gl_InvocationID == 0) {
		float f = pc.grid.z;
		gl_TessLevelOuter[0] = f;
		gl_TessLevelOuter[1] = f;
		gl_TessLevelOuter[2] = f;
		gl_TessLevelOuter[3] = f;
		gl_TessLevelInner[0] = f;
		gl_TessLevelInner[1] = f;
	}
}
