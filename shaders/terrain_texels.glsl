// The layers' block records and a view's instances as the terrain's passes and stages read
// them (terrain_draw.glsl, lod_commands.comp). Needs terrain_common.glsl.
// The layers' block records (block_record.glsl), read as R32_SFLOAT texels: a CPU
// implementation gathers a texel buffer's loads for all lanes at once, where it loads a
// storage buffer lane by lane (common/gpu/patch_gpu.c).
layout(binding = 11) uniform samplerBuffer block_records;
float block_err(uint i) { return texelFetch(block_records, int(i)).x; }

// e made non-decreasing: (e.x, max(e.x, e.y), ...). A block's eps_d can fall as d grows (the
// triangulations of its levels do not nest), and max(eps_1..eps_d) still bounds level d;
// with it, a level that passes a test implies every finer level passes.
vec4 running_max(vec4 e)
{
	e.y = max(e.x, e.y);
	e.z = max(e.y, e.z);
	e.w = max(e.z, e.w);
	return e;
}

// Block bl's errors eps_1..eps_4 in a patch of `blocks` blocks a side, non-decreasing.
vec4 block_eps_in(int layer, ivec2 bl, uint blocks)
{
	uint base = block_eps_index(layer, bl, blocks);
	return running_max(vec4(block_err(base), block_err(base + 1u), block_err(base + 2u), block_err(base + 3u)));
}

// What an edge of block bl at level d = 1..4 must keep within tau when the tessellator's
// strips are bounded (terrain_factors.glsl, edge_eps_at()): eps_d, or the charge of a strip
// along edge `edge` (0 west, 1 north, 2 east, 3 south) against any finer interior if
// larger, non-decreasing; `eps` is the block's own (block_eps_in()). lod_force.comp
// compares a border's with tau too.
vec4 edge_charges_in(int layer, ivec2 bl, uint edge, uint blocks, vec4 eps)
{
	uint i = block_strip_index(layer, bl, edge, blocks);
	return running_max(max(eps, vec4(block_err(i), block_err(i + 1u), block_err(i + 2u), block_err(i + 3u))));
}

// The instances (binding 4, written by lod_select.comp) as RGBA32_UINT texels, four an
// instance in memory order (instance_unpack()): for the passes that read them per lane, as
// the block records above.
layout(binding = 24) uniform usamplerBuffer instance_texels;
void inst_texels_at(uint slot, out uvec4 p[4])
{
	for (int j = 0; j < 4; j++)
		p[j] = texelFetch(instance_texels, 4 * int(slot) + j);
}
Instance inst_at(uint slot)
{
	uvec4 p[4];
	inst_texels_at(slot, p);
	return instance_unpack(p);
}
