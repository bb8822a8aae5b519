#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
// Coarse LOD for one view (common/lod.c is the CPU reference). It visits the patches all of
// whose ancestors are in the frustum and want to split: the top TOP_LEVELS levels in one
// dispatch, an invocation per patch (main()), then one dispatch per deeper level, one
// invocation per patch of that level's frontier. So the work follows the tree the view
// draws, not the whole tree: a 10-level tree has 349,525 patches, a view visits a few
// hundred. A visited patch of level TOP_LEVELS - 1 or deeper appends its four children to
// the next level's frontier when it is in the frustum and wants to split, and raises that
// level's workgroup count (the next dispatch is indirect). A frontier entry carries whether
// every ancestor is resident with its children there (so the patch can be drawn), and the
// distance to the parent's box.
// A patch wants to split by its screen-space error (with hysteresis: bit 0 of its split
// state, the view's last frame's decision, 0 for a patch that frame did not visit) or when
// lod_force.comp, run before for trees of 3 levels or more, set bit 1. It is drawn when
// it is resident, in the frustum, and either does not want to split or lacks children.
// Box, distance and error use the same float arithmetic as the CPU, written `precise` so
// that no multiply-add is fused.
// Requests look ahead: a missing patch of the frontier is asked for whether its ancestors
// are resident or not (it belongs to the tree this view draws once everything has
// arrived), so a cold cache or a camera that jumps asks for the whole chain down to the
// finest patch it needs in one frame, not one level per round trip. Each request carries
// the distance from the camera to the patch's parent's box: nearest first, and the four
// siblings a split needs alike, so that a cache short of layers completes one sibling set
// before it starts the next.
layout(local_size_x = 64) in;

// Levels 0 .. TOP_LEVELS - 1 are visited by the first dispatch (main()).
const uint TOP_LEVELS = 4u; // common/gpu/terrain_internal.h: SELECT_TOP_LEVELS

layout(std430, binding = 2) readonly buffer SplitPrev { uint split_prev[]; };
layout(std430, binding = 3) writeonly buffer SplitNext { uint split_next[]; };
layout(std430, binding = 4) writeonly buffer Instances { Instance inst[]; };
#include "lod_counters.glsl"
layout(std430, binding = 6) writeonly buffer Wants { uvec2 want[]; }; // id, distance (float bits)
layout(std430, binding = 7) writeonly buffer Use { uint use_frame[]; };
// [2][entries]: per frame parity, the least distance to the parent's box at which a view of
// that frame wanted each resident patch (float bits; the cache's eviction reads it).
layout(std430, binding = 18) buffer UseDist { uint use_dist[]; };
layout(std430, binding = 12) writeonly buffer Drawn { uint drawn[]; }; // this view, this frame; cleared before
layout(std430, binding = 14) writeonly buffer Curtains { uint curtain[]; }; // sides on the terrain's edge
// Level l's frontier at [window_at(l).z, window_at(l).z + its count), at most the level's entries
// (patch_entry.glsl: EMPTY children without one are not pushed): (id | 1 << 31 when every
// ancestor is resident with its children there, distance to the parent's box as float bits).
layout(std430, binding = 20) buffer Frontier { uvec2 frontier[]; };
// Per level: the VkDispatchIndirectCommand of its pass (x, 1, 1) and its frontier's count (w).
layout(std430, binding = 21) buffer LevelPasses { uvec4 passes[]; };

#include "lod_select_common.glsl"
#include "terrain_texels.glsl"
#include "draw_camera.glsl"
#include "lod_eye.glsl"

bool culled(vec3 bmin, vec3 bmax)
{
	int out_count[6] = int[6](0, 0, 0, 0, 0, 0);
	for (int k = 0; k < 8; k++) {
		vec3 p = vec3((k & 1) != 0 ? bmax.x : bmin.x, (k & 2) != 0 ? bmax.y : bmin.y, (k & 4) != 0 ? bmax.z : bmin.z);
		vec4 c = pc.vp * vec4(p, 1.0);
		out_count[0] += c.x < -c.w ? 1 : 0;
		out_count[1] += c.x > c.w ? 1 : 0;
		out_count[2] += c.y < -c.w ? 1 : 0;
		out_count[3] += c.y > c.w ? 1 : 0;
		out_count[4] += c.z < 0.0 ? 1 : 0;
		out_count[5] += c.z > c.w ? 1 : 0;
	}
	for (int i = 0; i < 6; i++)
		if (out_count[i] == 8)
			return true;
	return false;
}

bool wants_split(uint l, uint e, float d)
{
	return wants_split_by(l, e, d, split_prev[e]);
}

// Child k (0..3: row-major) of the patch at p of level l: its entry, NO_ENTRY when EMPTY
// outside its window (never missing, never drawn).
uint child_entry(uint l, uvec2 p, uint k) { return entry_at(l + 1u, ivec2(2u * p + uvec2(k & 1u, k >> 1u))); }

bool child_missing(uint c) { return c != NO_ENTRY && info_at(c).skirt >= 0.0 && layer_at(c) < 0; }

// Whether none of the children of the patch at p of level l is missing; ce: their entries
// (child_entry(), row-major).
bool children_there(uint l, uvec2 p, out uint ce[4])
{
	bool there = true;
	for (uint k = 0u; k < 4u; k++) {
		ce[k] = child_entry(l, p, k);
		there = there && !child_missing(ce[k]);
	}
	return there;
}

// Appends the children of a patch of level l that have entries (ce: their entries, ids: their
// ids, row-major) to level l + 1's frontier.
void push_children(uint l, uint ce[4], uint ids[4], bool reachable, float d)
{
	uint m = 0u;
	for (uint k = 0u; k < 4u; k++)
		m += ce[k] != NO_ENTRY ? 1u : 0u;
	uint n = atomicAdd(passes[l + 1u].w, m);
	atomicMax(passes[l + 1u].x, (n + m + 63u) / 64u);
	uint at = window_at(l + 1u).z + n;
	uint mark = reachable ? 0x80000000u : 0u, dist = floatBitsToUint(d);
	for (uint k = 0u; k < 4u; k++)
		if (ce[k] != NO_ENTRY)
			frontier[at++] = uvec2(ids[k] | mark, dist);
}

// Visits the patch (l, px, py) of entry e and id `id`, on the view's tree: all of its
// ancestors are in the frustum and want to split. marked: every ancestor is resident with
// its children there; parent_d: the distance to its parent's box (the root's own).
void visit(uint l, uint id, uint px, uint py, uint e, bool marked, float parent_d)
{
	uint side = 1u << l;
	vec3 bmin, bmax;
	box(l, px, py, e, bmin, bmax);
	float d = distance_to(bmin, bmax);
	if (l == 0u)
		parent_d = d;
	bool wish = wants_split(l, e, d);
	split_next[e] = wish ? 1u : 0u;
	if (l > 0u && child_missing(e)) {
		uint n = atomicAdd(counters.wants, 1u);
		if (n < pc.want_cap)
			want[n] = uvec2(id, floatBitsToUint(parent_d));
	}
	// A wanted patch is in use even when not drawn (its siblings may still be missing): so
	// that a cache short of layers does not evict it to make room for its siblings, and
	// then again them for it, every frame.
	if (layer_at(e) >= 0) {
		use_frame[e] = pc.frame;
		atomicMin(use_dist[(pc.frame & 1u) * entry_count() + e], floatBitsToUint(parent_d));
	}
	if (culled(bmin, bmax))
		return;
	bool reachable = marked && layer_at(e) >= 0;
	if (wish) {
		uint c0 = first_id(l + 1u) + 2u * py * (2u << l) + 2u * px, row = 2u << l;
		uint ids[4] = uint[4](c0, c0 + 1u, c0 + row, c0 + row + 1u), ce[4];
		bool there = children_there(l, uvec2(px, py), ce);
		// The top levels' patches are each visited by their own invocation of the first
		// dispatch (main()); deeper ones through the frontiers.
		if (l + 1u >= TOP_LEVELS)
			push_children(l, ce, ids, reachable && there, d);
		if (reachable && there)
			return; // the children draw this area
	}
	if (!reachable)
		return;
	uint n = atomicAdd(counters.drawn, 1u);
	Instance it;
	it.id = id;
	it.layer = layer_at(e);
	it.level = l;
	float q2 = 2.0 * pc.delta_finest; // 2 delta_l = 2 delta_L ratio^(L - l), exact in float
	for (uint k = l + 1u; k < pc.levels; k++)
		q2 *= float(pc.ratio);
	it.q2 = q2;
	int span = int(pc.P - 1u) << (pc.levels - 1u - l);
	it.base = ivec2(int(px) * span, int(py) * span) - pc.cell;
	it.scale = 1 << (pc.levels - 1u - l);
	it.err = info_at(e).err;
	it.skirt = info_at(e).skirt;
	it.px = px;
	it.py = py;
	it.pad = 0.0;
	it.frac = pc.frac;
	it.spacing = pc.spacing;
	inst[n] = it;
	drawn[e] = 1u;
	// The border pass's size (an item per border block edge and corner; lod_borders.comp's
	// first invocation also decides about back faces: the frame starts it at 1 group), and
	// the eye's height bound (lod_eye.glsl).
	uint blocks = (pc.P - 1u) / BLOCK_CELLS;
	atomicMax(counters.border_groups.x, ((n + 1u) * border_items(blocks) + 63u) / 64u);
	blocks_near_eye(it, eye_rows(), blocks);
	// Sides on the terrain's outer edge hang a curtain (the only skirts: inside, borders
	// are sealed).
	for (uint s = 0u; s < 4u; s++) {
		bool edge = s == 0u ? py == 0u : s == 1u ? py + 1u == side : s == 2u ? px == 0u : px + 1u == side;
		if (edge)
			curtain[atomicAdd(counters.curtains, 1u)] = n | (s << 30u);
	}
}

// The first dispatch (pc.level 0) visits the top TOP_LEVELS levels at once, an invocation
// per patch (ids are numbered level by level: invocation i is patch i): each decides from
// its ancestors' boxes, split states and residency whether its patch is on the view's
// tree, with the same arithmetic that visits them, so it takes the same decisions as
// level-by-level frontiers would. At most 85 invocations, each re-deriving at most 3
// ancestors, so the cost is bounded whatever the tree; a 4-level tree takes one dispatch
// instead of four, 0.04-0.10 ms less per frame on lavapipe (docs/lod-performance.md, "The
// top levels in one dispatch"). Deeper levels go level by level over their frontiers
// (pc.level >= TOP_LEVELS).
void main()
{
	uint l = pc.level;
	if (l == 0u) {
		uint id = gl_GlobalInvocationID.x, top = min(TOP_LEVELS, pc.levels);
		if (id >= first_id(top))
			return;
		uint lv = 0u;
		while (id >= first_id(lv + 1u))
			lv++;
		uint local = id - first_id(lv), side = 1u << lv;
		uint px = local % side, py = local / side;
		uint e = entry_at(lv, ivec2(px, py));
		if (e == NO_ENTRY)
			return;
		bool on_tree = true, marked = true;
		float parent_d = 0.0;
		for (uint a = 0u; a < lv; a++) {
			uint s = lv - a, ax = px >> s, ay = py >> s;
			uint ae = entry_at(a, ivec2(ax, ay)); // an ancestor of a patch with an entry has one
			vec3 bmin, bmax;
			box(a, ax, ay, ae, bmin, bmax);
			float d = distance_to(bmin, bmax);
			on_tree = on_tree && wants_split(a, ae, d) && !culled(bmin, bmax);
			uint ce[4];
			marked = marked && layer_at(ae) >= 0 && children_there(a, uvec2(ax, ay), ce);
			parent_d = d;
		}
		if (on_tree)
			visit(lv, id, px, py, e, marked, parent_d);
		return;
	}
	if (gl_GlobalInvocationID.x >= passes[l].w)
		return;
	uvec2 f = frontier[window_at(l).z + gl_GlobalInvocationID.x];
	uint id = f.x & 0x7fffffffu;
	uint local = id - first_id(l), side = 1u << l;
	uint px = local % side, py = local / side;
	uint e = entry_at(l, ivec2(px, py)); // pushed only with one
	visit(l, id, px, py, e, (f.x & 0x80000000u) != 0u, uintBitsToFloat(f.y));
}
