// Per-patch buffers (patch info, layer and use tables, split state, drawn marks, use
// distances, frontiers) have one element per *entry*: a patch's record number in the
// file's index (relief_index_entry(), docs/format.md). Level l's entries are the patches
// whose footprint starts inside the raster, px < cols and py < rows of window_at(l), row by
// row from entry window_at(l).z; any other patch is EMPTY (nothing drawn, nothing requested)
// and has none. So these buffers follow the data, not the square tree: a 262 km strip in a
// 13-level tree has 8,191 entries for 22.4 million patches. Levels beyond the tree have
// empty windows.
//
// The index windows (binding 22: per level cols, rows, first entry, 0), the patch info
// (binding 0: PatchInfo per entry) and the cache's layer table (binding 1: the layer of each
// entry's resident patch, -1 when none) are read as uniform texel buffers: no shader writes
// them, and the searches read them at lane-varying indices, which lavapipe (Mesa 22.3) loads
// from a storage buffer lane by lane and from a texel buffer with one gather
// (relief_vk_texel_view_create(); docs/lod-performance.md, "The draw camera and the
// per-patch tables read as texels").
layout(binding = 22) uniform usamplerBuffer window_texels;
layout(binding = 0) uniform samplerBuffer info_texels;
layout(binding = 1) uniform isamplerBuffer layer_texels;

uint window_count() { return uint(textureSize(window_texels)); }
uvec4 window_at(uint l) { return texelFetch(window_texels, int(l)); }

PatchInfo info_at(uint e)
{
	vec4 t = texelFetch(info_texels, int(e));
	return PatchInfo(t.x, t.y, t.z, t.w);
}

int layer_at(uint e) { return texelFetch(layer_texels, int(e)).x; }

const uint NO_ENTRY = 0xffffffffu;

// The entry of the patch at q of level l, or NO_ENTRY (outside its window or the tree).
uint entry_at(uint l, ivec2 q)
{
	if (l >= window_count())
		return NO_ENTRY;
	uvec4 w = window_at(l);
	if (q.x < 0 || q.y < 0 || uint(q.x) >= w.x || uint(q.y) >= w.y)
		return NO_ENTRY;
	return w.z + uint(q.y) * w.x + uint(q.x);
}
