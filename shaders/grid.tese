#version 450
#extension GL_GOOGLE_include_directive : require
#include "grid_common.glsl"
layout(quads, equal_spacing, ccw) in;
layout(location = 0) in vec2 in_grid[];
layout(location = 0) out float out_height;
layout(location = 1) out vec3 out_normal;
void main()
{
	// Corners: 0 = (0,0), 1 = (1,0), 2 = (0,1), 3 = (1,1) in patch space.
	vec2 g = mix(mix(in_grid[0], in_grid[1], gl_TessCoord.x),
	             mix(in_grid[2], in_grid[3], gl_TessCoord.x), gl_TessCoord.y);
	float size = pc.grid.y, amp = pc.grid.w;
	float h = grid_height(g);
	vec2 grad = grid_height_gradient(g) * amp / size;
	out_height = h;
	out_normal = normalize(vec3(-grad, 1.0));
	gl_Position = pc.mvp * vec4(g * size, h * amp, 1.0);
}
