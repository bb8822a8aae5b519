#version 450
// Mesh capture (relief_terrain_view_mesh_enable()): passes every triangle the tessellator
// makes on to the rasteriser unchanged and appends its three vertices, as drawn, to the
// view's mesh buffer (terrain_mesh.tese gives them), so that the CPU can measure each
// triangle's error everywhere, not only where pixel centres fall. The count goes on past
// the capacity: the reader learns how many triangles did not fit.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(location = 1) flat in float in_q2[];
layout(location = 2) in vec2 in_s[];
layout(location = 3) flat in int in_layer[];
layout(location = 7) flat in ivec2 in_grid[];
layout(location = 8) flat in float in_height[];
layout(location = 9) flat in uint in_id[];
layout(location = 10) flat in uvec4 in_quad[];
layout(location = 1) flat out float out_q2;
layout(location = 2) out vec2 out_s;
layout(location = 3) flat out int out_layer;
// Binding 23 (terrain_internal.h, struct mesh_header): triangles stored, capacity, the
// frame's parts and part (relief_draw_options.mesh_parts: only the triangles of patches
// whose id % parts is part are stored and counted; parts is at least 1), then 4 records
// per triangle: its 3 vertices (grid column, row relative to the camera's cell, height
// bits, patch id) and its quad (terrain_tese.glsl's out_quad: factors, where the quad is).
layout(std430, binding = 23) buffer Mesh {
	uint mesh_count;
	uint mesh_cap;
	uint mesh_parts;
	uint mesh_part;
	uvec4 mesh[];
};
void main()
{
	uint k = in_id[0] % mesh_parts == mesh_part ? atomicAdd(mesh_count, 1u) : 0xffffffffu;
	if (k < mesh_cap)
		mesh[4u * k + 3u] = in_quad[0];
	for (int i = 0; i < 3; i++) {
		if (k < mesh_cap)
			mesh[4u * k + uint(i)] = uvec4(uvec2(in_grid[i]), floatBitsToUint(in_height[i]), in_id[i]);
		gl_Position = gl_in[i].gl_Position;
		out_q2 = in_q2[i];
		out_s = in_s[i];
		out_layer = in_layer[i];
		EmitVertex();
	}
	EndPrimitive();
}
