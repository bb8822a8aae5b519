#version 450
// GPU reconstruction of one patch: the integer arithmetic of relief_patch_reconstruct()
// (common/codec.c), one invocation per sample of the (P+2)^2 block with its ring, so the
// result is bit-exact with the CPU reference decoder.
//
// Inputs: the parent's quantised block (layer parent_layer of `heights`) and the patch's
// symbols in a staging slot: labels (L*L ints), then residuals in plane order (H, V, C), or
// for mode 1 (the root, reconstructed on the CPU) the (P+2)^2 values themselves.
// Corrupt input (values outside the codec's bounds) sets flags[flag]; the CPU then marks
// the patch bad and never draws it.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, r32i) uniform iimage2DArray heights;
layout(std430, binding = 2) readonly buffer Staging { int data[]; } st;
layout(std430, binding = 3) buffer Flags { uint flags[]; } fl;

layout(push_constant) uniform Push {
	int child_layer;
	int parent_layer;
	int quadrant;   // bit 0 east, bit 1 south
	int ratio;      // k
	uint slot;      // first int of the staging slot
	uint flag;      // index into flags
	int mode;       // 0 decode from parent, 1 copy values (root)
	int P;          // samples per side
} pc;

const int Q_MAX = 1 << 26;

void set_flag() { atomicOr(fl.flags[pc.flag], 1u); }

int parent_q(ivec2 storage)
{
	int v = imageLoad(heights, ivec3(storage, pc.parent_layer)).x;
	if (v < -Q_MAX || v > Q_MAX)
		set_flag();
	return v;
}

// Refined value at even local (ex, ey) in [-2, P+1]: k * parent, plus the label inside.
int refined(int ex, int ey)
{
	int half_p = (pc.P - 1) >> 1, L = (pc.P + 1) >> 1;
	ivec2 o = ivec2((pc.quadrant & 1) != 0 ? half_p : 0, (pc.quadrant & 2) != 0 ? half_p : 0);
	int v = pc.ratio * parent_q(o + ivec2(ex >> 1, ey >> 1) + 1);
	if (ex >= 0 && ey >= 0 && ex < pc.P && ey < pc.P)
		v += st.data[pc.slot + uint((ey >> 1) * L + (ex >> 1))];
	return v;
}

void main()
{
	int E = pc.P + 2;
	ivec2 s = ivec2(gl_GlobalInvocationID.xy);
	if (s.x >= E || s.y >= E)
		return;
	int L = (pc.P + 1) >> 1, odd = (pc.P + 3) >> 1, even = L;
	uint values = pc.slot + uint(L * L);
	int q;
	if (pc.mode == 1) {
		q = st.data[values + uint(s.y * E + s.x)];
	} else {
		int x = s.x - 1, y = s.y - 1; // local coordinates, -1..P
		bool xe = (x & 1) == 0, ye = (y & 1) == 0;
		if (xe && ye) {
			q = refined(x, y); // even positions are always inside [0, P-1]
		} else {
			int pred, index;
			if (ye) {        // H plane: y even, x odd
				pred = (refined(x - 1, y) + refined(x + 1, y) + 1) >> 1;
				index = (y >> 1) * odd + ((x + 1) >> 1);
			} else if (xe) { // V plane: y odd, x even
				pred = (refined(x, y - 1) + refined(x, y + 1) + 1) >> 1;
				index = even * odd + ((y + 1) >> 1) * even + (x >> 1);
			} else {         // C plane: both odd
				pred = (refined(x - 1, y - 1) + refined(x + 1, y - 1) + refined(x - 1, y + 1) +
				        refined(x + 1, y + 1) + 2) >> 2;
				index = 2 * even * odd + ((y + 1) >> 1) * odd + ((x + 1) >> 1);
			}
			int d = st.data[values + uint(index)];
			if (d <= -(1 << 29) || d >= (1 << 29))
				set_flag();
			q = pred + d;
		}
	}
	if (q < -Q_MAX || q > Q_MAX)
		set_flag();
	imageStore(heights, ivec3(s, pc.child_layer), ivec4(q));
}
