// Fine LOD (design notes §4): the level of each block edge and of a block's interior, used
// by lod_factors.comp, which computes every drawn quad patch's factors once per frame, and
// through terrain_seal.glsl by the evaluation shader.
//
// Each edge of a tessellation block takes the coarsest simplification d (factor 16 / 2^d)
// whose error segment, the larger eps_d of the blocks on both sides, projects to at most
// tau pixels. eps_d is measured against the finest decoded surface directly (format
// version 4, common/patch_error.h), so unlike the paper no Err(P) is added to it. The
// paper measures the segment at the edge's midpoint only; here it is
// measured at both endpoints too (the largest projection wins), because an edge whose end
// is nearer the camera than its middle broke the bound in the benchmark, and half a block
// deep on both sides, where the strips along the edge reach (edge_factor()). Both blocks of an
// edge compute it from the same numbers, so the patch is seamless inside, and so is a border
// between two patches drawn at the same level (border_errors); between levels the finer
// patch draws its border with the coarser patch's vertices, on its drawn edge
// (terrain_seal.glsl). The inner factor is the same in both directions (an interior of,
// say, 8 x 4-sample cells is a triangulation that no eps_d measures, and the benchmark
// caught one exceeding tau): the level the block's own errors need at its sample nearest
// the camera, its corners, edge middles and centre, but at most one level coarser than its
// finest edge (interior_factor; the paper takes the smallest edge factor). The
// tessellator's transition strips between an edge and an interior of other factors are
// bounded from the patch's samples (edge_eps_at(), interior_factor(); docs/lod.md,
// "Transition triangles: what bounds them") unless the view is loose.
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

// The three of a block's nine measuring points (3 x 3, raster order) on edge `edge`.
ivec3 edge_points(uint edge)
{
	return edge == 0u ? ivec3(0, 3, 6) : edge == 1u ? ivec3(0, 1, 2) : edge == 2u ? ivec3(2, 5, 8) : ivec3(6, 7, 8);
}

// Block bl's height range (low, high; metres): every sample of the block lies in it, so the
// block drawn at any level does.
vec2 block_range_at(int layer, ivec2 bl)
{
	uint base = block_range_index(layer, bl, pc.blocks);
	return vec2(block_err(base), block_err(base + 1u));
}

// The height at which error segments are projected over a height range: a vertical error
// segment's image grows as its point nears the camera along the view axis, so where the
// camera looks down (clip w falls with height) the top of the range, else the bottom.
// Projected at the samples' own heights instead, a ridge higher than every measuring point
// was nearer than all of them, and a flight pixel broke tau by 2 % (docs/lod.md).
float check_height(vec2 range) { return pc.vp[2].w < 0.0 ? range.y : range.x; }

// `precise` throughout: both patches at a border must reach the same factor from the same
// numbers, so no call site may fuse operations differently.

// Clip-space image of a point: an error segment of length e centred on it then ends at
// c -/+ (e/2) vp[2] (vp's z column), so allowed_error() needs no matrix product.
vec4 clip_of(vec3 p)
{
	precise vec4 c = pc.vp * vec4(p, 1.0);
	return c;
}

vec3 sample_pos(Instance it, ivec2 m) { return pos_of(it, m, sample_height(it, m)); }

// Sample m's position raised (or lowered) to the measuring height h, in clip space; m may
// lie beyond the patch (a band across its border), so it is rounded down, not toward 0.
vec4 check_clip(Instance it, vec2 m, float h) { return clip_of(pos_of(it, ivec2(floor(m + 0.5)), h)); }

// The largest vertical error, metres, whose segment centred on clip point c projects to at
// most tau pixels. The segment of length e = 2 s has its ends at c -/+ s z, z = vp[2], and
// its image on the viewport is 2 s K / (c.w^2 - s^2 z.w^2) pixels long, K = |viewport / 2 *
// (c.xy z.w - z.xy c.w)|, growing with s until an end reaches the camera's plane; the
// root of tau (c.w^2 - s^2 z.w^2) = 2 s K, in the form without cancellation, is where it
// reaches tau, and any shorter segment projects shorter. So a level passes at c exactly
// when its error is at most this.
float allowed_error(vec4 c)
{
	if (c.w <= 1e-6)
		return 0.0; // the point is behind the camera: keep full detail
	vec4 z = pc.vp[2];
	precise vec2 d = 0.5 * pc.viewport * (c.xy * z.w - z.xy * c.w);
	precise float k = length(d);
	precise float tw = pc.tau * z.w * c.w;
	precise float den = k + sqrt(k * k + tw * tw);
	if (!(den > 0.0))
		return 1.0 / 0.0; // the segment projects to a point
	precise float s = pc.tau * c.w * c.w / den;
	return 2.0 * s;
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
// allowed error is taken at the measuring points, as for the levels themselves.
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

// The least allowed_error() at the points `across` (patch samples) from the ends and the
// middle of the axis-aligned edge a-b, and, if `both`, as far the other way, at measuring
// height h: where a band that deep along the edge is measured. Both blocks of an edge, and
// both patches of a border drawn at one level, reach the same points from the same
// integers (no camera position in them), so they agree on the factor.
float band_allowed(Instance it, vec2 a, vec2 b, vec2 across, bool both, float h)
{
	vec2 m = (a + b) * 0.5;
	float allowed = 1.0 / 0.0;
	for (int s = both ? -1 : 1; s <= 1; s += 2) {
		vec2 o = float(s) * across;
		allowed = min(allowed, min(allowed_error(check_clip(it, a + o, h)),
		                           min(allowed_error(check_clip(it, m + o, h)), allowed_error(check_clip(it, b + o, h)))));
	}
	return allowed;
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
	// The coarsest level d whose eps_d is at most the least allowed_error() at the edge's ends
	// and middle (0: full detail) and, where the strips along it are bounded, across the band
	// they can reach: a coarse-edge strip at level d lies within 2^(d-1) samples of the edge,
	// between it and the finer interior's inner ring, so the edge is also measured half a
	// block deep on both sides (band_allowed()). Measured on the edge alone, a strip's
	// triangle reaching half a block from its edge towards the camera was 1.0014 tau off in
	// test_lod_sweep (forty-eighth December 2026 session). One allowed error for every level,
	// so that a finer level never has less room than a coarser one and a morphing edge's
	// new vertices start on the coarser level's surface (morph_byte()); measured at each
	// level's own depth, test_morph_continuous's blend jumped by 0.14 px. Each allowed error
	// is worked out once per point (until December 2026 each level's segment was projected
	// at each point, which took the factor pass about a fifth longer at tau = 1).
	float h = check_height(range);
	float allowed = band_allowed(it, a, b, vec2(0.0), false, h); // on the edge
	if (strips_bounded()) {
		vec2 across = float(BLOCK_CELLS / 2u) * vec2(a.x == b.x ? 1.0 : 0.0, a.y == b.y ? 1.0 : 0.0);
		allowed = min(allowed, band_allowed(it, a, b, across, true, h));
	}
	int d = 4;
	for (; d >= 1; d--)
		if (level_passes(eps, d, allowed))
			break;
	morph = morph_byte(eps, d, allowed);
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

// The block's sample nearest the camera (which sits at the origin) at measuring height h,
// in clip space.
vec4 nearest_point(Instance it, vec2 lo, float h)
{
	vec3 o = pos_of(it, ivec2(0), 0.0);
	vec2 step = it.spacing * float(it.scale);
	vec2 cam = vec2(-o.x / step.x, o.y / step.y); // camera in patch samples
	return check_clip(it, clamp(cam, lo, lo + float(BLOCK_CELLS)), h);
}

// Ends of block bl's edge on `side`, in patch samples (the same pairs the quads use).
void block_edge(ivec2 bl, uint side, out vec2 a, out vec2 b)
{
	vec2 lo = vec2(bl) * float(BLOCK_CELLS), c = float(BLOCK_CELLS) * vec2(side == 3u ? 1.0 : 0.0, side == 1u ? 1.0 : 0.0);
	a = lo + c;
	b = lo + (side < 2u ? vec2(float(BLOCK_CELLS), c.y) : vec2(c.x, float(BLOCK_CELLS)));
}

// The interior factor of the block at lo with errors eps, clip-space corners, edge middles
// and centre pt, and edge factors `edges`. Until
// the third session it was the largest edge factor (and the nearest sample's need), so an
// edge made fine by the block across it, whose errors are larger, made this interior fine
// too; measured at ten points with the block's own errors, Puget Sound at tau = 1 draws
// 20 % fewer triangles. One level below the finest edge at most: without that limit, the
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
float interior_factor(Instance it, vec2 lo, vec4 eps, float h, vec4 pt[9], vec4 edges, out uint morph)
{
	// Levels coarser than the limit are not tried: the search starts there, and each level
	// stops at its first point over tau (passing is monotone in d, eps being so).
	float finest_edge = max(max(edges.x, edges.y), max(edges.z, edges.w));
	float least = 0.5 * finest_edge;
	float coarsest_edge = min(min(edges.x, edges.y), min(edges.z, edges.w));
	if (least == 2.0 && coarsest_edge >= 2.0)
		least = finest_edge; // not the centre alone against edges of 4, unless an edge has one segment (above)
	int top = least <= 1.0 ? 4 : findMSB(int(BLOCK_CELLS) / int(least));
	// The largest error each measuring point allows (as in error_factor()).
	float at[9];
	float allowed = allowed_error(nearest_point(it, lo, h));
	for (int k = 0; k < 9; k++) {
		at[k] = allowed_error(pt[k]);
		allowed = min(allowed, at[k]);
	}
	int d = top;
	for (; d >= 1; d--)
		if (level_passes(eps, d, allowed))
			break;
	// One level coarser than the finest edge makes a fine-edge strip (or a fan) along each
	// edge at that level: kept only where its charge (strip_fine_at()) projects within tau
	// at the edge's points and the block's centre, else the interior takes the finest edge's
	// level, which leaves strips along coarser edges only, which their edges' own levels
	// bound (edge_eps_at()). A level-4 interior (factor 1, drawn as the centre alone) is
	// no coarser than it looks against edges of 2 segments.
	// The strip lies between the edge and the inner ring one interior cell (2^d samples) in;
	// it is measured there too (the band below), as an edge's coarse-edge strips are.
	int finest = findMSB(int(BLOCK_CELLS) / int(finest_edge));
	if (d == finest + 1 && finest <= 2 && strips_bounded()) {
		ivec2 bl = ivec2(lo) / int(BLOCK_CELLS);
		const vec2 inward[4] = vec2[4](vec2(1.0, 0.0), vec2(0.0, 1.0), vec2(-1.0, 0.0), vec2(0.0, -1.0));
		for (uint k = 0u; k < 4u && d > finest; k++) {
			if (edges[k] != finest_edge)
				continue;
			float e = strip_fine_at(it.layer, bl, k, finest);
			ivec3 q = edge_points(k);
			vec2 a, b;
			block_edge(bl, side_of_edge(k), a, b);
			float band = band_allowed(it, a, b, float(1 << d) * inward[k], false, h);
			if (e > min(min(min(at[q.x], at[q.y]), min(at[q.z], at[4])), band)) // a fan reaches the centre
				d = finest;
		}
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
