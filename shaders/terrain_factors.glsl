// Fine LOD (design notes §4): the level of each block edge and of a block's interior, used
// by lod_factors.comp, which computes every drawn quad patch's factors once per frame, and
// through terrain_seal.glsl by the evaluation shader.
//
// Each edge of a tessellation block takes the coarsest simplification d (factor 16 / 2^d)
// whose error, the larger eps_d of the blocks on both sides, projects to at most tau
// pixels from anywhere in the band of triangles that the edge's level decides (the edge
// and 2^(d-1) samples on both sides, where the strips along it reach; edge_factor()).
// eps_d is measured against the finest decoded surface directly (format version 4,
// common/patch_error.h), so unlike the paper no Err(P) is added to it. The paper measures
// the segment at the edge's midpoint only; here the error is bounded over a box around the
// triangles it applies to (allowed_box()), so the bound holds at every point, not at
// chosen ones. Both blocks of an edge compute it from the same numbers, so the patch is
// seamless inside, and so is a border between two patches drawn at the same level
// (border_errors); between levels the finer patch draws its border with the coarser
// patch's vertices, on its drawn edge (terrain_seal.glsl). The inner factor is the same in
// both directions (an interior of, say, 8 x 4-sample cells is a triangulation that no eps_d
// measures, and the benchmark caught one exceeding tau): the level the block's own errors
// need over the block's box, but at most one level coarser than its finest edge
// (interior_factor; the paper takes the smallest edge factor). The tessellator's
// transition strips between an edge and an interior of other factors are bounded from the
// patch's samples (edge_eps_at(), interior_factor(); docs/lod.md, "Transition triangles:
// what bounds them") unless the view is loose.
// Skirt quads remain only along the terrain's outer edge (a curtain): its block's factor
// along the edge, 1 across.

// A block's errors eps_1..eps_4, made non-decreasing (running_max(), terrain_texels.glsl).
vec4 block_eps_at(int layer, ivec2 bl) { return block_eps_in(layer, bl, pc.blocks); }

vec4 block_eps(Instance it, int bx, int by) { return block_eps_at(it.layer, ivec2(bx, by)); }

// Transition strips (docs/lod.md, "Transition triangles: what bounds them"): where an
// edge's factor differs from the interior's, the tessellator's triangles along it are
// within eps_c + D of the finest surface, c the level of the column square they lie in and
// D what patch_strips.comp computed from the samples; along an edge coarser than the
// interior, also within eps_i + D_i, i the interior's level, and the decode stored the
// smaller (the edge's charge). Edge `edge`: 0 west, 1 north, 2 east, 3 south (the outer
// factors' order; edge_of_side(), terrain_common.glsl).

// Whether the strips are bounded: unless the view asks otherwise (MODE_LOOSE_STRIPS).
bool strips_bounded() { return (pc.mode & MODE_LOOSE_STRIPS) == 0u; }

// The errors an edge of block bl at each level d = 1..4 must keep within tau: the block's
// eps_d (non-decreasing, `eps`), or the charge of a strip along it against any finer
// interior, whatever the interior turns out to be, if larger; made non-decreasing again.
vec4 edge_eps_at(int layer, ivec2 bl, uint edge, vec4 eps)
{
	return strips_bounded() ? edge_charges_in(layer, bl, edge, pc.blocks, eps) : eps;
}

// The charge of a strip along edge `edge` of block bl at level d = 0..2 against an interior
// at d + 1 (a fan from the centre at d = 2): how far it can lie from the finest surface.
float strip_fine_at(int layer, ivec2 bl, uint edge, int d)
{
	return block_err(block_strip_index(layer, bl, edge, pc.blocks) + 4u + uint(d));
}

// Block bl's height range (low, high; metres): every sample of the block lies in it, so the
// block drawn at any level does.
vec2 block_range_at(int layer, ivec2 bl)
{
	uint base = block_range_index(layer, bl, pc.blocks);
	return vec2(block_err(base), block_err(base + 1u));
}

// `precise` throughout: both patches at a border must reach the same factor from the same
// numbers, so no call site may fuse operations differently.

vec4 clip_of(vec3 p)
{
	precise vec4 c = pc.vp * vec4(p, 1.0);
	return c;
}

vec3 sample_pos(Instance it, ivec2 m) { return pos_of(it, m, sample_height(it, m)); }

// Sample m (which may lie beyond the patch: a band across its border) at height h, in clip
// space.
vec4 sample_clip(Instance it, vec2 m, float h) { return clip_of(pos_of(it, ivec2(m), h)); }

// The error allowed over a box (docs/lod.md, "The room over a box"). A vertical segment of
// length e with ends c1 and c2 = c1 + e z in clip space (z = vp[2], the image of a metre
// up) is e |D(c1)| / (c1.w c2.w) pixels long on the viewport, where D(c) = viewport / 2 *
// (c.xy z.w - z.xy c.w); D(c2) = D(c1). So with K = |D| and w = c.w at its drawn end c1,
// and c2.w >= w - e |z.w|, its image is at most e (K / w^2) w / (w - e |z.w|). The drawn
// end of every error segment of a block lies in the block's box (each drawn point
// interpolates the block's samples, which its height range holds), so a bound on K / w^2
// and a least w over the box bound every segment's image there (allowed_box()): a level
// whose error is within that is within tau at every point of the box, not only at measuring
// points. Until the forty-ninth December 2026 session the segment was projected at ten
// points of a block and at nine along an edge, and test_lod_sweep found a frame whose
// triangle broke tau between them (1.0014 tau).

// A point's part of a box's measure: (K, the least w over the heights from the point's
// own to dh above it). D does not change with height; w changes by dh z.w.
vec2 point_measure(vec4 c, float dh)
{
	vec4 z = pc.vp[2];
	precise vec2 d = 0.5 * pc.viewport * (c.xy * z.w - z.xy * c.w);
	precise float w = c.w + min(0.0, dh * z.w);
	return vec2(length(d), w);
}

// The largest K / w^2 on the segment between point measures p and q (K, w): at an end, or
// where its derivative along the segment is 0, (p.x + t dx) / (p.y + t dy)^2 with
// t = (dx p.y - 2 p.x dy) / (dx dy) (dx, dy: q - p), if that lies between them; evaluated
// at the computed t (an error in t changes the value to second order only).
float segment_max(vec2 p, vec2 q)
{
	float g = max(p.x / (p.y * p.y), q.x / (q.y * q.y));
	vec2 dq = q - p;
	precise float t = (dq.x * p.y - 2.0 * p.x * dq.y) / (dq.x * dq.y);
	if (t > 0.0 && t < 1.0) {
		precise vec2 m = p + t * dq;
		g = max(g, m.x / (m.y * m.y));
	}
	return g;
}

// The largest vertical error, metres, whose segment projects to at most tau pixels from
// anywhere in the box whose four corners (through the whole height range) have point
// measures a, b, c, d. A point of the box is a convex combination of the corners with
// weights l: its w is at least l . w (the corners' least over the heights), its K at most
// l . K (K is convex: D is linear in c, c affine in the point). So K / w^2 is at most the
// largest (l . K) / (l . w)^2: over the convex hull of the corners' (w, K), which lies on
// its boundary (moving up raises it), so on a segment between two corners (segment_max()),
// F. With W the least w, the image of a segment of length e is then at most
// e F W / (W - e |z.w|), which is tau at e = tau W / (F W + tau |z.w|). Where K / w^2 is
// the same at every corner (the camera level: K grows as w), F is that and the bound is
// what a single point gives; bounding K by its largest corner and w by its least instead
// drew 13 % more triangles on Puget Sound at tau = 1.
float allowed_box(vec2 a, vec2 b, vec2 c, vec2 d)
{
	float w = min(min(a.y, b.y), min(c.y, d.y));
	if (w <= 1e-6)
		return 0.0; // the box reaches the camera's plane: keep full detail
	float f = max(max(max(segment_max(a, b), segment_max(a, c)), max(segment_max(a, d), segment_max(b, c))),
	              max(segment_max(b, d), segment_max(c, d)));
	precise float den = f * w + pc.tau * abs(pc.vp[2].w);
	if (!(den > 0.0))
		return 1.0 / 0.0; // every segment projects to a point
	precise float e = pc.tau * w / den;
	return e;
}

// The least error allowed over the block at lo (patch samples) between heights range: one
// box (4 x 4 boxes of 4 samples measured the same triangles on Puget Sound but 10 at
// tau = 4, and took the factor pass twice as long).
float block_allowed(Instance it, vec2 lo, vec2 range)
{
	float dh = range.y - range.x, s = float(BLOCK_CELLS);
	return allowed_box(point_measure(sample_clip(it, lo, range.x), dh),
	                   point_measure(sample_clip(it, lo + vec2(s, 0.0), range.x), dh),
	                   point_measure(sample_clip(it, lo + vec2(0.0, s), range.x), dh),
	                   point_measure(sample_clip(it, lo + vec2(s, s), range.x), dh));
}

// An axis-aligned block edge from a to b (patch samples) between heights range: its ends
// in clip space at the range's foot, and the step across it (a sample towards +x or +y).
struct EdgeMeasure {
	vec4 ca, cb, across;
	float dh;
};

EdgeMeasure edge_measure(Instance it, vec2 a, vec2 b, vec2 range)
{
	EdgeMeasure e;
	e.dh = range.y - range.x;
	e.ca = sample_clip(it, a, range.x);
	e.cb = sample_clip(it, b, range.x);
	e.across = sample_clip(it, a + vec2(a.x == b.x ? 1.0 : 0.0, a.y == b.y ? 1.0 : 0.0), range.x) - e.ca;
	return e;
}

// The least error allowed over the band `depth` samples deep on both sides of the edge (0:
// the edge alone), one box. Both blocks of an edge, and both patches of a border drawn at
// one level, have its ends and the sample across from the same integers (pos_of() gives
// every patch the same bits for a sample), and the same expressions make the same corners
// from them, so they agree on the factor.
float band_allowed(EdgeMeasure e, float depth)
{
	precise vec4 off = depth * e.across;
	precise vec4 a0 = e.ca - off, a1 = e.ca + off, b0 = e.cb - off, b1 = e.cb + off;
	return allowed_box(point_measure(a0, e.dh), point_measure(a1, e.dh), point_measure(b0, e.dh), point_measure(b1, e.dh));
}

// Geomorphing (docs/lod.md, "Morphing"). A block edge or interior drawn at level d (factor
// 16 / 2^d) because level d + 1 failed gives the vertices level d + 1 lacks (odd ones) the
// height (1 - t) c + t h, where h is the vertex's sample and c the level d + 1 surface there
// (the mean of its two neighbours along an edge or a row, of its four diagonal neighbours at
// a cell's centre). With t = 0 that drawn surface lies between level d + 1's two diagonal
// triangulations at every point, so eps_{d+1} bounds it; with t = 1 it is level d, within
// eps_d; with one t at every corner, within (1 - t) eps_{d+1} + t eps_d. But a triangle of
// a block's outer ring has corners on an edge, blended with the edge's weight, and inside,
// with the interior's: with weights from t_lo to t_hi it is the surface at t_hi moved at
// each corner by (t_k - t_hi) (h - c), and |h - c| <= eps_{d+1} (h is on the finest
// surface, c on level d + 1's), so it lies within (1 - t_lo) eps_{d+1} + t_hi eps_d <=
// (1 - t_lo) eps_{d+1} + eps_d. (The weight t0 that kept (1 - t) eps_{d+1} + t eps_d within
// the allowed error, used until December 2026, put such triangles up to 1.04 tau in the
// tests.) So every weight is at least t0 = (eps_{d+1} + eps_d - allowed) / eps_{d+1}, which
// keeps that within the allowed error whatever the other corners' weights, and, so that t0
// is 0 where level d + 1 stops passing (no jump when the level changes), a morphing view
// takes level d + 1 only where eps_{d+1} + eps_d is within the allowed error
// (level_passes()): it draws more triangles than a view without morphing (docs/lod.md).
// The eps are the edge's or the interior's own (an edge's at least its blocks'), and the
// allowed error is the room of level d + 1 (an edge's over its wider band, which holds
// level d's), as for the levels themselves.
// t = min(1, MORPH_RATE t0) moves continuously with the camera; the blend is done within
// the first 1 / MORPH_RATE of its range (a rate of 1 left every block part-way all the
// time, with twice the RMS error on a 48-pair Puget Sound flight; docs/lod.md). t travels
// as a morph byte m, t = m / 256, rounded up (a larger t only lowers the bound); MORPH_FULL
// (255) means t = 1, and is what a view without morphing (relief_view.morph, MORPH_CODE)
// and the baselines use: their factor pass then works out no allowed error, and the
// evaluation shader skips the blend for a quad whose bytes are all MORPH_FULL.
const uint MORPH_FULL = 255u;
const float MORPH_RATE = 4.0;

bool morph_on() { return MORPH_CODE && fine_lod() == FINE_ERRORS; }

uint morph_byte(vec4 eps, int d, float allowed)
{
	if (!morph_on() || d >= 4)
		return MORPH_FULL;
	float coarse = eps[d], fine = d == 0 ? 0.0 : eps[d - 1]; // eps_{d+1}, eps_d (0 at full detail)
	if (isinf(coarse) || !(coarse > 0.0))
		return MORPH_FULL;
	float t = clamp(MORPH_RATE * (coarse + fine - allowed) / coarse, 0.0, 1.0);
	return min(uint(ceil(t * 256.0)), MORPH_FULL);
}

// Whether level d (1..4) is fine enough where `allowed` is the largest error allowed:
// eps_d within it, and, in a morphing view, eps_d + eps_{d-1} (eps_0 = 0, full detail),
// the bound of a triangle whose corners are blended with any two weights (above).
bool level_passes(vec4 eps, int d, float allowed)
{
	float e = eps[d - 1];
	if (morph_on() && d >= 2)
		e += eps[d - 2];
	return e <= allowed;
}

float edge_factor(Instance it, vec2 a, vec2 b, vec4 eps, vec2 range, out uint morph)
{
	uint fine = fine_lod();
	morph = MORPH_FULL;
	if (fine == FINE_FULL)
		return float(BLOCK_CELLS);
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
	// The coarsest level d whose eps_d is within the error allowed over the triangles that
	// the edge's level decides (0: full detail): the edge itself and, where the strips along
	// it are bounded, the band they reach, 2^(d-1) samples deep on both sides at level d (a
	// coarse-edge strip lies between the edge and the finer interior's inner ring). Measured
	// on the edge's ends and middle alone, a strip's triangle half a block from its edge
	// towards the camera was 1.0014 tau off in test_lod_sweep (forty-eighth December 2026
	// session). The bands nest, so a finer level never has less room than a coarser one,
	// and a morphing edge's weights come from the failing level's room, where its new
	// vertices start on that level's surface (morph_byte()): within the drawn level's room,
	// which is no smaller.
	EdgeMeasure e = edge_measure(it, a, b, range);
	float failed = 0.0; // the room of the last level that failed
	int d = 4;
	for (; d >= 1; d--) {
		float allowed = band_allowed(e, strips_bounded() ? float(1 << (d - 1)) : 0.0);
		if (level_passes(eps, d, allowed))
			break;
		failed = allowed;
	}
	morph = morph_byte(eps, d, failed); // MORPH_FULL where level 4 passed (failed unset)
	return float(BLOCK_CELLS >> uint(d));
}

// Errors for the edge of border block bl on `side` (0 north, 1 south, 2 west, 3 east): the
// block's own, and, when the patch across the border at the same level is resident, its
// block there too. Both patches then compute one factor from the same numbers, so where
// they are drawn side by side their border vertices coincide (no T-junction, no skirt).
void border_errors(Instance it, ivec2 bl, uint side, inout vec4 eps, inout vec2 range)
{
	uint ne = neighbour_entry(it, side);
	if (ne == NO_ENTRY || layer_at(ne) < 0)
		return;
	ivec2 across = border_block(side ^ 1u, side >= 2u ? bl.y : bl.x); // its block facing bl
	eps = max(eps, edge_eps_at(layer_at(ne), across, edge_of_side(side ^ 1u), block_eps_at(layer_at(ne), across)));
	vec2 r = block_range_at(layer_at(ne), across);
	range = vec2(min(range.x, r.x), max(range.y, r.y));
}

// Ends of block bl's edge on `side`, in patch samples (the same pairs the quads use).
void block_edge(ivec2 bl, uint side, out vec2 a, out vec2 b)
{
	vec2 lo = vec2(bl) * float(BLOCK_CELLS), c = float(BLOCK_CELLS) * vec2(side == 3u ? 1.0 : 0.0, side == 1u ? 1.0 : 0.0);
	a = lo + c;
	b = lo + (side < 2u ? vec2(float(BLOCK_CELLS), c.y) : vec2(c.x, float(BLOCK_CELLS)));
}

// The interior factor of the block at lo with errors eps, height range `range` and edge
// factors `edges`: the level its own errors need over its box (block_allowed()). Until
// the third session it was the largest edge factor (and the nearest sample's need), so an
// edge made fine by the block across it, whose errors are larger, made this interior fine
// too; measured with the block's own errors, Puget Sound at tau = 1 drew 20 % fewer
// triangles. One level below the finest edge at most: without that limit, the
// tessellator's transition triangles between a fine edge and a much coarser interior put a
// test pixel 1.007 px off at tau = 1. And never an inner factor of 2 against an edge of 4
// or more: the interior is then the block's centre alone, and every triangle joins it to
// an edge segment, a triangulation of no level d that no eps_d bounds; at 1280 x 720 such
// a block was 112 m off, 2.05 px at tau = 2 (docs/lod.md, known issues). But not when an
// edge has a single segment: the raised interior then makes long transition triangles from
// that segment to its inner ring, and on the 48-pair flight one such block was 255 m off,
// 2.65 px at tau = 2 (eighth December session; 1.84 px without the rule). With that limit
// the rule costs 0-4.5 % more triangles. Every strip (and fan) left is bounded since
// December 2026: the interior's strips below, the edges' in edge_eps_at().
float interior_factor(Instance it, vec2 lo, vec4 eps, vec2 range, vec4 edges, out uint morph)
{
	// Levels coarser than the limit are not tried: the search starts there (passing is
	// monotone in d, eps being so).
	float finest_edge = max(max(edges.x, edges.y), max(edges.z, edges.w));
	float least = 0.5 * finest_edge;
	float coarsest_edge = min(min(edges.x, edges.y), min(edges.z, edges.w));
	if (least == 2.0 && coarsest_edge >= 2.0)
		least = finest_edge; // not the centre alone against edges of 4, unless an edge has one segment (above)
	int top = least <= 1.0 ? 4 : findMSB(int(BLOCK_CELLS) / int(least));
	float allowed = block_allowed(it, lo, range);
	int d = top;
	for (; d >= 1; d--)
		if (level_passes(eps, d, allowed))
			break;
	// One level coarser than the finest edge makes a fine-edge strip (or a fan) along each
	// edge at that level: kept only where its charge (strip_fine_at()) is within the
	// block's allowed error (the strip, between the edge and the inner ring one interior
	// cell in, or the fan to the centre, lies in the block), else the interior takes the
	// finest edge's level, which leaves strips along coarser edges only, which their edges'
	// own levels bound (edge_eps_at()). A level-4 interior (factor 1, drawn as the centre
	// alone) is no coarser than it looks against edges of 2 segments.
	int finest = findMSB(int(BLOCK_CELLS) / int(finest_edge));
	if (d == finest + 1 && finest <= 2 && strips_bounded()) {
		ivec2 bl = ivec2(lo) / int(BLOCK_CELLS);
		for (uint k = 0u; k < 4u && d > finest; k++)
			if (edges[k] == finest_edge && strip_fine_at(it.layer, bl, k, finest) > allowed)
				d = finest;
	}
	// An interior of factor 1 against a finer edge is drawn by the tessellator as its
	// centre alone (inner factor 1 rounds up to 2): with morphing that centre takes the
	// mean of the corners (t = 0), level 4's own surface there up to the diagonal, rather
	// than a sample of its own.
	if (d == 4) {
		morph = morph_on() ? 0u : MORPH_FULL;
		return 1.0;
	}
	morph = morph_byte(eps, d, allowed);
	return float(BLOCK_CELLS >> uint(d));
}

// The factor of border block bl's edge on `side` of patch `it`, as `it` draws it.
float border_edge_factor(Instance it, ivec2 bl, uint side, out uint morph)
{
	vec4 eps = edge_eps_at(it.layer, bl, edge_of_side(side), block_eps(it, bl.x, bl.y));
	vec2 range = block_range_at(it.layer, bl);
	border_errors(it, bl, side, eps, range);
	vec2 a, b;
	block_edge(bl, side, a, b);
	return edge_factor(it, a, b, eps, range, morph);
}
