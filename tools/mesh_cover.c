#include <math.h>
#include <stdbool.h>

#include "mat4.h"
#include "mesh_cover.h"

/* The kind of triangle t; for MESH_COVER_PIXELS, *centres gets the pixel centres inside. */
static enum mesh_cover_kind classify(const struct relief_mat4 *vp, const struct relief_header *hd,
                                     const struct relief_view *v, const struct relief_mesh_vertex *t, uint64_t *centres)
{
	/* Clip coordinates of the corners, positions relative to the eye as the view-projection
	 * takes them; reversed depth: z = w at the near plane, 0 at the far one. */
	double x[3], y[3], w[3];
	int beyond[6] = { 0 };
	for (int k = 0; k < 3; k++) {
		const struct relief_vec3 p = { hd->origin_x + (double)t[k].col * hd->spacing_x - v->eye.x,
			                       hd->origin_y - (double)t[k].row * hd->spacing_y - v->eye.y,
			                       (double)t[k].height - v->eye.z };
		const struct relief_vec3 c = relief_mat4_transform(vp, p, &w[k]);
		beyond[0] += c.x < -w[k];
		beyond[1] += c.x > w[k];
		beyond[2] += c.y < -w[k];
		beyond[3] += c.y > w[k];
		beyond[4] += c.z < 0.0;
		beyond[5] += c.z > w[k];
		x[k] = c.x;
		y[k] = c.y;
	}
	for (int p = 0; p < 6; p++)
		if (beyond[p] == 3)
			return MESH_COVER_OUTSIDE;
	for (int k = 0; k < 3; k++) {
		if (!(w[k] > 0.0))
			return MESH_COVER_EYE;
		/* framebuffer coordinates: the matrix flips y, so y grows downwards as in Vulkan */
		x[k] = (x[k] / w[k] + 1.0) * 0.5 * v->width;
		y[k] = (y[k] / w[k] + 1.0) * 0.5 * v->height;
	}
	/* Twice the shoelace area; Vulkan's signed area is its negative half, and a triangle is
	 * front-facing (VK_FRONT_FACE_COUNTER_CLOCKWISE) where that is positive. */
	const double s = (x[0] * y[1] - x[1] * y[0]) + (x[1] * y[2] - x[2] * y[1]) + (x[2] * y[0] - x[0] * y[2]);
	if (!(s < 0.0))
		return MESH_COVER_BACK;
	const double lo_x = fmin(x[0], fmin(x[1], x[2])), hi_x = fmax(x[0], fmax(x[1], x[2]));
	const double lo_y = fmin(y[0], fmin(y[1], y[2])), hi_y = fmax(y[0], fmax(y[1], y[2]));
	/* pixel centres (i + 0.5, j + 0.5) within the box and the viewport */
	const double i0 = fmax(0.0, ceil(lo_x - 0.5)), i1 = fmin(v->width - 1.0, floor(hi_x - 0.5));
	const double j0 = fmax(0.0, ceil(lo_y - 0.5)), j1 = fmin(v->height - 1.0, floor(hi_y - 0.5));
	uint64_t in = 0;
	for (double j = j0; j <= j1; j++)
		for (double i = i0; i <= i1; i++) {
			const double px = i + 0.5, py = j + 0.5;
			bool inside = true;
			for (int k = 0; k < 3 && inside; k++) {
				const int l = (k + 1) % 3;
				/* with s < 0, a point inside is on the non-positive side of every edge */
				inside = (x[l] - x[k]) * (py - y[k]) - (y[l] - y[k]) * (px - x[k]) <= 0.0;
			}
			in += inside;
		}
	*centres = in;
	return in > 0 ? MESH_COVER_PIXELS : MESH_COVER_EMPTY;
}

void mesh_cover_add(const struct relief_file *f, const struct relief_view *v, const struct relief_mesh_vertex *tri,
                    uint64_t n, struct mesh_cover *acc)
{
	const struct relief_mat4 vp = relief_view_projection(v, v->eye);
	for (uint64_t t = 0; t < n; t++) {
		uint64_t centres = 0;
		const enum mesh_cover_kind k = classify(&vp, &f->hdr, v, tri + 3 * t, &centres);
		acc->kind[k]++;
		acc->centres += centres;
	}
}
