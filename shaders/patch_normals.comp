#version 450
// Normal map of one decoded patch: central differences of its quantised heights, using the
// ring for the border samples so that neighbouring patches get the same normal on their
// shared edge. Output P x P, xyz of the unit normal (x east, y north, z up) as snorm8, and
// in w the sample's validity (1 valid, -1 no-data) so that the renderer can hide holes,
// packed into one R32_UINT texel (packSnorm4x8; see common/gpu/patch_cache.h).
#extension GL_GOOGLE_include_directive : require
#include "patch_run.glsl"

// Work split: a lane takes a block of ROWS x COLS samples and walks it column by column,
// keeping three columns of heights (west, centre, east) of its ROWS rows: per column it
// loads the east column and the samples just above and below the block, 6 loads for 4
// normals instead of 16 (a CPU implementation such as lavapipe pays per load and lane).
// The blocks are walked in runs, one per workgroup (patch_run.glsl).
layout(local_size_x = 64) in;

layout(binding = 0, r32i) uniform readonly iimage2DArray heights;
layout(binding = 1, r32ui) uniform writeonly uimage2DArray normals;
layout(binding = 2, r32i) uniform readonly iimageBuffer staging; // texels: see patch_decode.comp

#include "patch_job.glsl"

const int ROWS = 4, COLS = 8; // ROWS == 4: a column is an ivec4

// Height at sample (x, y), x, y in [-1, P] (the ring included); rows beyond the ring,
// read for a block's rows past the patch's last, are clamped and never stored.
int height(int x, int y)
{
	return imageLoad(heights, ivec3(x + 1, min(y, pc.P) + 1, pc.layer)).x;
}

ivec4 column(int x, int y0)
{
	return ivec4(height(x, y0), height(x, y0 + 1), height(x, y0 + 2), height(x, y0 + 3));
}

// Validity of sample (x, y) from the patch's mask bytes: 1 valid, -1 no-data.
float validity(int x, int y)
{
	if (pc.mask == ~0u)
		return 1.0;
	uint i = uint(y * pc.P + x);
	return ((uint(imageLoad(staging, int(pc.mask + i / 4u)).x) >> (8u * (i % 4u))) & 0xffu) != 0u ? 1.0 : -1.0;
}

void main()
{
	if (!job_begin())
		return;
	int blocks = (pc.P + ROWS - 1) / ROWS, segs = (pc.P + COLS - 1) / COLS;
	int first, end;
	patch_run(blocks * segs, first, end);
	ivec2 g = patch_run_start(first, segs); // (column segment, row block)
	for (int i = first + int(gl_LocalInvocationID.x); i < end; i += RUN_LANES) {
		int x0 = g.x * COLS, y0 = g.y * ROWS, x1 = min(x0 + COLS, pc.P);
		ivec4 west = column(x0 - 1, y0), centre = column(x0, y0);
		for (int x = x0; x < x1; x++) {
			ivec4 east = column(x + 1, y0);
			// rows grow southwards; world y (north) is up
			ivec4 north = ivec4(height(x, y0 - 1), centre.xyz);
			ivec4 south = ivec4(centre.yzw, height(x, y0 + ROWS));
			vec4 dhdx = vec4(east - west) * (pc.q2 * pc.inv_2sx);
			vec4 dhdy = vec4(north - south) * (pc.q2 * pc.inv_2sy);
			for (int r = 0; r < ROWS; r++) {
				int y = y0 + r;
				if (y < pc.P) {
					vec3 n = normalize(vec3(-dhdx[r], -dhdy[r], 1.0));
					imageStore(normals, ivec3(x, y, pc.layer), uvec4(packSnorm4x8(vec4(n, validity(x, y)))));
				}
			}
			west = centre;
			centre = east;
		}
		g = patch_run_next(g, segs);
	}
}
