#include <math.h>
#include <string.h>

#include "mat4.h"

struct relief_vec3 relief_vec3_sub(struct relief_vec3 a, struct relief_vec3 b)
{
	return (struct relief_vec3){ a.x - b.x, a.y - b.y, a.z - b.z };
}

struct relief_vec3 relief_vec3_cross(struct relief_vec3 a, struct relief_vec3 b)
{
	return (struct relief_vec3){ a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}

double relief_vec3_dot(struct relief_vec3 a, struct relief_vec3 b)
{
	return a.x * b.x + a.y * b.y + a.z * b.z;
}

double relief_vec3_length(struct relief_vec3 a)
{
	return sqrt(relief_vec3_dot(a, a));
}

bool relief_vec3_normalize(struct relief_vec3 a, struct relief_vec3 *out)
{
	double len = relief_vec3_length(a);
	if (!(len > 0.0) || !isfinite(len))
		return false;
	*out = (struct relief_vec3){ a.x / len, a.y / len, a.z / len };
	return true;
}

struct relief_mat4 relief_mat4_identity(void)
{
	struct relief_mat4 r = { { 0 } };
	r.m[0] = r.m[5] = r.m[10] = r.m[15] = 1.0;
	return r;
}

struct relief_mat4 relief_mat4_mul(const struct relief_mat4 *a, const struct relief_mat4 *b)
{
	struct relief_mat4 r;
	for (int c = 0; c < 4; c++)
		for (int row = 0; row < 4; row++) {
			double s = 0.0;
			for (int k = 0; k < 4; k++)
				s += a->m[k * 4 + row] * b->m[c * 4 + k];
			r.m[c * 4 + row] = s;
		}
	return r;
}

bool relief_mat4_look_at(struct relief_vec3 eye, struct relief_vec3 target, struct relief_vec3 up,
                         struct relief_mat4 *out)
{
	struct relief_vec3 f, s, u;
	if (!relief_vec3_normalize(relief_vec3_sub(target, eye), &f))
		return false;
	if (!relief_vec3_normalize(relief_vec3_cross(f, up), &s))
		return false;
	u = relief_vec3_cross(s, f);
	struct relief_mat4 r = relief_mat4_identity();
	r.m[0] = s.x; r.m[4] = s.y; r.m[8] = s.z;
	r.m[1] = u.x; r.m[5] = u.y; r.m[9] = u.z;
	r.m[2] = -f.x; r.m[6] = -f.y; r.m[10] = -f.z;
	r.m[12] = -relief_vec3_dot(s, eye);
	r.m[13] = -relief_vec3_dot(u, eye);
	r.m[14] = relief_vec3_dot(f, eye);
	*out = r;
	return true;
}

struct relief_mat4 relief_mat4_perspective(double fovy, double aspect, double znear, double zfar)
{
	/* Vulkan: y flipped (framebuffer y down), depth 0 at znear, 1 at zfar. */
	double f = 1.0 / tan(fovy / 2.0);
	struct relief_mat4 r = { { 0 } };
	r.m[0] = f / aspect;
	r.m[5] = -f;
	r.m[10] = zfar / (znear - zfar);
	r.m[11] = -1.0;
	r.m[14] = znear * zfar / (znear - zfar);
	return r;
}

struct relief_mat4 relief_mat4_perspective_reversed(double fovy, double aspect, double znear, double zfar)
{
	/* Depth 1 at znear, 0 at zfar: the standard matrix with the two planes swapped
	 * (m[10] = znear / (zfar - znear), m[14] = znear zfar / (zfar - znear)). */
	return relief_mat4_perspective(fovy, aspect, zfar, znear);
}

struct relief_mat4 relief_mat4_ortho(double l, double r, double b, double t, double zn, double zf)
{
	/* View-space z = -zn maps to depth 0, z = -zf to depth 1; y = t to the top row. */
	struct relief_mat4 m = relief_mat4_identity();
	m.m[0] = 2.0 / (r - l);
	m.m[5] = -2.0 / (t - b);
	m.m[10] = -1.0 / (zf - zn);
	m.m[12] = -(r + l) / (r - l);
	m.m[13] = (t + b) / (t - b);
	m.m[14] = -zn / (zf - zn);
	return m;
}

struct relief_vec3 relief_mat4_transform(const struct relief_mat4 *m, struct relief_vec3 p, double *w)
{
	const double *a = m->m;
	struct relief_vec3 r = {
		a[0] * p.x + a[4] * p.y + a[8] * p.z + a[12],
		a[1] * p.x + a[5] * p.y + a[9] * p.z + a[13],
		a[2] * p.x + a[6] * p.y + a[10] * p.z + a[14],
	};
	if (w)
		*w = a[3] * p.x + a[7] * p.y + a[11] * p.z + a[15];
	return r;
}

void relief_mat4_to_float(const struct relief_mat4 *m, float out[16])
{
	for (int i = 0; i < 16; i++)
		out[i] = (float)m->m[i];
}
