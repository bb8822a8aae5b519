// Declarations shared by the LOD selection compute shaders and the terrain draw.
// The CPU twins are in common/lod.c and common/gpu/terrain_internal.h; keep them in step.

// One drawn patch: written by lod_select.comp, read by the terrain stages. Positions are
// formed from integer sample indices relative to the camera's cell (pos_of), so that two
// patches compute bit-identical positions for the samples they share.
struct Instance {
	uint id;
	int layer;
	uint level;
	float q2;        // metres per quantum at the patch's level
	ivec2 base;      // finest-grid index (column, row) of the patch's sample (0, 0), minus the camera's cell
	int scale;       // finest samples per sample of the patch's level
	float err;       // the selection's error (PatchInfo), metres
	float skirt;     // skirt depth, metres
	uint px, py;     // the patch's position in its level
	float pad;
	vec2 frac;       // the camera's fraction of a finest cell
	vec2 spacing;    // finest sample spacing, metres (x east, rows south)
};

// An instance from its four uvec4 (bit casts only, so the same bits): the struct's 16 words
// in memory order, which is how the instance buffer's RGBA32_UINT texels hold it
// (terrain_texels.glsl) and how the control shader hands it to the evaluation shader as
// patch data, fetched once per quad rather than per vertex.
Instance instance_unpack(uvec4 p[4])
{
	return Instance(p[0].x, int(p[0].y), p[0].z, uintBitsToFloat(p[0].w), ivec2(p[1].xy), int(p[1].z),
	                uintBitsToFloat(p[1].w), uintBitsToFloat(p[2].x), p[2].y, p[2].z, uintBitsToFloat(p[2].w),
	                uintBitsToFloat(p[3].xy), uintBitsToFloat(p[3].zw));
}

uint first_id(uint l) { return ((1u << (2u * l)) - 1u) / 3u; }

// In the subtree of patch q, m patches a side a level (m = 2^k, k levels finer), the a-th
// along q's border that faces the patch q lies on `side` of (0 north, 1 south, 2 west,
// 3 east): q's last row, first row, last column or first column.
ivec2 facing_cell(ivec2 q, int m, uint side, int a)
{
	return side == 0u ? ivec2(q.x * m + a, q.y * m + m - 1) : side == 1u ? ivec2(q.x * m + a, q.y * m)
	     : side == 2u ? ivec2(q.x * m + m - 1, q.y * m + a) : ivec2(q.x * m, q.y * m + a);
}

// The block `a` blocks along the border `side` (0 north, 1 south, 2 west, 3 east; along
// runs west to east or north to south) of a patch of `blocks` blocks a side.
ivec2 border_block_in(uint side, int a, uint blocks)
{
	int last = int(blocks) - 1;
	return side == 0u ? ivec2(a, 0) : side == 1u ? ivec2(a, last) : side == 2u ? ivec2(0, a) : ivec2(last, a);
}

// A block's edge index (0 west, 1 north, 2 east, 3 south: the outer factors' order) of
// side `side` (0 north, 1 south, 2 west, 3 east).
uint edge_of_side(uint side) { return side == 0u ? 1u : side == 1u ? 3u : side == 2u ? 0u : 2u; }
// And back: the side (0 north, 1 south, 2 west, 3 east) of edge `edge` (0 west, 1 north, 2 east, 3 south).
uint side_of_edge(uint edge) { return edge == 0u ? 2u : edge == 1u ? 0u : edge == 2u ? 3u : 1u; }

// A drawn patch's border items (lod_borders.comp, one invocation and one record each): the
// block edges of its 4 sides (north, south, west, east; `blocks` each), then its 4 corners.
uint border_items(uint blocks) { return 4u * blocks + 4u; }

// A curtain record (lod_select.comp): drawn patch slot in bits 0-29, its side on the
// terrain's outer edge (0 north, 1 south, 2 west, 3 east) in bits 30-31.
const uint CURTAIN_SLOT_MASK = 0x3fffffffu;

// Static per-patch data from the file: heights of the reconstruction, the selection's error
// (the drawn error E0(P), common/format.h, or where the data has gaps under a coarse patch
// its share of the coverage error if larger: relief_patch_select_error(), common/lod.h),
// skirt depth (negative for patches with nothing to draw).
struct PatchInfo {
	float hmin, hmax, err, skirt;
};

#include "block_record.glsl"
