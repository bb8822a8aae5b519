/* 4x4 matrices and 3-vectors in double precision, column-major like GLSL
 * (m[col * 4 + row]). Projection matrices follow Vulkan's clip conventions: y down in
 * framebuffer space, depth in [0, 1]. Positions are kept in double so that a terrain at
 * projected coordinates in the millions of metres keeps millimetre precision; only
 * camera-relative values are converted to float for the GPU. */
#pragma once

#include <stdbool.h>

struct relief_vec3 {
	double x, y, z;
};

struct relief_mat4 {
	double m[16];
};

struct relief_vec3 relief_vec3_sub(struct relief_vec3 a, struct relief_vec3 b);
struct relief_vec3 relief_vec3_cross(struct relief_vec3 a, struct relief_vec3 b);
double relief_vec3_dot(struct relief_vec3 a, struct relief_vec3 b);
double relief_vec3_length(struct relief_vec3 a);
/* Unit vector; returns false (and leaves *out alone) for a zero or non-finite vector. */
bool relief_vec3_normalize(struct relief_vec3 a, struct relief_vec3 *out);

struct relief_mat4 relief_mat4_identity(void);
struct relief_mat4 relief_mat4_mul(const struct relief_mat4 *a, const struct relief_mat4 *b);
/* Right-handed view matrix looking from eye to target with `up` as the rough up direction.
 * Returns false when eye == target or up is parallel to the view direction. */
bool relief_mat4_look_at(struct relief_vec3 eye, struct relief_vec3 target, struct relief_vec3 up,
                         struct relief_mat4 *out);
/* Perspective with vertical field of view fovy (radians); camera looks down -z. */
struct relief_mat4 relief_mat4_perspective(double fovy, double aspect, double znear, double zfar);
/* Reversed-Z perspective: depth 1 at znear, 0 at zfar, so that float depth keeps its
 * precision far away (terrain views reach hundreds of kilometres from a near plane of a
 * metre). Use with a depth clear of 0 and a GREATER depth test. */
struct relief_mat4 relief_mat4_perspective_reversed(double fovy, double aspect, double znear, double zfar);
/* Orthographic mapping x in [l, r] -> [-1, 1], y in [b, t] -> [1, -1] (north up on screen),
 * view-space z = -zn -> depth 0 and z = -zf -> depth 1 (camera looks down -z). */
struct relief_mat4 relief_mat4_ortho(double l, double r, double b, double t, double zn, double zf);
struct relief_vec3 relief_mat4_transform(const struct relief_mat4 *m, struct relief_vec3 p, double *w);
void relief_mat4_to_float(const struct relief_mat4 *m, float out[16]);
