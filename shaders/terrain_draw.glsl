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
	uint P, blocks, per_patch, mode; // bit 0: wireframe pass; bits 1-2: fine LOD (FINE_*)
	vec4 sun;         // xyz: towards the sun
	vec2 hrange;      // colour ramp heights, metres
	float target_px;  // FINE_DISTANCE: wanted triangle edge length, pixels
} pc;

const uint FINE_ERRORS = 0u;   // block errors and tau (relief)
const uint FINE_FULL = 1u;     // every block at full resolution (chunked LOD, full grid)
const uint FINE_DISTANCE = 2u; // factor from the edge's projected length (no error metric)
