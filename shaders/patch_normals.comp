#version 450
// Normal map of one decoded patch: central differences of its quantised heights, using the
// ring for the border samples so that neighbouring patches get the same normal on their
// shared edge. Output P x P, xyz of the unit normal (x east, y north, z up) as snorm8, and
// in w the sample's validity (1 valid, -1 no-data) so that the renderer can hide holes.
#extension GL_GOOGLE_include_directive : require
#include "patch_run.glsl"

// One step per sample, walked in runs, one per workgroup (patch_run.glsl).
layout(local_size_x = 64) in;

layout(binding = 0, r32i) uniform readonly iimage2DArray heights;
layout(binding = 1, rgba8_snorm) uniform writeonly image2DArray normals;
layout(std430, binding = 2) readonly buffer Staging { int data[]; } st;

// One dispatch per batch: workgroup z is the job; the job record is shared with
// patch_decode.comp.
struct Job {
	int layer;     // the patch's layer (child_layer in the decode pass)
	int parent_layer, quadrant, ratio;
	uint slot, flag;
	int mode;      // 2: nothing to do (warm-up)
	int P;
	uint mask;     // staging int offset of the patch's validity bytes, or ~0u: all valid
	float q2;      // metres per quantum at the patch's level (2 delta_l)
	float inv_2sx; // 1 / (2 x spacing) at the patch's level, 1/m
	float inv_2sy;
};
layout(std430, binding = 4) readonly buffer Jobs { Job jobs[]; };
layout(push_constant) uniform Push { uint first_job; } push;
Job pc;

void normal_at(ivec2 p)
{
	ivec2 s = p + 1; // storage coordinates of the sample; rows grow southwards
	int e = imageLoad(heights, ivec3(s + ivec2(1, 0), pc.layer)).x;
	int w = imageLoad(heights, ivec3(s - ivec2(1, 0), pc.layer)).x;
	int so = imageLoad(heights, ivec3(s + ivec2(0, 1), pc.layer)).x;
	int no = imageLoad(heights, ivec3(s - ivec2(0, 1), pc.layer)).x;
	float dhdx = float(e - w) * pc.q2 * pc.inv_2sx;
	float dhdy = float(no - so) * pc.q2 * pc.inv_2sy; // north is up in world y
	vec3 n = normalize(vec3(-dhdx, -dhdy, 1.0));
	float valid = 1.0;
	if (pc.mask != ~0u) {
		uint i = uint(p.y * pc.P + p.x);
		valid = ((uint(st.data[pc.mask + i / 4u]) >> (8u * (i % 4u))) & 0xffu) != 0u ? 1.0 : -1.0;
	}
	imageStore(normals, ivec3(p, pc.layer), vec4(n, valid));
}

void main()
{
	pc = jobs[push.first_job + gl_WorkGroupID.z];
	if (pc.mode == 2)
		return;
	int first, end;
	patch_run(pc.P * pc.P, first, end);
	ivec2 p = patch_run_start(first, pc.P);
	for (int i = first + int(gl_LocalInvocationID.x); i < end; i += RUN_LANES) {
		normal_at(p);
		p = patch_run_next(p, pc.P);
	}
}
