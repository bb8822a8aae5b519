// Bindings, push constants and helpers of the terrain draw stages (common/gpu/terrain_internal.h).
// Needs patch_entry.glsl (per-patch buffers by entry).
// What the selection and lod_commands.comp wrote as storage buffers, read here as uniform
// texel buffers (patch_entry.glsl says why; even a word every lane reads alike is a load per
// lane from a storage buffer in lavapipe): the counters (binding 5 as R32_UINT texels,
// binding 30; struct counters in common/gpu/terrain_internal.h), the drawn marks by entry
// (binding 12 as 29) and the curtains, the terrain-edge sides of drawn patches (14 as 31).
layout(binding = 30) uniform usamplerBuffer counter_texels;
layout(binding = 29) uniform usamplerBuffer drawn_texels;
layout(binding = 31) uniform usamplerBuffer curtain_texels;
uint counted_patches() { return texelFetch(counter_texels, 0).x; }  // drawn patches
uint counted_curtains() { return texelFetch(counter_texels, 3).x; } // curtains
bool draw_culled() { return texelFetch(counter_texels, 15).x != 0u; } // back faces culled in this frame's draws
#include "draw_camera.glsl"
layout(binding = 9, r32i) uniform readonly iimage2DArray heights;
layout(binding = 10, r32ui) uniform readonly uimage2DArray normals; // packSnorm4x8, see patch_normals.comp

// The normal (xyz) and validity (w: 1 valid, -1 no-data) of sample si of layer `layer`.
vec4 normal_load(ivec2 si, int layer) { return unpackSnorm4x8(imageLoad(normals, ivec3(si, layer)).x); }
#include "terrain_texels.glsl"

layout(push_constant) uniform DrawPush {
	mat4 vp;          // camera-relative view-projection
	vec2 viewport;    // pixels
	float tau;        // pixels
	float cam_z;      // metres
	// per_patch: blocks^2; mode bit 0: wireframe pass; bit 3: no skirts; bit 4: no block
	// culling; bit 6: blocks without data drawn; bit 8: quads taken from the clipped list,
	// not the shown list (lod_commands.comp); bit 9: transition strips unbounded
	uint P, blocks, per_patch, mode;
	vec4 sun;         // xyz: towards the sun
	vec2 hrange;      // colour ramp heights, metres
	float target_px;  // FINE_DISTANCE: wanted triangle edge length, pixels
	uint ratio;       // tolerance growth per coarser level (the codec's k)
} pc;

// The frame's quad patches: every drawn patch's blocks, then every curtain's quads.
uint counted_quads() { return counted_patches() * pc.per_patch + counted_curtains() * pc.blocks; }

const uint FINE_ERRORS = 0u;   // block errors and tau (relief)
const uint FINE_FULL = 1u;     // every block at full resolution (chunked LOD, full grid)
const uint FINE_DISTANCE = 2u; // factor from the edge's projected length (no error metric)
const uint MODE_NO_SKIRTS = 8u; // tests: leave every crack open
const uint MODE_NO_BLOCK_CULL = 16u; // tests: tessellate unseen blocks too (lod_factors.comp)
const uint MODE_KEEP_EMPTY_BLOCKS = 64u; // tests: tessellate blocks without a valid sample too
const uint MODE_CLIPPED_LIST = 256u; // the clipped list's draw (back faces kept)
const uint MODE_LOOSE_STRIPS = 512u; // transition strips unbounded (relief_view.loose_transitions, terrain_factors.glsl)

// Camera-relative position of the patch's sample m (x east, y north, z up) at height h
// metres. Integer finest-grid indices first, one rounding to float after: every patch that
// holds a sample computes the same bits for it, so shared borders meet exactly.
vec3 pos_of(Instance it, ivec2 m, float h)
{
	precise float x = (float(it.base.x + m.x * it.scale) - it.frac.x) * it.spacing.x;
	precise float y = (float(it.base.y + m.y * it.scale) - it.frac.y) * it.spacing.y;
	precise float z = h - pc.cam_z;
	return vec3(x, -y, z);
}

// The block `a` blocks along a patch's border `side` (border_block_in()).
ivec2 border_block(uint side, int a) { return border_block_in(side, a, pc.blocks); }

// The position, at the patch's level, of its neighbour across border `side` (0 north,
// 1 south, 2 west, 3 east); outside [0, 2^level) beyond the terrain's edge.
ivec2 neighbour_at(Instance it, uint side)
{
	return ivec2(it.px, it.py) + (side == 0u ? ivec2(0, -1) : side == 1u ? ivec2(0, 1)
	                            : side == 2u ? ivec2(-1, 0) : ivec2(1, 0));
}

// Whether the patch across border `side` at the same level lies inside the terrain's grid.
bool has_neighbour(Instance it, uint side)
{
	int n = 1 << it.level;
	ivec2 q = neighbour_at(it, side);
	return q.x >= 0 && q.y >= 0 && q.x < n && q.y < n;
}

// The entry of the patch across border `side` at the same level, or NO_ENTRY (beyond the
// terrain's edge, or EMPTY).
uint neighbour_entry(Instance it, uint side)
{
	return has_neighbour(it, side) ? entry_at(it.level, neighbour_at(it, side)) : NO_ENTRY;
}

// Whether the patch at q of `level` is drawn by this view (one without an entry never is).
bool drawn_at(uint level, ivec2 q)
{
	uint e = entry_at(level, q);
	return e != NO_ENTRY && texelFetch(drawn_texels, int(e)).x != 0u;
}

// For cell q of `level` (inside the terrain): when the patch there is not drawn but one of
// its ancestors is, that ancestor's entry and the level difference j >= 1; otherwise 0
// (drawn at this level, drawn finer, or culled).
uint drawn_above(uint level, ivec2 q, out uint entry)
{
	entry = 0u;
	if (drawn_at(level, q))
		return 0u;
	for (uint j = 1u; j <= level; j++) {
		uint l = level - j;
		if (drawn_at(l, q >> j)) {
			entry = entry_at(l, q >> j);
			return j;
		}
	}
	return 0u;
}

// drawn_above() for the neighbour across border `side`; 0 beyond the terrain's edge.
uint coarser_across(Instance it, uint side, out uint ce)
{
	ce = 0u;
	return has_neighbour(it, side) ? drawn_above(it.level, neighbour_at(it, side), ce) : 0u;
}

// Height in metres of sample m of patch `it` (its quantum times q2, the same operations
// wherever a sample's height is needed, so shared samples give the same bits).
float sample_height(Instance it, ivec2 m)
{
	precise float h = it.q2 * float(imageLoad(heights, ivec3(m + 1, it.layer)).x);
	return h;
}

// The kind of frame a pipeline is made for, as specialization constants, so that the
// compiler leaves out what the frame does not ask for: lavapipe runs a shader's code for
// every lane whether or not a lane takes it, and such code slowed every frame (docs/lod.md,
// "Morphing": what it costs when off; "Fine LOD": the compute passes). terrain.c makes
// each pipeline the first time a frame needs it (relief's without morphing with the
// terrain).
// 0: the view geomorphs (relief_view.morph): the blends in the evaluation shader, the
// morph bytes in the factor and border passes. Without it every morph byte is MORPH_FULL.
layout(constant_id = 0) const bool MORPH_CODE = true;
// 1: the fine LOD the factor and border passes compute factors for (FINE_*, the frame's
// relief_draw_options.fine). The draw stages do not read it.
layout(constant_id = 1) const uint FINE_LOD = 0u; // FINE_ERRORS
// 2: the evaluation shader takes heights from coarser patches' drawn edges (the seals,
// terrain_seal.glsl). Off in the pipelines that draw the quads whose seal record is empty
// (lod_factors.comp marks the others; lod_commands.comp lists them apart), so that their
// vertices, most of a frame's, do not run the seal code masked off (docs/lod.md, "Between
// patches").
layout(constant_id = 2) const bool SEAL_CODE = true;

uint fine_lod() { return FINE_LOD; }

// Metres per quantum j levels coarser than `it`: the same sequence of products as the
// selection's (lod_select.comp), so the bits equal the coarser patch's own.
float coarser_q2(Instance it, uint j)
{
	float q2 = it.q2;
	for (uint k = 0u; k < j; k++)
		q2 *= float(pc.ratio);
	return q2;
}

// Quad patch q of the frame: the drawn patches' blocks first (per_patch each, in instance
// order), then the curtains (`blocks` quads each). Its instance slot, and k as quad_corner()
// counts a patch's quads: blocks, then per side (north, south, west, east) `blocks` skirt
// quads.
void quad_of(uint q, out uint slot, out uint k)
{
	uint block_quads = counted_patches() * pc.per_patch;
	if (q < block_quads) {
		slot = q / pc.per_patch;
		k = q % pc.per_patch;
		return;
	}
	uint c = (q - block_quads) / pc.blocks, rec = texelFetch(curtain_texels, int(c)).x;
	slot = rec & CURTAIN_SLOT_MASK;
	k = pc.per_patch + (rec >> 30u) * pc.blocks + (q - block_quads) % pc.blocks;
}

// Corner v (bit 0: +u, bit 1: +v) of quad patch k of a drawn patch, in patch sample
// coordinates: blocks^2 tessellation blocks of 16 x 16 cells, then 4 * blocks skirt quads
// hanging from the patch's border (north, south, west, east); `down` is 1 at a skirt's bottom.
vec2 quad_corner(uint k, uint v, out float down)
{
	vec2 c = vec2(float(v & 1u), float(v >> 1u));
	uint b = pc.blocks;
	if (k < b * b) {
		down = 0.0;
		return (vec2(float(k % b), float(k / b)) + c) * float(BLOCK_CELLS);
	}
	uint j = k - b * b, side = j / b, i = j % b;
	// North and east curtains run the other way, so that every curtain's outer face is
	// counter-clockwise like the blocks' upper side (back faces may be culled).
	float u = side == 0u || side == 3u ? 1.0 - c.x : c.x;
	float along = (float(i) + u) * float(BLOCK_CELLS), last = float(pc.P - 1u);
	down = c.y;
	return side == 0u ? vec2(along, 0.0) : side == 1u ? vec2(along, last) : side == 2u ? vec2(0.0, along)
	                                                                     : vec2(last, along);
}
