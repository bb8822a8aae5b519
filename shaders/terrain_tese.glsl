// The terrain's evaluation shader (terrain.tese; terrain_mesh.tese, with RELIEF_MESH defined,
// also passes each vertex's position on to the mesh capture, terrain_mesh.geom).
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
#include "terrain_factors.glsl"
#include "terrain_seal.glsl"
// Vertices land on samples (factors are 16 / 2^d), displaced by the decoded heights;
// positions are camera-relative, so floats stay small at any world coordinates, and formed
// by pos_of() so that patches sharing a border put its vertices at the same bits. A border
// vertex next to a coarser patch takes its height on that patch's drawn edge; any other
// vertex that its edge's or interior's next coarser level lacks is morphed towards that
// level (terrain_factors.glsl).
layout(quads, equal_spacing, ccw) in;
layout(location = 2) in vec2 in_s[];
layout(location = 3) in float in_down[];
layout(location = 4) patch in uvec4 in_seal; // this quad's seal record (terrain_seal.glsl)
layout(location = 5) patch in uvec4 in_inst[4]; // its patch's instance (instance_unpack())
// The quad's factors[] record (lod_factors.comp): outer factors (x), inner factors and the
// interior's morph byte (y), the outer edges' morph bytes (z).
layout(location = 9) patch in uvec3 in_factors;
layout(location = 1) flat out float out_q2; // metres per quantum of the patch's heights
layout(location = 2) out vec2 out_s;          // patch sample coordinates: validity, normal, height per fragment
layout(location = 3) flat out int out_layer;
precise gl_Position; // shared border vertices get identical bits in both patches
#ifdef RELIEF_MESH
// The vertex as drawn, exactly: its finest-grid index (column, row) relative to the
// camera's cell, the height drawn there (metres) and the patch's id.
layout(location = 7) flat out ivec2 out_grid;
layout(location = 8) flat out float out_height;
layout(location = 9) flat out uint out_id;
// And its quad's (relief_mesh_quad): outer factors (a byte each: west, north, east,
// south), inner factor | log2(finest samples per patch sample) << 8, and the finest-grid
// index of the quad's first corner, relative to the camera's cell.
layout(location = 10) flat out uvec4 out_quad;
#endif

// Height of sample si of a quad whose corners are samples lo (0, 0) and hi (1, 1) at its
// morphed level, given its own height h. On an outer edge (si on the quad's border, not a
// corner) the edge's factor and morph byte apply along it; inside, the inner factor's (an
// inner factor of 1 is drawn as 2, the centre alone). A curtain quad (`curtain`, lo and hi
// on the terrain's edge) morphs along its top edge like the block above it.
float morphed_height(Instance it, ivec2 si, ivec2 lo, ivec2 hi, bool curtain, float h)
{
	// An outer edge k (factor order: west, north, east, south) or a curtain's top edge, along
	// dir from lo; a curtain's morph bytes are all its border edge's.
	uint k;
	ivec2 dir;
	bool w = si.x == lo.x, e = si.x == hi.x, n = si.y == lo.y, s = si.y == hi.y;
	if (curtain) {
		k = 1u;
		dir = clamp(hi - lo, ivec2(-1), ivec2(1));
	} else if ((w || e) && (n || s)) {
		return h; // a block corner: on every level
	} else if (w || e || n || s) {
		k = w ? 0u : n ? 1u : e ? 2u : 3u;
		dir = (w || e) ? ivec2(0, 1) : ivec2(1, 0);
	} else {
		int step = int(BLOCK_CELLS) / max(int(in_factors.y & 0xffu), 2);
		ivec2 ij = (si - lo) / step;
		uint m = (in_factors.y >> 16u) & 0xffu;
		if ((ij.x & 1) != 0 && (ij.y & 1) != 0) { // a cell's centre: the mean of both diagonals' ends
			float a = sample_height(it, si + ivec2(-step, -step)), b = sample_height(it, si + ivec2(step, step));
			float c = sample_height(it, si + ivec2(step, -step)), d = sample_height(it, si + ivec2(-step, step));
			precise float ab = 0.5 * (a + b), cd = 0.5 * (c + d);
			return morph_height(ab, h, cd, m);
		}
		if ((ij.x & 1) != 0)
			return morph_along(it, si, ivec2(1, 0), step, h, m);
		if ((ij.y & 1) != 0)
			return morph_along(it, si, ivec2(0, 1), step, h, m);
		return h;
	}
	int step = int(BLOCK_CELLS) / int(in_factors.x >> (8u * k) & 0xffu);
	int i = (dir.x * (si - lo).x + dir.y * (si - lo).y) / step; // lo and hi are its ends: i >= 0
	return (i & 1) != 0 ? morph_along(it, si, dir, step, h, (in_factors.z >> (8u * k)) & 0xffu) : h;
}

void main()
{
	Instance it = instance_unpack(in_inst);
	vec2 s = mix(mix(in_s[0], in_s[1], gl_TessCoord.x), mix(in_s[2], in_s[3], gl_TessCoord.x), gl_TessCoord.y);
	float down = mix(mix(in_down[0], in_down[1], gl_TessCoord.x), mix(in_down[2], in_down[3], gl_TessCoord.x),
	                 gl_TessCoord.y);
	ivec2 si = clamp(ivec2(s + 0.5), ivec2(0), ivec2(int(pc.P) - 1));
	float h = sample_height(it, si);
	int last = int(pc.P) - 1;
	// On a coarser patch's drawn edge (no crack between levels): the height sealed_height()
	// gives, from the record the factor pass wrote, so that this shader does no search.
	bool ex = si.x == 0 || si.x == last, ey = si.y == 0 || si.y == last, sealed = false;
	if (!SEAL_CODE) {
		// a quad without seals (lod_factors.comp): its own samples everywhere
	} else if (ex && ey) {
		sealed = in_seal.w != 0u;
		if (sealed)
			h = uintBitsToFloat(in_seal.z);
	} else if (ex || ey) {
		uint rec = ex ? in_seal.x : in_seal.y;
		sealed = (rec & 7u) != 0u;
		if (sealed)
			h = sealed_side_height(it, si, ex ? (si.x == 0 ? 2u : 3u) : (si.y == 0 ? 0u : 1u), rec);
	}
	if (MORPH_CODE && !sealed && (in_factors.z != 0xffffffffu || (in_factors.y >> 16u) != MORPH_FULL))
		h = morphed_height(it, si, ivec2(in_s[0] + 0.5), ivec2(in_s[3] + 0.5), in_down[3] > 0.0, h);
	out_s = vec2(si);
	out_layer = it.layer;
	out_q2 = it.q2;
	vec3 p = pos_of(it, si, h);
	if (down > 0.0)
		p.z -= down * it.skirt;
	gl_Position = draw_vp() * vec4(p, 1.0);
#ifdef RELIEF_MESH
	out_grid = it.base + si * it.scale;
	out_height = down > 0.0 ? h - down * it.skirt : h;
	out_id = it.id;
	out_quad = uvec4(in_factors.x, (in_factors.y & 0xffu) | uint(findMSB(it.scale)) << 8u,
	                 uvec2(it.base + ivec2(in_s[0] + 0.5) * it.scale));
#endif
}
