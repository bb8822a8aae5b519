// Shared by the displaced-grid shaders (the foundation smoke render and `relief hello`).
// The grid spans [0, size]^2 in world x (east) and y (north); z is up.
layout(push_constant) uniform GridPush {
	mat4 mvp;     // world -> clip
	vec4 grid;    // x: patches per side, y: world size, z: tessellation factor, w: amplitude
	vec4 light;   // xyz: direction towards the sun (unit), w: mode (0 height code, 1 shaded)
} pc;

const float TAU = 6.28318530717958647692;

// Height at grid coordinate g in [0,1]^2, in units of the amplitude. The CPU twin is
// grid_height() in common/gpu/grid.c; keep both in step.
float grid_height(vec2 g)
{
	return 0.6 * sin(TAU * 1.5 * g.x) * cos(TAU * g.y) + 0.4 * sin(TAU * 1.4 * (g.x + g.y));
}

vec2 grid_height_gradient(vec2 g)
{
	float dx = 0.6 * TAU * 1.5 * cos(TAU * 1.5 * g.x) * cos(TAU * g.y) +
	           0.4 * TAU * 1.4 * cos(TAU * 1.4 * (g.x + g.y));
	float dy = -0.6 * TAU * sin(TAU * 1.5 * g.x) * sin(TAU * g.y) +
	           0.4 * TAU * 1.4 * cos(TAU * 1.4 * (g.x + g.y));
	return vec2(dx, dy);
}
