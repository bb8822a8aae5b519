// A layer's block record in the patch cache (binding 11 of the terrain, 5 of the decode
// passes; relief_patch_layer_floats(), common/gpu/patch_cache.h): what the file stores
// for the patch's blocks, copied from staging (blocks^2 x 4 errors, blocks^2 x 2 height
// ranges, then whether each block has a valid sample, 16 blocks per float: an integer,
// bit j of float w: block 16 w + j), then what patch_strips.comp computes from the
// decoded samples: STRIP_FLOATS per block and edge (west, north, east, south).
const uint BLOCK_CELLS = 16u;
const uint STRIP_FLOATS = 8u;

uint stored_floats(uint blocks) { return blocks * blocks * 6u + (blocks * blocks + 15u) / 16u; }

uint layer_record(int layer, uint blocks)
{
	return uint(layer) * (stored_floats(blocks) + blocks * blocks * 4u * STRIP_FLOATS);
}

// Index of block bl's first error and of its range's low end.
uint block_eps_index(int layer, ivec2 bl, uint blocks)
{
	return layer_record(layer, blocks) + (uint(bl.y) * blocks + uint(bl.x)) * 4u;
}

uint block_range_index(int layer, ivec2 bl, uint blocks)
{
	return layer_record(layer, blocks) + blocks * blocks * 4u + (uint(bl.y) * blocks + uint(bl.x)) * 2u;
}

// Index of the float that holds block bl's bit, and the bit.
uint block_data_index(int layer, ivec2 bl, uint blocks, out uint bit)
{
	uint b = uint(bl.y) * blocks + uint(bl.x);
	bit = b % 16u;
	return layer_record(layer, blocks) + blocks * blocks * 6u + b / 16u;
}

// Index of the first strip bound of block bl's edge `edge` (0 west, 1 north, 2 east,
// 3 south: the order of the outer factors).
uint block_strip_index(int layer, ivec2 bl, uint edge, uint blocks)
{
	return layer_record(layer, blocks) + stored_floats(blocks) +
	       ((uint(bl.y) * blocks + uint(bl.x)) * 4u + edge) * STRIP_FLOATS;
}
