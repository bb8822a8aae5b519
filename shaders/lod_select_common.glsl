// What the selection (lod_select.comp) and its pre-pass (lod_force.comp) share: the push
// block, patch boxes, distances and the split rule. The including shader declares
// `info` (PatchInfo[], binding 0) first.

layout(push_constant) uniform Push {
	mat4 vp;          // camera-relative view-projection
	ivec2 cell;       // camera's finest sample cell
	vec2 frac;        // and its fraction
	vec2 spacing;     // finest spacing, metres
	float cam_z, kappa, tau; // kappa: relief_view_error_kappa(), the baselines' relief_view_kappa() (common/lod.h)
	uint frame;
	uint level;       // lod_select.comp: the level this dispatch visits
	uint levels, P, want_cap;
	float delta_finest; // tolerance of the finest level, metres
	uint ratio;
} pc;

// The share of tau the selection's own rule takes (pc.tau is tau times it):
// RELIEF_LOD_COARSE_SHARE, common/lod.h.
const float COARSE_SHARE = 0.5;

// Entries in the tree (patch_entry.glsl): the per-patch buffers' length.
uint entry_count() { uvec4 w = window_at(pc.levels - 1u); return w.z + w.x * w.y; }

// The box of the patch at (px, py) of level l, whose entry is e.
void box(uint l, uint px, uint py, uint e, out vec3 bmin, out vec3 bmax)
{
	int span = int(pc.P - 1u) << (pc.levels - 1u - l);
	precise float x0 = (float(int(px) * span - pc.cell.x) - pc.frac.x) * pc.spacing.x;
	precise float y0 = (float(int(py) * span - pc.cell.y) - pc.frac.y) * pc.spacing.y;
	precise float w = float(span) * pc.spacing.x, h = float(span) * pc.spacing.y;
	precise float x1 = x0 + w, y1 = y0 + h;
	bmin = vec3(x0, -y1, info_at(e).hmin - pc.cam_z);
	bmax = vec3(x1, -y0, info_at(e).hmax - pc.cam_z);
}

float distance_to(vec3 bmin, vec3 bmax)
{
	precise vec3 d = max(max(bmin, -bmax), vec3(0.0));
	precise float d2 = d.x * d.x + d.y * d.y + d.z * d.z;
	return sqrt(d2);
}

// Whether the patch of entry e (level l, at distance d from the camera) wants to split, given its
// split state from the view's last frame (`prev`): bit 0 split then (hysteresis), bit 1
// forced this frame by lod_force.comp (a patch 5 levels finer would be drawn beside it).
bool wants_split_by(uint l, uint e, float d, uint prev)
{
	if (l + 1u >= pc.levels)
		return false;
	precise float err = d > 0.0 ? info_at(e).err * pc.kappa / d : 1.0 / 0.0;
	return (prev & 2u) != 0u || err > pc.tau || ((prev & 1u) != 0u && err > 0.8 * pc.tau);
}
