// Borders between levels (docs/lod.md): where a patch's neighbour at its level is not
// drawn but an ancestor of it is, the finer patch rebuilds that coarser patch's instance,
// reproduces its factor for the block edge holding its own, draws its border with the
// coarser patch's vertices only, and puts every border vertex on the coarser patch's drawn
// edge. Needs terrain_factors.glsl.

// How many levels finer than `it` the finest patch drawn across its border block bl on
// `side` is (0: none finer), at most log2(BLOCK_CELLS) = 4: the finest a block edge can
// draw every corner of (factor 16); a patch finer still counts as 4 levels finer. Up to
// log2(blocks) levels finer one patch covers the block edge at each level; beyond,
// 2^j / blocks patches share it and each is looked at.
uint finer_across(Instance it, ivec2 bl, uint side)
{
	if (!has_neighbour(it, side))
		return 0u;
	ivec2 q = neighbour_at(it, side);
	if (drawn_at(it.level, q))
		return 0u;
	int b = int(pc.blocks), along = side >= 2u ? bl.y : bl.x;
	uint found = 0u;
	for (uint j = 1u;; j++) {
		uint l = it.level + j;
		if (l >= window_count() || window_at(l).x == 0u)
			break; // finer than the finest level
		// cells per side at level l; those along bl: a0 .. a0 + n - 1
		int m = 1 << j, a0 = along * m / b, n = max(m / b, 1);
		for (int a = a0; a < a0 + n; a++) {
			ivec2 c = facing_cell(q, m, side, a);
			if (drawn_at(l, c))
				found = j;
		}
		if (found >= uint(findMSB(BLOCK_CELLS)) || (j <= uint(findMSB(b)) && found != 0u))
			return min(found, uint(findMSB(BLOCK_CELLS))); // nothing finer matters
	}
	return min(found, uint(findMSB(BLOCK_CELLS)));
}

// The factor `it` draws its border block bl's edge on `side` with when nothing coarser is
// drawn across: border_edge_factor(), but at least 2^j where a patch j levels finer is
// drawn across, so that every corner of that patch's blocks along the edge is a vertex
// here too (no T-junction: its border is drawn with these vertices, terrain_seal.glsl).
// Its morph byte: the edge's own, or MORPH_FULL where the finer patch raised the factor.
float drawn_border_factor(Instance it, ivec2 bl, uint side, out uint morph)
{
	float f = border_edge_factor(it, bl, side, morph), least = float(1u << finer_across(it, bl, side));
	if (least > f) {
		morph = MORPH_FULL;
		return least;
	}
	return f;
}

// The patch j levels above `it` at position q of its level, where its own selection would
// place it: level, quantum, scale and samples; id, layer, err and skirt are left as `it`'s.
Instance coarser_at(Instance it, uint j, ivec2 q)
{
	int cells = int(pc.P) - 1;
	ivec2 cell = ivec2(it.px, it.py) * (cells * it.scale) - it.base; // the camera's cell
	Instance c = it;
	c.level = it.level - j;
	c.q2 = coarser_q2(it, j);
	c.scale = it.scale << j;
	c.base = q * (cells * c.scale) - cell;
	c.px = uint(q.x);
	c.py = uint(q.y);
	return c;
}

// Instance of the coarser patch (entry ce), j levels above `it` at q, as its own selection
// wrote it.
Instance coarser_instance(Instance it, uint ce, uint j, ivec2 q)
{
	Instance c = coarser_at(it, j, q);
	c.id = first_id(c.level) + uint(q.y) * (1u << c.level) + uint(q.x);
	c.layer = layer_at(ce);
	c.err = info_at(ce).err;
	c.skirt = info_at(ce).skirt;
	return c;
}

// Border block bl on `side` against a coarser patch drawn across it: the coarser patch's
// factor for its block edge that holds this one, that edge's morph byte, and j. The caller
// draws this edge with that patch's vertices only (factor fc / 2^j, at least 1) and the
// evaluation shader puts them on its drawn edge, so the border has no crack and needs no
// skirt.
uint coarser_edge(Instance it, ivec2 bl, uint side, out float fc, out int clayer, out uint cmorph)
{
	uint ce;
	uint j = coarser_across(it, side, ce);
	fc = 0.0;
	clayer = -1;
	cmorph = MORPH_FULL;
	if (j == 0u)
		return 0u;
	clayer = layer_at(ce);
	ivec2 q = neighbour_at(it, side) >> j;
	Instance c = coarser_instance(it, ce, j, q);
	int b = int(pc.blocks);
	// This block's index along the border in the level's blocks, then in the coarser
	// patch's: a coarser block spans 2^j of ours.
	bool vertical = side >= 2u; // west or east border: along runs north to south
	int along = (vertical ? int(it.py) : int(it.px)) * b + (vertical ? bl.y : bl.x);
	int c_along = (along >> j) - (vertical ? q.y : q.x) * b;
	uint c_side = side ^ 1u; // the coarser patch's border facing us
	fc = drawn_border_factor(c, border_block(c_side, c_along), c_side, cmorph);
	return j;
}

// Seal records (lod_factors.comp writes one per quad, the evaluation shader reads it): for a
// block on the patch's border, x for its west or east side and y for its north or south
// side: j (bits 0-2, 0: nothing coarser across), the coarser patch's samples per segment of
// its drawn edge there (bits 3-7), its layer (bits 8-23; the pool has at most 65,535) and
// that edge's morph byte (bits 24-31); z, w for the patch corner the quad touches, if any:
// the height sealed_height() gives there (float bits) and 1, or 0.
uint seal_side(uint j, float fc, int clayer, uint cmorph)
{
	if (j == 0u)
		return 0u;
	return j | (uint(int(BLOCK_CELLS) / int(fc)) << 3u) | ((uint(clayer) & 0xffffu) << 8u) | (cmorph << 24u);
}

// Whether a quad's seal record puts any of its vertices on a coarser patch's edge.
bool seal_any(uvec4 seal) { return (seal.x & 7u) != 0u || (seal.y & 7u) != 0u || seal.w != 0u; }

// The blend of a vertex's own height h with c, the mean of lo and hi, by morph byte `morph`
// (terrain_factors.glsl).
float morph_height(float lo, float h, float hi, uint morph)
{
	if (!MORPH_CODE || morph == MORPH_FULL)
		return h;
	precise float c = 0.5 * (lo + hi);
	precise float r = c + (h - c) * (float(morph) * (1.0 / 256.0));
	return r;
}

// The height of a vertex at sample m of patch `it` that a run along dir, drawn in segments
// of `step` samples, has at an odd position (the next coarser level lacks it): its own
// height h blended with the mean of its neighbours one segment either way. The evaluation
// shader and the seals both use this, so a vertex two patches share gets the same bits in
// both.
float morph_along(Instance it, ivec2 m, ivec2 dir, int step, float h, uint morph)
{
	if (!MORPH_CODE || morph == MORPH_FULL)
		return h;
	return morph_height(sample_height(it, m - dir * step), h, sample_height(it, m + dir * step), morph);
}

// Vertex i's height on a run of samples m0 + k dir drawn in segments of `step` samples with
// morph byte `morph`: its sample's, blended for an odd vertex (morph_along).
float run_vertex_height(Instance c, ivec2 m0, ivec2 dir, int i, int step, uint morph)
{
	ivec2 m = m0 + dir * (i * step);
	float h = sample_height(c, m);
	return (i & 1) != 0 ? morph_along(c, m, dir, step, h, morph) : h;
}

// Height of patch c's border `side` as c draws it (segments of `step` of its samples, morph
// byte `morph`), at `along` finest samples from its sample 0: c's vertex height where it
// has a vertex, on the segment between two elsewhere.
float drawn_edge_height(Instance c, uint side, int along, int step, uint morph)
{
	int last = int(pc.P) - 1;
	int step_g = step * c.scale, i0 = along / step_g, rem = along - i0 * step_g;
	int across = side == 1u || side == 3u ? last : 0;
	ivec2 m0 = side >= 2u ? ivec2(across, 0) : ivec2(0, across), dir = side >= 2u ? ivec2(0, 1) : ivec2(1, 0);
	float ha = run_vertex_height(c, m0, dir, i0, step, morph);
	float h = ha;
	if (rem != 0) {
		float hb = run_vertex_height(c, m0, dir, i0 + 1, step, morph);
		precise float hm = mix(ha, hb, float(rem) / float(step_g));
		h = hm;
	}
	return h;
}

// The height sealed_height() gives at si, a sample on border `side` of `it` that is not a
// patch corner, from the seal record of the quad drawing it (j != 0). The coarser block
// that holds this quad's block holds every vertex of its border edge but the two ends, and
// there (a multiple of any step) both blocks give the same sample, so one record serves the
// whole edge; the arithmetic is sealed_height()'s, so the bits are too.
float sealed_side_height(Instance it, ivec2 si, uint side, uint rec)
{
	uint j = rec & 7u;
	int step = int((rec >> 3u) & 31u);
	Instance c = coarser_at(it, j, neighbour_at(it, side) >> j);
	c.layer = int((rec >> 8u) & 0xffffu);
	ivec2 o = it.base + si * it.scale - c.base; // relative to the coarser patch's sample 0
	uint cside = side ^ 1u;                    // its border facing us
	return drawn_edge_height(c, cside, cside >= 2u ? o.y : o.x, step, rec >> 24u);
}

// Height, in metres, at which every patch drawn around `it`'s border sample si puts a vertex
// there: the point is on the border of `it` and of up to three patches across it; the
// coarsest of them draws that border with its own vertices, and the others put theirs on
// its drawn edge. Returns false when `it` is that coarsest (or level with it): its own
// sample then is the height.
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
			if ((dx == 0 && dy == 0) || q.x < 0 || q.y < 0 || q.x >= n || q.y >= n)
				continue;
			uint a, j = drawn_above(it.level, q, a); // 0: shares our samples, or finer
			if (j != 0u && it.level - j < best) {
				best = it.level - j;
				best_id = a;
				best_q = q >> j;
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
	uint morph;
	// the coarser patch's samples per segment there
	int step = int(BLOCK_CELLS) / int(drawn_border_factor(c, border_block(side, cb), side, morph));
	h = drawn_edge_height(c, side, along, step, morph);
	return true;
}
