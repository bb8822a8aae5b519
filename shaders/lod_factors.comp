#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
#include "terrain_factors.glsl"
#include "terrain_seal.glsl"
// Tessellation factors of every drawn quad patch of one view, once per frame, one
// invocation per quad (dispatched indirectly from the drawn count): the work the control
// shader would otherwise repeat per patch, here spread over all compute lanes. Factors are
// 0 or powers of two up to 16, stored as bytes: outer in x, inner in y (bytes 0, 1); the
// morph bytes (terrain_factors.glsl) of the outer edges in z, of the interior in y byte 2.
layout(local_size_x = 64) in;

// What lod_borders.comp computed for drawn patch `slot`: border block edge `a` (along the
// border) on `side` (0 north, 1 south, 2 west, 3 east): (outer factor | morph byte << 8,
// seal side record);
// corner c (bit 0 east, bit 1 south): (sealed height bits, 1) or (, 0).
// Read as RG32_UINT texels (binding 25 over the buffer lod_borders.comp writes as binding
// 17), as the block records (terrain_draw.glsl).
layout(binding = 25) uniform usamplerBuffer border_texels;
uvec2 border_at(uint i) { return texelFetch(border_texels, int(i)).xy; }
uvec2 border_edge(uint slot, uint side, int a) { return border_at(slot * border_items(pc.blocks) + side * pc.blocks + uint(a)); }
uvec2 border_corner(uint slot, uint c) { return border_at(slot * border_items(pc.blocks) + 4u * pc.blocks + c); }

// The seal record's corner part (terrain_seal.glsl) for a quad with corners s[] (patch
// samples): the sealed height at the patch corner among them, if any.
void seal_corner(uint slot, vec2 s[4], inout uvec4 seal)
{
	float last = float(pc.P - 1u);
	for (int v = 0; v < 4; v++)
		if ((s[v].x == 0.0 || s[v].x == last) && (s[v].y == 0.0 || s[v].y == last)) {
			uvec2 rec = border_corner(slot, (s[v].x == last ? 1u : 0u) | (s[v].y == last ? 2u : 0u));
			if (rec.y != 0u)
				seal.zw = rec;
		}
}

// Where the box of the block at lo (patch samples), between heights range, lies against
// the draw camera's clip volume (the corners are formed from one corner and the matrix's
// columns, the vertices by pos_of(), so each test leaves 0.1 % of w for rounding):
// BLOCK_UNSEEN, all eight corners beyond one plane moved out by 0.1 % (the box is convex,
// so the block shows nothing; no sliver it shows can be culled); BLOCK_INSIDE, every
// corner within every plane moved in by 0.1 %, and 0.1 % of the distance before the far
// plane (draw_eye().w; reversed depth nears 0 there, so a margin relative to w would reach
// deep into the frustum): the rasteriser clips nothing the block draws, unless a seal or
// a curtain reaches beyond its box; BLOCK_CROSSING otherwise.
const uint BLOCK_UNSEEN = 0u, BLOCK_CROSSING = 1u, BLOCK_INSIDE = 2u;
uint block_clip(Instance it, vec2 lo, vec2 range)
{
	mat4 m = draw_vp();
	float far_z = draw_eye().w;
	vec4 c0 = m * vec4(pos_of(it, ivec2(lo), range.x), 1.0);
	float side = float(int(BLOCK_CELLS) * it.scale);
	vec4 ex = m[0] * (side * it.spacing.x), ey = m[1] * (-side * it.spacing.y), ez = m[2] * (range.y - range.x);
	uint outside = 63u;
	bool inside = true;
	for (int c = 0; c < 8; c++) {
		vec4 p = c0 + ((c & 1) != 0 ? ex : vec4(0.0)) + ((c & 2) != 0 ? ey : vec4(0.0)) + ((c & 4) != 0 ? ez : vec4(0.0));
		float wo = 1.001 * p.w, wi = 0.999 * p.w;
		outside &= (p.x < -wo ? 1u : 0u) | (p.x > wo ? 2u : 0u) | (p.y < -wo ? 4u : 0u) | (p.y > wo ? 8u : 0u) |
		           (p.z < -0.001 * p.w ? 16u : 0u) | (p.z > wo ? 32u : 0u);
		inside = inside && p.w > 0.0 && abs(p.x) < wi && abs(p.y) < wi && p.z > far_z && p.z < wi;
	}
	return outside != 0u ? BLOCK_UNSEEN : inside ? BLOCK_INSIDE : BLOCK_CROSSING;
}

// Whether block bl of a layer has a valid sample. One without shows nothing: the fragment
// shader discards every fragment whose nearest sample is no-data, and every point of the
// block, its curtain quad's too, is nearest to one of the block's own samples.
bool block_has_data(int layer, ivec2 bl)
{
	uint bit, i = block_data_index(layer, bl, pc.blocks, bit);
	return ((uint(block_err(i)) >> bit) & 1u) != 0u;
}

// Factors of quad patch k of drawn patch `it`: outer (u = 0 west, v = 0 north, u = 1 east,
// v = 1 south) and inner; all zero discards the quad. `seal`: its seal record; `morph`:
// the morph bytes of the outer edges (x) and of the interior (y), packed as in factors[];
// `inside`: the rasteriser clips none of its triangles (block_clip()).
void quad_factors(uint slot, Instance it, uint k, out vec4 outer, out vec2 inner, out uvec4 seal, out uvec2 morph,
                  out bool inside)
{
	inside = false;
	seal = uvec4(0u);
	morph = uvec2(0xffffffffu, MORPH_FULL);
	vec2 in_s[4];
	float down;
	for (uint v = 0u; v < 4u; v++)
		in_s[v] = quad_corner(k, v, down);
	seal_corner(slot, in_s, seal);
	int b = int(pc.blocks);
	bool cull = (pc.mode & MODE_NO_BLOCK_CULL) == 0u, cull_empty = (pc.mode & MODE_KEEP_EMPTY_BLOCKS) == 0u;
	if (k < pc.blocks * pc.blocks) {
		ivec2 bl = ivec2(in_s[0] / float(BLOCK_CELLS));
		vec2 lo = vec2(bl) * float(BLOCK_CELLS);
		if (cull_empty && !block_has_data(it.layer, bl)) {
			outer = vec4(0.0);
			inner = vec2(0.0);
			return;
		}
		vec4 e = block_eps(it, bl.x, bl.y);
		vec2 range = block_range_at(it.layer, bl);
		bool errors = fine_lod() == FINE_ERRORS;
		// Edges in the order of the outer factors: west, north, east, south.
		const ivec2 toward[4] = ivec2[4](ivec2(-1, 0), ivec2(0, -1), ivec2(1, 0), ivec2(0, 1));
		// Edges on the patch's border first: lod_borders.comp has their factors and seals.
		float f[4];
		uint m[4];
		bool inner_edge[4];
		for (int i = 0; i < 4; i++) {
			ivec2 nb = bl + toward[i];
			inner_edge[i] = nb.x >= 0 && nb.y >= 0 && nb.x < b && nb.y < b;
			if (inner_edge[i])
				continue;
			uint side = side_of_edge(uint(i));
			uvec2 rec = border_edge(slot, side, side >= 2u ? bl.y : bl.x);
			if (i % 2 == 0)
				seal.x = rec.y; // west or east
			else
				seal.y = rec.y; // north or south
			f[i] = float(rec.x & 0xffu);
			m[i] = rec.x >> 8u;
		}
		// A block the draw camera cannot see is not tessellated, and its other factors are
		// not worked out (only its own control shader reads them; each neighbour computes
		// a shared edge's factor itself). Everything it draws lies in its box unless a
		// border takes a coarser patch's heights (a seal): such a block is kept.
		uint clip = !seal_any(seal) ? block_clip(it, lo, range) : BLOCK_CROSSING;
		if (cull && clip == BLOCK_UNSEEN) {
			outer = vec4(0.0);
			inner = vec2(0.0);
			return;
		}
		inside = clip == BLOCK_INSIDE;
		for (int i = 0; i < 4; i++) {
			if (!inner_edge[i])
				continue;
			ivec2 nb = bl + toward[i];
			vec4 eps = max(edge_eps_at(it.layer, bl, uint(i), e),
			               edge_eps_at(it.layer, nb, uint(i + 2) % 4u, block_eps(it, nb.x, nb.y)));
			vec2 rn = block_range_at(it.layer, nb), er = vec2(min(range.x, rn.x), max(range.y, rn.y));
			vec2 a, c;
			block_edge(bl, side_of_edge(uint(i)), a, c);
			f[i] = edge_factor(it, a, c, eps, er, m[i]);
		}
		outer = vec4(f[0], f[1], f[2], f[3]);
		morph.x = m[0] | (m[1] << 8u) | (m[2] << 16u) | (m[3] << 24u);
		if (errors) { // isotropic: see the top of terrain_factors.glsl
			inner = vec2(interior_factor(it, lo, e, range, outer, morph.y));
		} else { // the distance baseline keeps one inner factor per direction, as such schemes do
			inner = vec2(max(f[1], f[3]), max(f[0], f[2]));
		}
	} else {
		uint j = k - pc.blocks * pc.blocks, side = j / pc.blocks;
		int i = int(j % pc.blocks);
		if (has_neighbour(it, side) || (pc.mode & MODE_NO_SKIRTS) != 0u ||
		    (cull_empty && !block_has_data(it.layer, border_block(side, i)))) {
			// Inside the terrain every border is sealed: matched at one level, drawn on
			// the coarser edge between levels. Only the terrain's edge hangs a curtain.
			outer = vec4(0.0);
			inner = vec2(0.0);
			return;
		}
		uint rec = border_edge(slot, side, i).x, mb = rec >> 8u;
		float f = float(rec & 0xffu);
		outer = vec4(1.0, f, 1.0, f);
		inner = vec2(f, 1.0);
		morph.x = mb | (mb << 8u) | (mb << 16u) | (mb << 24u); // the border edge's, top and bottom
	}
}

layout(std430, binding = 13) writeonly buffer Factors { uvec4 factors[]; };
layout(std430, binding = 16) writeonly buffer Seals { uvec4 seals[]; };

void main()
{
	uint q = gl_GlobalInvocationID.x;
	if (q >= counted_quads())
		return;
	uint slot, k;
	quad_of(q, slot, k);
	vec4 o;
	vec2 i;
	uvec4 seal;
	uvec2 m;
	bool inside;
	quad_factors(slot, inst_at(slot), k, o, i, seal, m, inside);
	seals[q] = seal;
	uvec4 ob = uvec4(o);
	uvec2 ib = uvec2(i);
	// A drawn quad that the rasteriser may clip goes to the clipped list (w bit 0) when back
	// faces are culled: the other pipeline draws it (docs/lod.md, "Back faces"). One with a
	// seal (w bit 1) is drawn by the pipelines with the seal code (SEAL_CODE), the others
	// without it. lod_commands.comp lists them so.
	bool listed = draw_culled() && ob.x != 0u && !inside;
	bool sealed = seal_any(seal);
	factors[q] = uvec4(ob.x | (ob.y << 8u) | (ob.z << 16u) | (ob.w << 24u), ib.x | (ib.y << 8u) | (m.y << 16u), m.x,
	                   (listed ? 1u : 0u) | (sealed ? 2u : 0u));
}
