// Whether back faces are culled (docs/lod.md, "Back faces"): the drawing camera must be
// above the surface drawn under it. That surface, at the eye's x, y, is a triangle of the
// drawn block b containing the point, with vertices among b's samples, blends of them, or a
// coarser patch's samples on b's border, which lie in that patch's block touching b. Every
// drawn block within its own side of the eye (Chebyshev distance) includes b and those
// coarser blocks (each at least b's side), so the largest height range over them bounds the
// surface there. If no drawn block holds the eye (the patch under it is outside the
// frustum), the CPU's conservative decision stands.
// The selection (lod_select.comp) raises the bound patch by patch as it draws them;
// lod_borders.comp, the pass after it, decides. Needs lod_counters.glsl, terrain_texels.glsl
// and draw_camera.glsl.

// Float bits as an unsigned key that orders like the floats (for atomicMax).
uint height_key(float h)
{
	uint b = floatBitsToUint(h);
	return (b & 0x80000000u) != 0u ? ~b : b | 0x80000000u;
}

float key_height(uint k) { return uintBitsToFloat((k & 0x80000000u) != 0u ? k & 0x7fffffffu : ~k); }

// The drawing eye relative to the LOD camera, x east, y south (rows), metres.
vec2 eye_rows() { vec4 e = draw_eye(); return vec2(e.x, -e.y); }

// Drawn patch it's blocks (blocks x blocks of them) within their own side of the eye: their
// largest height range raises counters.near_high, and one holding the eye (within half a
// finest cell) sets counters.found. Only the patches around the eye get past the first test.
void blocks_near_eye(Instance it, vec2 eye, uint blocks)
{
	vec2 side = it.spacing * float(it.scale * int(BLOCK_CELLS));
	vec2 origin = (vec2(it.base) - it.frac) * it.spacing;
	vec2 f = (eye - origin) / side; // the eye in block units of this patch
	if (any(lessThan(f, vec2(-1.0))) || any(greaterThan(f, vec2(float(blocks) + 1.0))))
		return;
	ivec2 c = ivec2(floor(f));
	for (int by = c.y - 2; by <= c.y + 2; by++)
		for (int bx = c.x - 2; bx <= c.x + 2; bx++) {
			if (bx < 0 || by < 0 || bx >= int(blocks) || by >= int(blocks))
				continue;
			vec2 lo = origin + vec2(bx, by) * side, hi = lo + side;
			vec2 d = max(max(lo - eye, eye - hi), vec2(0.0));
			if (max(d.x, d.y) > max(side.x, side.y))
				continue;
			atomicMax(counters.near_high, height_key(block_err(block_range_index(it.layer, ivec2(bx, by), blocks) + 1u)));
			if (all(lessThanEqual(d, 0.5 * it.spacing)))
				atomicOr(counters.found, 1u);
		}
}

// The decision, once every drawn patch has been seen: the drawing eye's height against the
// bound plus a margin (draw_camera's cull texel: x the margin in metres, y the CPU's
// decision for when no block holds the eye, z whether the GPU's decision splits the draws).
// near_high turns from a key into metres.
void eye_decide()
{
	vec4 cull = draw_cull();
	bool found = counters.found != 0u, cpu_cull = cull.y != 0.0;
	float high = key_height(counters.near_high);
	bool gpu = found ? draw_eye().z > high + cull.x : cpu_cull;
	counters.face_culled = gpu ? 1u : 0u;
	counters.near_high = floatBitsToUint(high);
	counters.draw_culled = (cull.z != 0.0 ? gpu : cpu_cull) ? 1u : 0u;
}
