#version 450
// GPU reconstruction of one patch: the integer arithmetic of relief_patch_reconstruct()
// (common/codec.c), so the result is bit-exact with the CPU reference decoder.
//
// Inputs: the parent's quantised block (layer parent_layer of `heights`) and the patch's
// symbols in a staging slot: labels (L*L ints), then residuals in plane order (H, V, C), or
// for mode 1 (the root, reconstructed on the CPU) the (P+2)^2 values themselves.
// Corrupt input (values outside the codec's bounds) sets flags[flag]; the CPU then marks
// the patch bad and never draws it.
//
// Work split: a quad is 2 x 2 samples with its refined sample at even local (ex, ey),
// ex, ey in [-2, P-1]: its step writes the refined sample (ex, ey), the edge samples
// (ex+1, ey) and (ex, ey+1) and the centre (ex+1, ey+1), those inside [-1, P]. Every lane
// runs the same code (no divergence between sample kinds) and needs four refined values.
// A lane takes SEG quads along a row and carries the two refined values a quad shares with
// the next, so each is fetched twice instead of four times: a CPU implementation (lavapipe)
// pays for every fetch lane by lane. The segments are walked in runs, one per workgroup
// (patch_run.glsl).
#extension GL_GOOGLE_include_directive : require
#include "patch_run.glsl"

layout(local_size_x = 64) in;

layout(binding = 0, r32i) uniform iimage2DArray heights;
// The staging slots as texels: a CPU implementation loads texels for all lanes at once
// but a storage buffer lane by lane (create_staging_view() in common/gpu/patch_gpu.c).
layout(binding = 2, r32i) uniform readonly iimageBuffer staging;
layout(std430, binding = 3) buffer Flags { uint flags[]; } fl;

#include "patch_job.glsl"

const int Q_MAX = 1 << 26;

// Set by any check that fails; written to flags[pc.flag] once at the end, since a CPU
// implementation runs every atomic lane by lane, active or not.
bool bad = false;

void set_flag() { bad = true; }

int staged(uint index) { return imageLoad(staging, int(index)).x; }

// Refined value at even local (ex, ey) in [-2, P+1]: k * parent, plus the label inside.
int refined(int ex, int ey)
{
	int half_p = (pc.P - 1) >> 1, L = (pc.P + 1) >> 1;
	ivec2 o = ivec2((pc.quadrant & 1) != 0 ? half_p : 0, (pc.quadrant & 2) != 0 ? half_p : 0);
	int p = imageLoad(heights, ivec3(o + ivec2(ex >> 1, ey >> 1) + 1, pc.parent_layer)).x;
	if (p < -Q_MAX || p > Q_MAX)
		set_flag();
	int v = pc.ratio * p;
	if (ex >= 0 && ey >= 0 && ex < pc.P && ey < pc.P)
		v += staged(pc.slot + uint((ey >> 1) * L + (ex >> 1)));
	return v;
}

void put(int x, int y, int q)
{
	if (x < -1 || y < -1 || x > pc.P || y > pc.P)
		return;
	if (q < -Q_MAX || q > Q_MAX)
		set_flag();
	imageStore(heights, ivec3(x + 1, y + 1, pc.layer), ivec4(q));
}

int residual(uint index)
{
	int d = staged(index);
	if (d <= -(1 << 29) || d >= (1 << 29))
		set_flag();
	return d;
}

const int SEG = 8;

// Mode 1 (the root): the quad's values, copied.
void copy_quad(int ex, int ey)
{
	int E = pc.P + 2, L = (pc.P + 1) >> 1;
	uint values = pc.slot + uint(L * L);
	for (int dy = 0; dy < 2; dy++)
		for (int dx = 0; dx < 2; dx++) {
			int x = ex + dx, y = ey + dy;
			if (x >= -1 && y >= -1 && x <= pc.P && y <= pc.P)
				put(x, y, staged(values + uint((y + 1) * E + x + 1)));
		}
}

// The quad at (ex, ey) from its refined corners r00 (ex, ey), r10 (ex + 2, ey),
// r01 (ex, ey + 2), r11 (ex + 2, ey + 2).
void decode_quad(int ex, int ey, int r00, int r10, int r01, int r11)
{
	int L = (pc.P + 1) >> 1, odd = (pc.P + 3) >> 1, even = L;
	uint values = pc.slot + uint(L * L);
	int x = ex + 1, y = ey + 1; // odd coordinates of this quad
	put(ex, ey, r00);           // refined: inside only when ex, ey >= 0
	// H plane sample (x, ey): index (ey / 2) * odd + (x + 1) / 2
	if (ey >= 0)
		put(x, ey, ((r00 + r10 + 1) >> 1) + residual(values + uint((ey >> 1) * odd + ((x + 1) >> 1))));
	// V plane sample (ex, y)
	if (ex >= 0)
		put(ex, y, ((r00 + r01 + 1) >> 1) + residual(values + uint(even * odd + ((y + 1) >> 1) * even + (ex >> 1))));
	// C plane sample (x, y)
	put(x, y, ((r00 + r10 + r01 + r11 + 2) >> 2) +
	          residual(values + uint(2 * even * odd + ((y + 1) >> 1) * odd + ((x + 1) >> 1))));
}

void main()
{
	if (!job_begin())
		return;
	int quads = (pc.P + 3) >> 1; // ex = -2, 0, ..., P-1
	int segs = (quads + SEG - 1) / SEG; // per row of quads
	int first, end;
	patch_run(segs * quads, first, end);
	ivec2 g = patch_run_start(first, segs); // (segment, row of quads)
	for (int i = first + int(gl_LocalInvocationID.x); i < end; i += RUN_LANES) {
		int ey = 2 * g.y - 2, q0 = g.x * SEG, q1 = min(q0 + SEG, quads);
		if (pc.mode == 1) {
			for (int q = q0; q < q1; q++)
				copy_quad(2 * q - 2, ey);
		} else {
			int r00 = refined(2 * q0 - 2, ey), r01 = refined(2 * q0 - 2, ey + 2);
			for (int q = q0; q < q1; q++) {
				int ex = 2 * q - 2, r10 = refined(ex + 2, ey), r11 = refined(ex + 2, ey + 2);
				decode_quad(ex, ey, r00, r10, r01, r11);
				r00 = r10;
				r01 = r11;
			}
		}
		g = patch_run_next(g, segs);
	}
	if (bad)
		atomicOr(fl.flags[pc.flag], 1u);
}
