// Per-patch buffers (patch info, layer and use tables, split state, drawn marks, use
// distances, frontiers) have one element per *entry*: a patch's record number in the
// file's index (relief_index_entry(), docs/format.md). Level l's entries are the patches
// whose footprint starts inside the raster, px < cols and py < rows of window[l], row by
// row from entry window[l].z; any other patch is EMPTY (nothing drawn, nothing requested)
// and has none. So these buffers follow the data, not the square tree: a 262 km strip in a
// 13-level tree has 8,191 entries for 22.4 million patches. Levels beyond the tree have
// empty windows.
layout(std430, binding = 22) readonly buffer Windows { uvec4 window[]; }; // cols, rows, first entry, 0

const uint NO_ENTRY = 0xffffffffu;

// The entry of the patch at q of level l, or NO_ENTRY (outside its window or the tree).
uint entry_at(uint l, ivec2 q)
{
	if (l >= uint(window.length()))
		return NO_ENTRY;
	uvec4 w = window[l];
	if (q.x < 0 || q.y < 0 || uint(q.x) >= w.x || uint(q.y) >= w.y)
		return NO_ENTRY;
	return w.z + uint(q.y) * w.x + uint(q.x);
}
