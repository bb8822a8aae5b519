#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
// Passes the quad's corners through and sets the factors lod_factors.comp computed for it
// this frame (terrain_factors.glsl and terrain_seal.glsl have the method).
layout(vertices = 4) out;
layout(location = 0) in flat uint in_slot[];
layout(location = 1) in flat uint in_quad[];
layout(location = 2) in vec2 in_s[];
layout(location = 3) in float in_down[];
layout(location = 2) out vec2 out_s[];
layout(location = 3) out float out_down[];
layout(location = 4) patch out uvec4 out_seal; // terrain_seal.glsl
layout(location = 5) patch out uvec4 out_inst[4]; // the quad's patch instance (instance_unpack())
layout(location = 9) patch out uvec3 out_factors; // the quad's factors[] record (lod_factors.comp)
// lod_factors.comp's factors and seal records (bindings 13 and 16) as RGBA32_UINT texels
// (terrain_internal.h says why).
layout(binding = 26) uniform usamplerBuffer factor_texels;
layout(binding = 27) uniform usamplerBuffer seal_texels;

float byte_of(uint v, uint i) { return float((v >> (8u * i)) & 0xffu); }

void main()
{
	out_s[gl_InvocationID] = in_s[gl_InvocationID];
	out_down[gl_InvocationID] = in_down[gl_InvocationID];
	if (gl_InvocationID != 0)
		return;
	uvec4 f = texelFetch(factor_texels, int(in_quad[0]));
	gl_TessLevelOuter[0] = byte_of(f.x, 0u);
	gl_TessLevelOuter[1] = byte_of(f.x, 1u);
	gl_TessLevelOuter[2] = byte_of(f.x, 2u);
	gl_TessLevelOuter[3] = byte_of(f.x, 3u);
	gl_TessLevelInner[0] = byte_of(f.y, 0u);
	gl_TessLevelInner[1] = byte_of(f.y, 1u);
	out_seal = texelFetch(seal_texels, int(in_quad[0]));
	out_factors = f.xyz;
	inst_texels_at(in_slot[0], out_inst); // memory order, as instance_unpack() takes it
}
