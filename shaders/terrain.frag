#version 450
#extension GL_GOOGLE_include_directive : require
#include "terrain_common.glsl"
#include "patch_entry.glsl"
#include "terrain_draw.glsl"
// One sun, a height ramp (water-level green to snow) and rock on steep slopes. The normal
// and the height that picks the colour come from the patch's maps at this fragment
// (bilinear between the four samples around it), not from the vertices: the picture keeps
// the full resolution of the data at any tessellation level, shows no triangles, and does
// not change when a block's level does (per-vertex values did all three).
layout(location = 1) flat in float in_q2;
layout(location = 2) in vec2 in_s;
layout(location = 3) flat in int in_layer;
layout(location = 0) out vec4 out_color;
void main()
{
	// No-data is a hole, never a made-up height: the validity of the nearest sample, per
	// fragment (tessellated vertices can be far apart where the terrain is smooth).
	ivec2 si = clamp(ivec2(in_s + 0.5), ivec2(0), ivec2(int(pc.P) - 1));
	if (normal_load(si, in_layer).w < 0.0)
		discard;
	if ((pc.mode & 1u) != 0u) {
		out_color = vec4(0.05, 0.05, 0.05, 1.0);
		return;
	}
	vec2 s = clamp(in_s, vec2(0.0), vec2(float(pc.P) - 1.0));
	ivec2 i0 = min(ivec2(s), ivec2(int(pc.P) - 2)); // the cell holding s, within the patch
	vec2 f = s - vec2(i0);
	vec3 n00 = normal_load(i0, in_layer).xyz, n10 = normal_load(i0 + ivec2(1, 0), in_layer).xyz;
	vec3 n01 = normal_load(i0 + ivec2(0, 1), in_layer).xyz, n11 = normal_load(i0 + ivec2(1, 1), in_layer).xyz;
	vec3 n = normalize(mix(mix(n00, n10, f.x), mix(n01, n11, f.x), f.y));
	// Heights have a ring of one sample: sample (x, y) is texel (x + 1, y + 1).
	ivec3 h0 = ivec3(i0 + 1, in_layer);
	vec4 q = vec4(imageLoad(heights, h0).x, imageLoad(heights, h0 + ivec3(1, 0, 0)).x,
	              imageLoad(heights, h0 + ivec3(0, 1, 0)).x, imageLoad(heights, h0 + ivec3(1, 1, 0)).x);
	float height = in_q2 * mix(mix(q.x, q.y, f.x), mix(q.z, q.w, f.x), f.y);
	float t = clamp((height - pc.hrange.x) / max(pc.hrange.y - pc.hrange.x, 1e-3), 0.0, 1.0);
	vec3 low = vec3(0.27, 0.45, 0.22), mid = vec3(0.55, 0.50, 0.36), high = vec3(0.96, 0.96, 0.98);
	vec3 albedo = t < 0.55 ? mix(low, mid, t / 0.55) : mix(mid, high, (t - 0.55) / 0.45);
	albedo = mix(albedo, vec3(0.45, 0.43, 0.41), smoothstep(0.55, 0.8, 1.0 - n.z));
	float diffuse = max(dot(n, normalize(pc.sun.xyz)), 0.0);
	out_color = vec4(albedo * (0.3 + 0.7 * diffuse), 1.0);
}
