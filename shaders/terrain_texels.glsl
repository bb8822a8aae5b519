// The layers' block records and a view's instances as the terrain's passes and stages read
// them (terrain_draw.glsl, lod_commands.comp). Needs terrain_common.glsl.
// The layers' block records (block_record.glsl), read as R32_SFLOAT texels: a CPU
// implementation gathers a texel buffer's loads for all lanes at once, where it loads a
// storage buffer lane by lane (common/gpu/patch_gpu.c).
layout(binding = 11) uniform samplerBuffer block_records;
float block_err(uint i) { return texelFetch(block_records, int(i)).x; }
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
