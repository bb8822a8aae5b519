// Declarations shared by the LOD selection compute shaders and the terrain draw.
// The CPU twins are in common/lod.c and common/gpu/terrain.c; keep them in step.

// One drawn patch: written by lod_select.comp, read by the terrain stages.
struct Instance {
	uint id;
	int layer;
	uint level;
	float q2;        // metres per quantum at the patch's level
	vec2 origin;     // camera-relative metres of the patch's sample (0, 0) (north-west)
	vec2 step;       // metres per level sample (x east, y south)
	float err;       // Err(P), metres
	float skirt;     // skirt depth, metres
	float pad0, pad1;
};

// Static per-patch data from the file: heights of the reconstruction, Err(P), skirt depth
// (negative for patches with nothing to draw).
struct PatchInfo {
	float hmin, hmax, err, skirt;
};

const uint BLOCK_CELLS = 16u;
