// Fine LOD (design notes §4), shared by lod_factors.comp, which computes every drawn quad
// patch's tessellation factors once per frame, and terrain.tesc, which reads them.
//
// Each edge of a tessellation block takes the coarsest simplification d (factor 16 / 2^d)
// whose error segment, eps_d of the blocks on both sides plus Err(P), projects to at most
// tau pixels. The paper measures the segment at the edge's midpoint only; here it is
// measured at both endpoints too (the largest projection wins), because an edge whose end
// is nearer the camera than its middle broke the bound in the benchmark. Both blocks of an
// edge compute it from the same numbers, so the patch is seamless inside, and so is a border
// between two patches drawn at the same level (border_errors); between levels the finer
// patch draws its border with the coarser patch's vertices, on its drawn edge
// (coarser_edge, terrain.tese). The inner factor, the same in both directions, is the
// largest of the edge factors and of the level the block's point nearest the camera needs
// (the paper takes the smallest edge factor): an interior of, say, 8 x 4-sample cells is a
// triangulation that no eps_d measures, and the benchmark caught one exceeding tau.
// Skirt quads remain only along the terrain's outer edge (a curtain): its block's factor
// along the edge, 1 across.

// A block's errors eps_1..eps_4, made non-decreasing: a coarser level's measured error can
// be below a finer one's (the triangulations do not nest), and max(eps_1..eps_d) still bounds
// level d. With it, a level that passes the test implies every finer level passes.
vec4 block_eps_at(int layer, ivec2 bl)
{
	uint base = (uint(layer) * pc.blocks * pc.blocks + uint(bl.y) * pc.blocks + uint(bl.x)) * 4u;
	vec4 e = vec4(block_err[base], block_err[base + 1u], block_err[base + 2u], block_err[base + 3u]);
	e.y = max(e.x, e.y);
	e.z = max(e.y, e.z);
	e.w = max(e.z, e.w);
	return e;
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

// Ends of block bl's edge on `side`, in patch samples (the same pairs the quads use).
void block_edge(ivec2 bl, uint side, out vec2 a, out vec2 b)
{
	vec2 lo = vec2(bl) * float(BLOCK_CELLS), c = float(BLOCK_CELLS) * vec2(side == 3u ? 1.0 : 0.0, side == 1u ? 1.0 : 0.0);
	a = lo + c;
	b = lo + (side < 2u ? vec2(float(BLOCK_CELLS), c.y) : vec2(c.x, float(BLOCK_CELLS)));
}

// The factor of border block bl's edge on `side` of patch `it`, as `it` draws it.
float border_edge_factor(Instance it, ivec2 bl, uint side)
{
	vec4 eps = block_eps(it, bl.x, bl.y);
	float err = it.err;
	border_errors(it, bl, side, eps, err);
	vec2 a, b;
	block_edge(bl, side, a, b);
	return edge_factor(it, a, b, eps, err);
}

// Instance of the coarser patch cid, j levels above `it`, as its own selection wrote it.
Instance coarser_instance(Instance it, uint cid, uint j, ivec2 q)
{
	int cells = int(pc.P) - 1;
	ivec2 cell = ivec2(it.px, it.py) * (cells * it.scale) - it.base; // the camera's cell
	Instance c = it;
	c.id = cid;
	c.layer = layer_of[cid];
	c.level = it.level - j;
	c.q2 = coarser_q2(it, j);
	c.scale = it.scale << j;
	c.base = q * (cells * c.scale) - cell;
	c.err = info[cid].err;
	c.skirt = info[cid].skirt;
	c.px = uint(q.x);
	c.py = uint(q.y);
	return c;
}

// Border block bl on `side` against a coarser patch drawn across it: the coarser patch's
// factor for its block edge that holds this one, and j. The caller draws this edge with
// that patch's vertices only (factor fc / 2^j, at least 1) and the evaluation shader
// puts them on its drawn edge, so the border has no crack and needs no skirt.
uint coarser_edge(Instance it, ivec2 bl, uint side, out float fc)
{
	uint cid;
	uint j = coarser_across(it, side, cid);
	fc = 0.0;
	if (j == 0u)
		return 0u;
	ivec2 q = neighbour_at(it, side) >> j;
	Instance c = coarser_instance(it, cid, j, q);
	int b = int(pc.blocks);
	// This block's index along the border in the level's blocks, then in the coarser
	// patch's: a coarser block spans 2^j of ours.
	bool vertical = side >= 2u; // west or east border: along runs north to south
	int along = (vertical ? int(it.py) : int(it.px)) * b + (vertical ? bl.y : bl.x);
	int c_along = (along >> j) - (vertical ? q.y : q.x) * b;
	int last = b - 1;
	uint c_side = side ^ 1u; // the coarser patch's border facing us
	ivec2 cbl = c_side == 0u ? ivec2(c_along, 0) : c_side == 1u ? ivec2(c_along, last)
	          : c_side == 2u ? ivec2(0, c_along) : ivec2(last, c_along);
	fc = border_edge_factor(c, cbl, c_side);
	return j;
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
		vec4 e = block_eps(it, bl.x, bl.y);
		// Edges in the order of the outer factors: west, north, east, south.
		const uint sides[4] = uint[4](2u, 0u, 3u, 1u);
		const ivec2 toward[4] = ivec2[4](ivec2(-1, 0), ivec2(0, -1), ivec2(1, 0), ivec2(0, 1));
		float f[4];
		for (int i = 0; i < 4; i++) {
			ivec2 nb = bl + toward[i];
			if (nb.x >= 0 && nb.y >= 0 && nb.x < b && nb.y < b) {
				vec2 a, c;
				block_edge(bl, sides[i], a, c);
				f[i] = edge_factor(it, a, c, max(e, block_eps(it, nb.x, nb.y)), it.err);
				continue;
			}
			float fc;
			uint j = coarser_edge(it, bl, sides[i], fc);
			f[i] = j != 0u ? max(1.0, fc / float(1u << j)) : border_edge_factor(it, bl, sides[i]);
		}
		float fn = nearest_factor(it, vec2(bl) * float(BLOCK_CELLS), e);
		outer = vec4(f[0], f[1], f[2], f[3]);
		inner = vec2(max(max(f[1], f[3]), fn), max(max(f[0], f[2]), fn));
		if (((pc.mode >> 1) & 3u) == FINE_ERRORS) // isotropic: see the top of the file
			inner = vec2(max(inner.x, inner.y));
		// (the distance baseline keeps one inner factor per direction, as such schemes do)
	} else {
		uint j = k - pc.blocks * pc.blocks, side = j / pc.blocks;
		int i = int(j % pc.blocks);
		if (neighbour_id(it, side) >= 0 || (pc.mode & MODE_NO_SKIRTS) != 0u) {
			// Inside the terrain every border is sealed: matched at one level, drawn on
			// the coarser edge between levels. Only the terrain's edge hangs a curtain.
			outer = vec4(0.0);
			inner = vec2(0.0);
			return;
		}
		ivec2 bl = side == 0u ? ivec2(i, 0) : side == 1u ? ivec2(i, b - 1) : side == 2u ? ivec2(0, i) : ivec2(b - 1, i);
		float f = border_edge_factor(it, bl, side);
		outer = vec4(1.0, f, 1.0, f);
		inner = vec2(f, 1.0);
	}
}

// Height, in metres, at which every patch drawn around finest-grid point g (camera-relative
// integer index) puts a vertex there: the point is on the border of `it`, and of up to three
// patches across it; the coarsest of them draws that border with its own vertices, and the
// others put theirs on its drawn edge. Returns false when `it` is that coarsest (or level
// with it): its own sample then is the height.
bool sealed_height(Instance it, ivec2 si, out float h)
{
	h = 0.0;
	int last = int(pc.P) - 1;
	ivec2 lo = ivec2(si.x == 0 ? -1 : 0, si.y == 0 ? -1 : 0), hi = ivec2(si.x == last ? 1 : 0, si.y == last ? 1 : 0);
	uint best = it.level, best_id = 0u;
	ivec2 best_q = ivec2(0);
	int n = 1 << it.level;
	for (int dy = lo.y; dy <= hi.y; dy++)
		for (int dx = lo.x; dx <= hi.x; dx++) {
			ivec2 q = ivec2(it.px, it.py) + ivec2(dx, dy);
			if ((dx == 0 && dy == 0) || q.x < 0 || q.y < 0 || q.x >= n || q.y >= n ||
			    drawn[first_id(it.level) + uint(q.y) * uint(n) + uint(q.x)] != 0u)
				continue; // beyond the edge, or drawn at this level (shares our samples)
			for (uint j = 1u; j <= it.level; j++) {
				uint l = it.level - j;
				uint a = first_id(l) + uint(q.y >> j) * (1u << l) + uint(q.x >> j);
				if (drawn[a] != 0u) {
					if (l < best) {
						best = l;
						best_id = a;
						best_q = q >> j;
					}
					break;
				}
			}
		}
	if (best == it.level)
		return false;
	uint j = it.level - best;
	Instance c = coarser_instance(it, best_id, j, best_q);
	// The point relative to the coarser patch's sample (0, 0), in finest samples.
	int span = last * c.scale;
	ivec2 o = it.base + si * it.scale - c.base;
	uint side = o.x == 0 ? 2u : o.x == span ? 3u : o.y == 0 ? 0u : 1u;
	int along = side >= 2u ? o.y : o.x;
	int block_span = int(BLOCK_CELLS) * c.scale, b = int(pc.blocks);
	int cb = min(along / block_span, b - 1);
	ivec2 cbl = side == 0u ? ivec2(cb, 0) : side == 1u ? ivec2(cb, b - 1) : side == 2u ? ivec2(0, cb) : ivec2(b - 1, cb);
	int step = int(BLOCK_CELLS) / int(border_edge_factor(c, cbl, side)); // coarser samples per segment
	int step_g = step * c.scale, i0 = along / step_g, rem = along - i0 * step_g;
	int across = side == 0u ? 0 : side == 1u || side == 3u ? last : 0;
	ivec2 ma = side >= 2u ? ivec2(across, i0 * step) : ivec2(i0 * step, across);
	precise float ha = c.q2 * float(imageLoad(heights, ivec3(ma + 1, c.layer)).x);
	h = ha;
	if (rem != 0) {
		ivec2 mb = ma + (side >= 2u ? ivec2(0, step) : ivec2(step, 0));
		precise float hb = c.q2 * float(imageLoad(heights, ivec3(mb + 1, c.layer)).x);
		precise float hm = mix(ha, hb, float(rem) / float(step_g));
		h = hm;
	}
	return true;
}
