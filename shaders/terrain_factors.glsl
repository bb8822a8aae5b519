// Fine LOD (design notes §4), shared by lod_factors.comp, which computes every drawn quad
// patch's tessellation factors once per frame, and terrain.tesc, which reads them.
//
// Each edge of a tessellation block takes the coarsest simplification d (factor 16 / 2^d)
// whose error segment, eps_d of the blocks on both sides plus Err(P), projects to at most
// tau pixels. The paper measures the segment at the edge's midpoint only; here it is
// measured at both endpoints too (the largest projection wins), because an edge whose end
// is nearer the camera than its middle broke the bound in the benchmark. Both blocks of an
// edge compute it from the same numbers, so the patch is seamless inside, and so is a border
// between two patches drawn at the same level (border_errors); borders between levels keep
// their skirts. The inner factor is the largest of the edge factors and of the level the
// block's point nearest the camera needs (the paper takes the smallest edge factor).
// A skirt quad takes its block's factor along the patch border, 1 across; it is discarded
// where the neighbour is drawn at the same level.

vec4 block_eps_at(int layer, ivec2 bl)
{
	uint base = (uint(layer) * pc.blocks * pc.blocks + uint(bl.y) * pc.blocks + uint(bl.x)) * 4u;
	return vec4(block_err[base], block_err[base + 1u], block_err[base + 2u], block_err[base + 3u]);
}

vec4 block_eps(Instance it, int bx, int by) { return block_eps_at(it.layer, ivec2(bx, by)); }

// `precise` throughout: both patches at a border must reach the same factor from the same
// numbers, so no call site may fuse operations differently.

// Clip-space image of a point: the error segment of length e centred on it then ends at
// c -/+ (e/2) vp[2] (vp's z column), so trying a level costs no matrix product.
vec4 clip_of(vec3 p)
{
	precise vec4 c = pc.vp * vec4(p, 1.0);
	return c;
}

float seg_pixels(vec4 c, float e)
{
	precise vec4 half_seg = (0.5 * e) * pc.vp[2];
	precise vec4 a = c - half_seg, b = c + half_seg;
	if (a.w <= 1e-6 || b.w <= 1e-6)
		return 1.0 / 0.0; // reaches behind the camera: keep full detail
	precise vec2 d = (a.xy / a.w - b.xy / b.w) * 0.5 * pc.viewport;
	precise float len = length(d);
	return len;
}

vec3 sample_pos(Instance it, ivec2 m)
{
	precise float h = it.q2 * float(imageLoad(heights, ivec3(m + 1, it.layer)).x);
	return pos_of(it, m, h);
}

// The coarsest factor whose error segment, measured at each of `n` points (clip space), is
// within tau.
float error_factor(vec4 c[3], int n, vec4 eps, float err)
{
	for (int d = 4; d >= 1; d--) {
		precise float e = eps[d - 1] + err;
		float worst = 0.0;
		for (int i = 0; i < n; i++)
			worst = max(worst, seg_pixels(c[i], e));
		if (worst <= pc.tau)
			return float(BLOCK_CELLS >> uint(d));
	}
	return float(BLOCK_CELLS);
}

float edge_factor(Instance it, vec2 a, vec2 b, vec4 eps, float err)
{
	uint fine = (pc.mode >> 1) & 3u;
	if (fine == FINE_FULL)
		return float(BLOCK_CELLS);
	ivec2 m = ivec2((a + b) * 0.5 + 0.5);
	vec3 p = sample_pos(it, m);
	if (fine == FINE_DISTANCE) {
		// Baseline without error metrics: cells so that triangles are about target_px wide,
		// rounded down to a power of two so that vertices stay on samples.
		precise vec4 pa = pc.vp * vec4(sample_pos(it, ivec2(a)), 1.0), pb = pc.vp * vec4(sample_pos(it, ivec2(b)), 1.0);
		if (pa.w <= 1e-6 || pb.w <= 1e-6)
			return float(BLOCK_CELLS);
		precise float len = length((pa.xy / pa.w - pb.xy / pb.w) * 0.5 * pc.viewport);
		float f = clamp(len / pc.target_px, 1.0, float(BLOCK_CELLS));
		return exp2(floor(log2(f)));
	}
	vec4 pts[3] = vec4[3](clip_of(sample_pos(it, ivec2(a + 0.5))), clip_of(p), clip_of(sample_pos(it, ivec2(b + 0.5))));
	return error_factor(pts, 3, eps, err);
}

// Errors for the edge of border block bl on `side` (0 north, 1 south, 2 west, 3 east): the
// block's own, and, when the patch across the border at the same level is resident, its
// block there too. Both patches then compute one factor from the same numbers, so where
// they are drawn side by side their border vertices coincide (no T-junction, no skirt).
void border_errors(Instance it, ivec2 bl, uint side, inout vec4 eps, inout float err)
{
	int nid = neighbour_id(it, side);
	if (nid < 0 || layer_of[nid] < 0)
		return;
	int last = int(pc.blocks) - 1;
	ivec2 across = side == 0u ? ivec2(bl.x, last) : side == 1u ? ivec2(bl.x, 0) : side == 2u ? ivec2(last, bl.y)
	             : ivec2(0, bl.y);
	eps = max(eps, block_eps_at(layer_of[nid], across));
	err = max(err, info[nid].err);
}

// The level needed at the block's sample nearest the camera (which sits at the origin).
float nearest_factor(Instance it, vec2 lo, vec4 eps)
{
	uint fine = (pc.mode >> 1) & 3u;
	if (fine != FINE_ERRORS)
		return 1.0;
	vec3 o = pos_of(it, ivec2(0), 0.0);
	vec2 step = it.spacing * float(it.scale);
	vec2 cam = vec2(-o.x / step.x, o.y / step.y); // camera in patch samples
	ivec2 m = ivec2(clamp(cam, lo, lo + float(BLOCK_CELLS)) + 0.5);
	vec4 pts[3];
	pts[0] = clip_of(sample_pos(it, m));
	return error_factor(pts, 1, eps, it.err);
}

// Factors of quad patch k of drawn patch `it`: outer (u = 0 west, v = 0 north, u = 1 east,
// v = 1 south) and inner; all zero discards the quad.
void quad_factors(Instance it, uint k, out vec4 outer, out vec2 inner)
{
	vec2 in_s[4];
	float down;
	for (uint v = 0u; v < 4u; v++)
		in_s[v] = quad_corner(k, v, down);
	int b = int(pc.blocks);
	if (k < pc.blocks * pc.blocks) {
		ivec2 bl = ivec2(in_s[0] / float(BLOCK_CELLS));
		vec4 e = block_eps(it, bl.x, bl.y), w = e, n = e, ea = e, s = e;
		float err_w = it.err, err_n = it.err, err_e = it.err, err_s = it.err;
		if (bl.x > 0)
			w = max(e, block_eps(it, bl.x - 1, bl.y));
		else
			border_errors(it, bl, 2u, w, err_w);
		if (bl.y > 0)
			n = max(e, block_eps(it, bl.x, bl.y - 1));
		else
			border_errors(it, bl, 0u, n, err_n);
		if (bl.x + 1 < b)
			ea = max(e, block_eps(it, bl.x + 1, bl.y));
		else
			border_errors(it, bl, 3u, ea, err_e);
		if (bl.y + 1 < b)
			s = max(e, block_eps(it, bl.x, bl.y + 1));
		else
			border_errors(it, bl, 1u, s, err_s);
		float f0 = edge_factor(it, in_s[0], in_s[2], w, err_w);  // u = 0: west
		float f1 = edge_factor(it, in_s[0], in_s[1], n, err_n);  // v = 0: north
		float f2 = edge_factor(it, in_s[1], in_s[3], ea, err_e); // u = 1: east
		float f3 = edge_factor(it, in_s[2], in_s[3], s, err_s);  // v = 1: south
		float fn = nearest_factor(it, vec2(bl) * float(BLOCK_CELLS), e);
		outer = vec4(f0, f1, f2, f3);
		inner = vec2(max(max(f1, f3), fn), max(max(f0, f2), fn));
	} else {
		uint j = k - pc.blocks * pc.blocks, side = j / pc.blocks;
		int i = int(j % pc.blocks);
		int nid = neighbour_id(it, side);
		if ((nid >= 0 && drawn[nid] != 0u) || (pc.mode & MODE_NO_SKIRTS) != 0u) {
			// The neighbour is drawn at this level: the border is matched, nothing to hide.
			outer = vec4(0.0);
			inner = vec2(0.0);
			return;
		}
		ivec2 bl = side == 0u ? ivec2(i, 0) : side == 1u ? ivec2(i, b - 1) : side == 2u ? ivec2(0, i) : ivec2(b - 1, i);
		vec4 e = block_eps(it, bl.x, bl.y);
		float err = it.err;
		border_errors(it, bl, side, e, err);
		float f = edge_factor(it, in_s[0], in_s[1], e, err);
		outer = vec4(1.0, f, 1.0, f);
		inner = vec2(f, 1.0);
	}
}
