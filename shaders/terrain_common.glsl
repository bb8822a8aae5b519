// Declarations shared by the LOD selection compute shaders and the terrain draw.
// The CPU twins are in common/lod.c and common/gpu/terrain.c; keep them in step.

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
	float err;       // Err(P), metres
	float skirt;     // skirt depth, metres
	uint px, py;     // the patch's position in its level
	float pad;
	vec2 frac;       // the camera's fraction of a finest cell
	vec2 spacing;    // finest sample spacing, metres (x east, rows south)
};

uint first_id(uint l) { return ((1u << (2u * l)) - 1u) / 3u; }

// A curtain record (lod_select.comp): drawn patch slot in bits 0-29, its side on the
// terrain's outer edge (0 north, 1 south, 2 west, 3 east) in bits 30-31.
const uint CURTAIN_SLOT_MASK = 0x3fffffffu;

// Static per-patch data from the file: heights of the reconstruction, Err(P), skirt depth
// (negative for patches with nothing to draw).
struct PatchInfo {
	float hmin, hmax, err, skirt;
};

const uint BLOCK_CELLS = 16u;
