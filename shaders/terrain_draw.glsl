// Bindings and push constants of the terrain draw stages (common/gpu/terrain.c).
layout(std430, binding = 4) readonly buffer Instances { Instance inst[]; };
layout(binding = 9, r32i) uniform readonly iimage2DArray heights;
layout(binding = 10, rgba8_snorm) uniform readonly image2DArray normals;
layout(std430, binding = 11) readonly buffer Errors { float block_err[]; };

layout(push_constant) uniform DrawPush {
	mat4 vp;          // camera-relative view-projection
	vec2 viewport;    // pixels
	float tau;        // pixels
	float cam_z;      // metres
	uint P, blocks, per_patch, mode; // mode: 0 shaded, 1 wireframe overlay
	vec4 sun;         // xyz: towards the sun
	vec2 hrange;      // colour ramp heights, metres
} pc;
