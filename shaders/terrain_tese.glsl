// The terrain's evaluation shader (terrain.tese; terrain_mesh.tese, with RELIEF_MESH defined,
// also passes each vertex's position on to the mesh capture, terrain_mesh.geom).
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
// Vertices land on samples (factors are 16 / 2^d), displaced by the decoded heights;
// positions are camera-relative, so floats stay small at any world coordinates, and formed
// by pos_of() so that patches sharing a border put its vertices at the same bits. A border
// vertex next to a coarser patch takes its height on that patch's drawn edge; any other
// vertex that its edge's or interior's next coarser level lacks is morphed towards that
// level (terrain_factors.glsl). terrain_vertex.glsl has the height and the outputs.
#include "terrain_vertex.glsl"
layout(quads, equal_spacing, ccw) in;
layout(location = 2) in vec2 in_s[];
layout(location = 3) in float in_down[];
layout(location = 4) patch in uvec4 in_seal; // this quad's seal record (terrain_seal.glsl)
layout(location = 5) patch in uvec4 in_inst[4]; // its patch's instance (instance_pack)
// The quad's factors[] record (lod_factors.comp): outer factors (x), inner factors and the
// interior's morph byte (y), the outer edges' morph bytes (z).
layout(location = 9) patch in uvec3 in_factors;

void main()
{
	Instance it = instance_unpack(in_inst);
	vec2 s = mix(mix(in_s[0], in_s[1], gl_TessCoord.x), mix(in_s[2], in_s[3], gl_TessCoord.x), gl_TessCoord.y);
	float down = mix(mix(in_down[0], in_down[1], gl_TessCoord.x), mix(in_down[2], in_down[3], gl_TessCoord.x),
	                 gl_TessCoord.y);
	ivec2 si = clamp(ivec2(s + 0.5), ivec2(0), ivec2(int(pc.P) - 1));
	ivec2 lo = ivec2(in_s[0] + 0.5);
	float h = drawn_height(it, si, in_seal, in_factors, lo, ivec2(in_s[3] + 0.5), in_down[3] > 0.0);
	vertex_emit(it, si, h, down, in_factors, lo);
}
