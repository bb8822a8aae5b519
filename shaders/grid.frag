#version 450
#extension GL_GOOGLE_include_directive : require
#include "grid_common.glsl"
layout(location = 0) in float in_height;
layout(location = 1) in vec3 in_normal;
layout(location = 0) out vec4 out_color;
void main()
{
	float t = clamp(0.5 * in_height + 0.5, 0.0, 1.0);
	if (pc.light.w < 0.5) {
		out_color = vec4(t, t, t, 1.0);   // height code, read back by the smoke test
		return;
	}
	vec3 low = vec3(0.20, 0.42, 0.18), mid = vec3(0.55, 0.47, 0.33), high = vec3(0.95, 0.95, 0.97);
	vec3 albedo = t < 0.6 ? mix(low, mid, t / 0.6) : mix(mid, high, (t - 0.6) / 0.4);
	float diffuse = max(dot(normalize(in_normal), pc.light.xyz), 0.0);
	out_color = vec4(albedo * (0.25 + 0.75 * diffuse), 1.0);
}
