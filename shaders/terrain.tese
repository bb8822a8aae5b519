#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "terrain_draw.glsl"
#include "terrain_factors.glsl"
#include "terrain_seal.glsl"
// Vertices land on samples (factors are 16 / 2^d), displaced by the decoded heights;
// positions are camera-relative, so floats stay small at any world coordinates, and formed
// by pos_of() so that patches sharing a border put its vertices at the same bits. A border
// vertex next to a coarser patch takes its height on that patch's drawn edge.
layout(quads, equal_spacing, ccw) in;
layout(location = 2) in vec2 in_s[];
layout(location = 3) in float in_down[];
layout(location = 4) patch in uvec4 in_seal; // this quad's seal record (terrain_seal.glsl)
layout(location = 5) patch in uvec4 in_inst[4]; // its patch's instance (instance_pack)
layout(location = 1) flat out float out_q2; // metres per quantum of the patch's heights
layout(location = 2) out vec2 out_s;          // patch sample coordinates: validity, normal, height per fragment
layout(location = 3) flat out int out_layer;
precise gl_Position; // shared border vertices get identical bits in both patches
void main()
{
	Instance it = instance_unpack(in_inst);
	vec2 s = mix(mix(in_s[0], in_s[1], gl_TessCoord.x), mix(in_s[2], in_s[3], gl_TessCoord.x), gl_TessCoord.y);
	float down = mix(mix(in_down[0], in_down[1], gl_TessCoord.x), mix(in_down[2], in_down[3], gl_TessCoord.x),
	                 gl_TessCoord.y);
	ivec2 si = clamp(ivec2(s + 0.5), ivec2(0), ivec2(int(pc.P) - 1));
	float h = sample_height(it, si);
	int last = int(pc.P) - 1;
	// On a coarser patch's drawn edge (no crack between levels): the height sealed_height()
	// gives, from the record the factor pass wrote, so that this shader does no search.
	bool ex = si.x == 0 || si.x == last, ey = si.y == 0 || si.y == last;
	if (ex && ey) {
		if (in_seal.w != 0u)
			h = uintBitsToFloat(in_seal.z);
	} else if (ex || ey) {
		uint rec = ex ? in_seal.x : in_seal.y;
		if ((rec & 7u) != 0u)
			h = sealed_side_height(it, si, ex ? (si.x == 0 ? 2u : 3u) : (si.y == 0 ? 0u : 1u), rec);
	}
	out_s = vec2(si);
	out_layer = it.layer;
	out_q2 = it.q2;
	vec3 p = pos_of(it, si, h);
	if (down > 0.0)
		p.z -= down * it.skirt;
	gl_Position = draw_vp * vec4(p, 1.0);
}
