#include <assert.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "lod.h"
#include "patch_error.h"
#include "strip_bound.h"

int relief_view_check(const struct relief_view *v, const char **why)
{
	const double vals[] = { v->eye.x, v->eye.y, v->eye.z, v->target.x, v->target.y, v->target.z, v->roll,
	                        v->fovy,  v->znear, v->zfar, v->tau };
	/* The points first: a tool derives the planes from them, which overflow before they do. */
	for (size_t i = 0; i < 6; i++)
		if (isfinite(vals[i]) && !(fabs(vals[i]) <= RELIEF_VIEW_MAX_COORD)) {
			*why = "the camera and the look point must lie within 1e12 m of the origin on every axis";
			return -EINVAL;
		}
	for (size_t i = 0; i < sizeof(vals) / sizeof(vals[0]); i++)
		if (!isfinite(vals[i])) {
			*why = "a camera value is not a finite number";
			return -EINVAL;
		}
	if (v->width == 0 || v->height == 0 || v->width > 16384 || v->height > 16384) {
		*why = "the viewport must be 1..16384 pixels on each side";
		return -EINVAL;
	}
	struct relief_vec3 f, r, u;
	if (!relief_view_axes(v, &f, &r, &u)) {
		*why = "the camera equals the look point";
		return -EINVAL;
	}
	if (!(v->fovy > 1e-4 && v->fovy < M_PI - 1e-4)) {
		*why = "the field of view must lie between 0.00573 and 179.99427 degrees (1e-4 rad from 0 and 180)";
		return -EINVAL;
	}
	if (!(v->znear > 0 && v->zfar > v->znear)) {
		*why = "near and far planes must satisfy 0 < near < far";
		return -EINVAL;
	}
	/* The GPU takes tau as a float: beyond FLT_MAX it would become infinite, under which
	 * even an error segment reaching behind the camera passes (terrain_factors.glsl). */
	if (!(v->tau > 0 && v->tau <= FLT_MAX)) {
		*why = "tau must be a positive number of pixels, at most 3.4e38";
		return -EINVAL;
	}
	return 0;
}

bool relief_view_axes(const struct relief_view *v, struct relief_vec3 *fwd, struct relief_vec3 *right,
                      struct relief_vec3 *up)
{
	struct relief_vec3 f, r0;
	if (!isfinite(v->roll) || !relief_vec3_normalize(relief_vec3_sub(v->target, v->eye), &f))
		return false;
	/* |f x z| = sin of the angle from the vertical; below the limit the cross product's
	 * direction is rounding noise, so the picture's top is north instead. */
	struct relief_vec3 fz = relief_vec3_cross(f, (struct relief_vec3){ 0, 0, 1 });
	if (relief_vec3_length(fz) < RELIEF_VIEW_NADIR)
		fz = relief_vec3_cross(f, (struct relief_vec3){ 0, 1, 0 });
	if (!relief_vec3_normalize(fz, &r0))
		return false;
	struct relief_vec3 u0 = relief_vec3_cross(r0, f);
	double c = cos(v->roll), s = sin(v->roll);
	/* Right bank: the right axis dips (-s u0), the up axis leans right (+s r0). */
	*right = (struct relief_vec3){ c * r0.x - s * u0.x, c * r0.y - s * u0.y, c * r0.z - s * u0.z };
	*up = (struct relief_vec3){ c * u0.x + s * r0.x, c * u0.y + s * r0.y, c * u0.z + s * r0.z };
	*fwd = f;
	return true;
}

double relief_view_kappa(const struct relief_view *v)
{
	return 0.5 * v->height / tan(0.5 * v->fovy);
}

double relief_view_error_kappa(const struct relief_view *v)
{
	const double t = tan(0.5 * v->fovy), aspect = (double)v->width / (double)v->height;
	return relief_view_kappa(v) * (1.0 + t * t * (1.0 + aspect * aspect));
}

void relief_view_origin(const struct relief_file *f, const struct relief_view *v, struct relief_view_origin *o)
{
	double gx = (v->eye.x - f->hdr.origin_x) / f->hdr.spacing_x;
	double gy = (f->hdr.origin_y - v->eye.y) / f->hdr.spacing_y;
	/* Cameras further than 2^30 samples away see nothing anyway; keep int32 for the GPU. */
	const double lim = 1073741824.0;
	gx = gx < -lim ? -lim : gx > lim ? lim : gx;
	gy = gy < -lim ? -lim : gy > lim ? lim : gy;
	double fx = floor(gx), fy = floor(gy);
	o->cell_x = (int64_t)fx;
	o->cell_y = (int64_t)fy;
	o->frac_x = gx - fx;
	o->frac_y = gy - fy;
	o->z = v->eye.z;
}

/* Float arithmetic identical to box() in shaders/lod_select.comp (this file is compiled
 * without fused multiply-adds: ISO C mode), so CPU and GPU agree on every decision. */
void relief_patch_box(const struct relief_file *f, const struct relief_view_origin *o, uint32_t id,
                      struct relief_box *box)
{
	uint32_t l, px, py;
	relief_patch_coords(&f->layout, id, &l, &px, &py);
	struct relief_patch_record r;
	relief_file_record(f, id, &r);
	int32_t span = (int32_t)(f->hdr.patch_size - 1) << (f->hdr.levels - 1 - l);
	float sx = (float)f->hdr.spacing_x, sy = (float)f->hdr.spacing_y;
	float x0 = ((float)((int32_t)px * span - (int32_t)o->cell_x) - (float)o->frac_x) * sx;
	float y0 = ((float)((int32_t)py * span - (int32_t)o->cell_y) - (float)o->frac_y) * sy;
	float w = (float)span * sx, h = (float)span * sy;
	float x1 = x0 + w, y1 = y0 + h;
	box->min[0] = x0;
	box->max[0] = x1;
	box->min[1] = -y1; /* rows grow southwards, y northwards */
	box->max[1] = -y0;
	box->min[2] = r.height_min - (float)o->z;
	box->max[2] = r.height_max - (float)o->z;
}

float relief_box_distance(const struct relief_box *b)
{
	float d[3];
	for (int i = 0; i < 3; i++) {
		float m = b->min[i] > -b->max[i] ? b->min[i] : -b->max[i];
		d[i] = m > 0.0f ? m : 0.0f;
	}
	float d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
	return sqrtf(d2);
}

void relief_view_matrix(const struct relief_view *v, float out[16])
{
	relief_view_matrix_from(v, v->eye, out);
}

struct relief_mat4 relief_view_projection(const struct relief_view *v, struct relief_vec3 origin)
{
	struct relief_mat4 view, proj;
	struct relief_vec3 f, r, u;
	relief_view_axes(v, &f, &r, &u);
	relief_mat4_look_at(relief_vec3_sub(v->eye, origin), relief_vec3_sub(v->target, origin), u, &view);
	proj = relief_mat4_perspective_reversed(v->fovy, (double)v->width / v->height, v->znear, v->zfar);
	return relief_mat4_mul(&proj, &view);
}

void relief_view_matrix_from(const struct relief_view *v, struct relief_vec3 origin, float out[16])
{
	struct relief_mat4 vp = relief_view_projection(v, origin);
	relief_mat4_to_float(&vp, out);
}

bool relief_box_culled(const float m[16], const struct relief_box *b)
{
	/* Clip coordinates of the 8 corners; culled if all are beyond one plane. */
	float c[8][4];
	for (int k = 0; k < 8; k++) {
		float x = k & 1 ? b->max[0] : b->min[0], y = k & 2 ? b->max[1] : b->min[1], z = k & 4 ? b->max[2] : b->min[2];
		for (int r = 0; r < 4; r++)
			c[k][r] = m[r] * x + m[4 + r] * y + m[8 + r] * z + m[12 + r];
	}
	int out[6] = { 0 };
	for (int k = 0; k < 8; k++) {
		out[0] += c[k][0] < -c[k][3];
		out[1] += c[k][0] > c[k][3];
		out[2] += c[k][1] < -c[k][3];
		out[3] += c[k][1] > c[k][3];
		out[4] += c[k][2] < 0.0f;
		out[5] += c[k][2] > c[k][3];
	}
	for (int p = 0; p < 6; p++)
		if (out[p] == 8)
			return true;
	return false;
}

double relief_patch_coverage_error(const struct relief_file *f, uint32_t id)
{
	uint32_t l, px, py;
	if (!relief_patch_coords(&f->layout, id, &l, &px, &py) || l + 1 >= f->layout.levels ||
	    !relief_file_patch_gaps(f, id))
		return 0.0;
	return ldexp(hypot(f->hdr.spacing_x, f->hdr.spacing_y), (int)(f->layout.levels - 1 - l));
}

float relief_patch_select_error(const struct relief_file *f, uint32_t id, const struct relief_patch_record *r)
{
	if (r->flags & RELIEF_PATCH_EMPTY)
		return r->draw_error; /* 0, as the file has it: such a patch draws nothing to hold to tau */
	float cover = relief_float_up(RELIEF_LOD_COARSE_SHARE * relief_patch_coverage_error(f, id));
	return r->draw_error > cover ? r->draw_error : cover;
}

static bool wants_split(float err, float tau, bool was_split)
{
	return err > tau || (was_split && err > RELIEF_LOD_MERGE * tau);
}

/* What the forced splits read: the view, and the split state they build (bit 1 of
 * forced[id]). */
struct force_ctx {
	const struct relief_file *f;
	const struct relief_view_origin *o;
	float kappa, tau; /* tau: the coarse share (the split rule's) */
	const uint8_t *split_prev, *resident;
	const struct relief_lod_borders *border; /* resident patches' charges; NULL: no border rule */
	uint8_t *forced;
};

/* The screen error of a patch whose box is b: err * kappa / (distance to b), infinite inside. */
static float box_error(const struct relief_box *b, float err, float kappa)
{
	float d = relief_box_distance(b);
	return d > 0.0f ? err * kappa / d : INFINITY;
}

/* Patch id (level l, with an index entry, its box `box`) wants to split by its own error,
 * with its hysteresis bit (forced splits aside). */
static bool own_wish(const struct force_ctx *c, uint32_t l, uint32_t id, const struct relief_box *box)
{
	if (l + 1 >= c->f->layout.levels)
		return false;
	struct relief_patch_record rec;
	relief_file_record(c->f, id, &rec);
	return wants_split(box_error(box, relief_patch_select_error(c->f, id, &rec), c->kappa), c->tau,
	                   c->split_prev[id]);
}

/* Patch (l, x, y) wants to split by the usual rule, with its hysteresis bit, or is forced
 * to (bit 1 of `forced[id]`). A patch without an index entry (EMPTY outside its level's
 * window) does neither: nothing is drawn there (the GPU has no element for it). */
static bool raw_wish(const struct force_ctx *c, uint32_t l, uint32_t x, uint32_t y)
{
	if (l + 1 >= c->f->layout.levels)
		return false;
	uint32_t id = relief_patch_id(l, x, y);
	if (relief_index_entry(&c->f->hdr, id) == UINT32_MAX)
		return false;
	if (c->forced[id] & 2)
		return true;
	struct relief_box box;
	relief_patch_box(c->f, c->o, id, &box);
	return own_wish(c, l, id, &box);
}

/* Whether resident patch id's border on `side`, drawn at level k, projects beyond tau
 * (the whole of it) from its box `box`. */
static bool border_beyond(const struct force_ctx *c, uint32_t id, const struct relief_box *box, uint32_t side,
                          uint32_t k)
{
	const float *charges = c->border->charges(c->border->data, id);
	float charge = charges ? charges[4 * side + k - 1] : 0.0f;
	if (!(charge > 0.0f))
		return false; /* a border drawn exactly at any level: nothing to project */
	return box_error(box, charge, c->kappa) > c->tau / (float)RELIEF_LOD_COARSE_SHARE;
}

/* shaders/lod_force.comp's twin: whether patch id, of level l in 1 .. L - 2, must split
 * because beside one of its sides a chain of patches of levels l + 1 .. l + 4 along the
 * border, each there because the one above it wants to split or is forced to, reaches
 * level l + 4 with a wish to split (a patch 5 levels finer would be drawn there) or holds
 * a resident patch, not wanting to split by its own error, whose border at its jump
 * projects beyond tau. */
static bool forced_split(const struct force_ctx *c, uint32_t id)
{
	uint32_t l, px, py;
	relief_patch_coords(&c->f->layout, id, &l, &px, &py);
	if (raw_wish(c, l, px, py))
		return false; /* it splits anyway */
	const int dirs[4][2] = { { 0, -1 }, { 0, 1 }, { -1, 0 }, { 1, 0 } }; /* north, south, west, east */
	for (uint32_t s = 0; s < 4; s++) {
		int64_t qx = (int64_t)px + dirs[s][0], qy = (int64_t)py + dirs[s][1], n = (int64_t)1 << l;
		if (qx < 0 || qy < 0 || qx >= n || qy >= n)
			continue;
		uint32_t chain = raw_wish(c, l, (uint32_t)qx, (uint32_t)qy);
		for (uint32_t k = 1; k <= 4 && chain; k++) {
			uint32_t m = 1u << k, next = 0;
			for (uint32_t i = 0; i < m; i++) {
				if (!(chain & (1u << (i >> 1))))
					continue;
				uint32_t cx = s == 2 ? (uint32_t)qx * m + m - 1 : s == 3 ? (uint32_t)qx * m : (uint32_t)qx * m + i;
				uint32_t cy = s == 0 ? (uint32_t)qy * m + m - 1 : s == 1 ? (uint32_t)qy * m : (uint32_t)qy * m + i;
				if (l + k >= c->f->layout.levels)
					continue;
				uint32_t cid = relief_patch_id(l + k, cx, cy);
				if (relief_index_entry(&c->f->hdr, cid) == UINT32_MAX)
					continue;
				struct relief_box box;
				relief_patch_box(c->f, c->o, cid, &box);
				const bool own = own_wish(c, l + k, cid, &box);
				if (c->border && c->resident[cid] && !own && border_beyond(c, cid, &box, s ^ 1u, k))
					return true;
				if ((c->forced[cid] & 2) || own)
					next |= 1u << i;
			}
			chain = next;
		}
		if (chain)
			return true;
	}
	return false;
}

/* Sets bit 1 of forced[id] for every patch of levels 1 .. L - 2 that must split, to a fixed
 * point: a forced split counts as a wish in the chains of other patches, so one can force
 * another (see lod_force.comp). Forcing only adds splits, so repeating sweeps until one
 * adds nothing reaches the least fixed point whatever the order, the set the GPU's loop
 * reaches too. `forced` is zero on entry. */
static void force_splits(const struct force_ctx *c)
{
	const uint32_t L = c->f->layout.levels;
	if (L < 3 || (L < 7 && !c->border))
		return; /* neither rule can force anything (the GPU leaves the pass out) */
	const uint32_t end = relief_level_first_id(L - 1);
	for (bool changed = true; changed;) {
		changed = false;
		for (uint32_t id = 1; id < end; id++)
			if (!(c->forced[id] & 2) && relief_index_entry(&c->f->hdr, id) != UINT32_MAX && forced_split(c, id)) {
				c->forced[id] |= 2;
				changed = true;
			}
	}
}

void relief_lod_border_charges(const float *eps, const float *strips, uint32_t blocks,
                               float out[RELIEF_LOD_BORDER_FLOATS])
{
	const uint32_t last = blocks - 1, edges[4] = { 1, 3, 0, 2 }; /* north, south, west, east: edge index */
	for (uint32_t side = 0; side < 4; side++) {
		float charge[4] = { 0.0f, 0.0f, 0.0f, 0.0f };
		for (uint32_t a = 0; a < blocks; a++) {
			uint32_t bx = side < 2 ? a : side == 2 ? 0 : last, by = side >= 2 ? a : side == 0 ? 0 : last;
			uint32_t b = by * blocks + bx;
			const float *e = eps + 4 * (size_t)b, *st = strips + ((size_t)b * 4 + edges[side]) * RELIEF_STRIP_FLOATS;
			float run = 0.0f, block_run = 0.0f;
			for (uint32_t k = 0; k < 4; k++) {
				/* shaders/terrain_texels.glsl, edge_charges_in(): eps made non-decreasing,
				 * then the larger of it and the strip charge, non-decreasing again. */
				block_run = k == 0 ? e[0] : fmaxf(block_run, e[k]);
				float v = fmaxf(block_run, st[k]);
				run = k == 0 ? v : fmaxf(run, v);
				charge[k] = fmaxf(charge[k], run);
			}
		}
		memcpy(out + 4 * side, charge, sizeof(charge));
	}
}

uint32_t relief_lod_select(const struct relief_file *f, const struct relief_view *v, const uint8_t *resident,
                           const struct relief_lod_borders *border, const uint8_t *split_prev,
                           uint8_t *split_next, uint8_t *draw, uint32_t *want, uint32_t want_cap,
                           uint32_t *n_want)
{
	struct relief_view_origin o;
	relief_view_origin(f, v, &o);
	const float kappa = (float)relief_view_error_kappa(v), tau = (float)(v->tau * RELIEF_LOD_COARSE_SHARE);
	const struct relief_layout *lay = &f->layout;
	float vp[16];
	relief_view_matrix(v, vp);
	uint32_t drawn = 0;
	*n_want = 0;
	/* Marks left on a patch by its parent, level by level (children have larger ids):
	 * REACHABLE, every ancestor resident, visible and splitting with its children there;
	 * WANTED, every ancestor visible and wanting to split (the tree drawn once everything
	 * has arrived). Replaced by the result, 1 for drawn, once the patch is visited. */
	enum { REACHABLE = 2, WANTED = 4 };
	memset(draw, 0, lay->patch_count);
	draw[0] = REACHABLE | WANTED;
	/* split_next holds the forced splits (bit 1) until the traversal writes each entry. */
	memset(split_next, 0, lay->patch_count);
	/* The border rule is for bounded strips only (lod_force.comp). */
	const struct force_ctx fc = { f, &o, kappa, tau, split_prev, resident, v->loose_transitions ? NULL : border,
		                      split_next };
	force_splits(&fc);
	for (uint32_t id = 0; id < lay->patch_count; id++) {
		uint32_t l, px, py;
		relief_patch_coords(lay, id, &l, &px, &py);
		uint8_t marks = draw[id];
		const bool forced = split_next[id] & 2;
		draw[id] = 0;
		split_next[id] = 0;
		if (!(marks & WANTED))
			continue; /* nor REACHABLE: a drawn patch's ancestors all want to split */
		struct relief_box box;
		relief_patch_box(f, &o, id, &box);
		struct relief_patch_record rec;
		relief_file_record(f, id, &rec);
		float err = box_error(&box, relief_patch_select_error(f, id, &rec), kappa);
		bool wish = l + 1 < lay->levels &&
		            (wants_split(err, tau, split_prev[id]) || forced);
		split_next[id] = wish;
		if (id != 0 && !(rec.flags & RELIEF_PATCH_EMPTY) && !resident[id] && *n_want < want_cap)
			want[(*n_want)++] = id;
		if (relief_box_culled(vp, &box))
			continue;
		bool reachable = (marks & REACHABLE) && resident[id];
		if (wish) {
			uint32_t child0 = relief_patch_id(l + 1, 2 * px, 2 * py);
			bool children_there = true;
			for (uint32_t k = 0; k < 4; k++) {
				uint32_t c = child0 + (k & 1) + (k >> 1) * (1u << (l + 1));
				struct relief_patch_record r;
				relief_file_record(f, c, &r);
				children_there = children_there && ((r.flags & RELIEF_PATCH_EMPTY) || resident[c]);
				draw[c] = WANTED;
			}
			if (reachable && children_there) {
				for (uint32_t k = 0; k < 4; k++)
					draw[child0 + (k & 1) + (k >> 1) * (1u << (l + 1))] |= REACHABLE;
				continue; /* the children draw this area */
			}
		}
		if (reachable) {
			draw[id] = 1;
			drawn++;
		}
	}
	return drawn;
}

double relief_view_depth_distance(const struct relief_view *v, double d)
{
	if (!(d > 0))
		return INFINITY;
	/* Inverse of relief_mat4_perspective_reversed(): d = n (f - D) / (D (f - n)). */
	return v->znear * v->zfar / (d * (v->zfar - v->znear) + v->znear);
}

struct relief_vec3 relief_view_unproject(const struct relief_view *v, int x, int y, double d)
{
	double D = relief_view_depth_distance(v, d); /* along the view axis */
	struct relief_vec3 f, r, u;
	relief_view_axes(v, &f, &r, &u);
	double t = tan(v->fovy / 2), aspect = (double)v->width / v->height;
	double nx = (2.0 * (x + 0.5) / v->width - 1.0) * t * aspect, ny = (1.0 - 2.0 * (y + 0.5) / v->height) * t;
	return (struct relief_vec3){ v->eye.x + D * (f.x + nx * r.x + ny * u.x), v->eye.y + D * (f.y + nx * r.y + ny * u.y),
	                             v->eye.z + D * (f.z + nx * r.z + ny * u.z) };
}

double relief_view_segment_px(const struct relief_view *v, struct relief_vec3 p, double e)
{
	struct relief_mat4 vp = relief_view_projection(v, (struct relief_vec3){ 0, 0, 0 });
	return relief_segment_px(&vp, v->width, v->height, p, e);
}

double relief_segment_px(const struct relief_mat4 *vp, uint32_t width, uint32_t height, struct relief_vec3 p, double e)
{
	double w0, w1;
	struct relief_vec3 a = relief_mat4_transform(vp, p, &w0);
	struct relief_vec3 b = relief_mat4_transform(vp, (struct relief_vec3){ p.x, p.y, p.z + e }, &w1);
	if (w0 <= 0 || w1 <= 0)
		return INFINITY;
	double dx = (a.x / w0 - b.x / w1) * 0.5 * width, dy = (a.y / w0 - b.y / w1) * 0.5 * height;
	return sqrt(dx * dx + dy * dy);
}

/* The largest K / w^2 on the segment between (K, w) pairs p and q (allowed_box() in
 * shaders/terrain_factors.glsl says why): at an end, or where its derivative is 0. */
static double segment_max(const double p[2], const double q[2])
{
	double g = fmax(p[0] / (p[1] * p[1]), q[0] / (q[1] * q[1]));
	double dk = q[0] - p[0], dw = q[1] - p[1], t = (dk * p[1] - 2.0 * p[0] * dw) / (dk * dw);
	if (t > 0.0 && t < 1.0) {
		double k = p[0] + t * dk, w = p[1] + t * dw;
		g = fmax(g, k / (w * w));
	}
	return g;
}

double relief_box_allowed_error(const struct relief_mat4 *vp, uint32_t width, uint32_t height, double tau,
                                const struct relief_vec3 c[4], double dh)
{
	const double *m = vp->m, zx = m[8], zy = m[9], zw = m[11]; /* the image of a metre up */
	double kw[4][2], w_least = INFINITY;
	for (int i = 0; i < 4; i++) {
		double w;
		struct relief_vec3 p = relief_mat4_transform(vp, c[i], &w);
		double dx = 0.5 * width * (p.x * zw - zx * w), dy = 0.5 * height * (p.y * zw - zy * w);
		kw[i][0] = sqrt(dx * dx + dy * dy);
		kw[i][1] = w + fmin(0.0, dh * zw);
		w_least = fmin(w_least, kw[i][1]);
	}
	if (!(w_least > 1e-6))
		return 0.0;
	double f = 0.0;
	for (int i = 0; i < 4; i++)
		for (int j = i + 1; j < 4; j++)
			f = fmax(f, segment_max(kw[i], kw[j]));
	double den = f * w_least + tau * fabs(zw);
	return den > 0.0 ? tau * w_least / den : INFINITY;
}

double relief_surface_vertical_error(const struct relief_file *f, const float *hf, const uint8_t *valid,
                                     uint32_t w, uint32_t h, uint32_t step, struct relief_vec3 p, double *mid)
{
	if (mid)
		*mid = 0.0;
	double gx = (p.x - f->hdr.origin_x) / (f->hdr.spacing_x * step);
	double gy = (f->hdr.origin_y - p.y) / (f->hdr.spacing_y * step);
	if (!(gx >= -1 && gy >= -1 && gx <= w && gy <= h) || w < 2 || h < 2)
		return 0.0;
	/* A drawn point just outside the raster's extent lies on a terrain-edge curtain, off
	 * the edge by rounding, or in the half cell kept past the last sample: both at the edge */
	gx = gx < 0 ? 0 : gx > w - 1 ? w - 1 : gx;
	gy = gy < 0 ? 0 : gy > h - 1 ? h - 1 : gy;
	uint32_t i = gx >= w - 1 ? w - 2 : (uint32_t)gx, j = gy >= h - 1 ? h - 2 : (uint32_t)gy;
	const size_t k = (size_t)j * w + i;
	if (valid && !valid[k] && !valid[k + 1] && !valid[k + w] && !valid[k + w + 1])
		return 0.0;
	double u = gx - i, t = gy - j;
	double a = hf[k], b = hf[k + 1], c = hf[k + w], d = hf[k + w + 1];
	double d0 = u >= t ? a + u * (b - a) + t * (d - b) : a + t * (c - a) + u * (d - c);
	double d1 = u + t <= 1 ? a + u * (b - a) + t * (c - a) : d + (1 - u) * (c - d) + (1 - t) * (b - d);
	double e0 = p.z - d0, e1 = p.z - d1;
	if (mid)
		*mid = p.z - 0.5 * (d0 + d1);
	return fabs(e0) < fabs(e1) ? e0 : e1;
}

/* Block height ranges of one patch: blocks^2 pairs, at most 16 x 16 blocks (P = 257). */
enum { MAX_BLOCK_RANGES = 2 * RELIEF_MAX_BLOCKS };

double relief_surface_height_bound(const struct relief_file *f, double x, double y)
{
	const struct relief_header *hd = &f->hdr;
	const double global = hd->height_max + f->layout.delta[0];
	const double gx = (x - hd->origin_x) / hd->spacing_x, gy = (hd->origin_y - y) / hd->spacing_y;
	const double last = (double)f->layout.size - 1; /* finest samples 0 .. last */
	if (!(gx >= 0 && gy >= 0 && gx <= last && gy <= last)) /* also NaN */
		return global;
	const uint32_t P = hd->patch_size, blocks = f->layout.blocks, L = hd->levels;
	float range[MAX_BLOCK_RANGES];
	assert(relief_block_ranges_per_patch(P) <= MAX_BLOCK_RANGES);
	double bound = -INFINITY;
	uint32_t decoded = UINT32_MAX; /* the patch whose ranges are in range[] */
	for (uint32_t l = 0; l < L; l++)
		for (int probe = 0; probe < 4; probe++) {
			/* level-l sample coordinates of the probe, clamped into the grid */
			double px = gx + (probe & 1 ? 0.5 : -0.5), py = gy + (probe & 2 ? 0.5 : -0.5);
			px = px < 0 ? 0 : px > last ? last : px;
			py = py < 0 ? 0 : py > last ? last : py;
			const uint32_t shift = L - 1 - l, cells = P - 1, n = 1u << l;
			uint32_t sx = (uint32_t)px >> shift, sy = (uint32_t)py >> shift;
			uint32_t ix = sx / cells < n ? sx / cells : n - 1, iy = sy / cells < n ? sy / cells : n - 1;
			uint32_t bx = (sx - ix * cells) / RELIEF_BLOCK_CELLS, by = (sy - iy * cells) / RELIEF_BLOCK_CELLS;
			bx = bx < blocks ? bx : blocks - 1;
			by = by < blocks ? by : blocks - 1;
			uint32_t id = relief_patch_id(l, ix, iy);
			if (id != decoded) { /* the probes mostly fall in one patch: read it once */
				struct relief_patch_record r;
				relief_file_record(f, id, &r);
				if (r.flags & RELIEF_PATCH_EMPTY)
					continue; /* never drawn */
				relief_file_block_ranges(f, id, range);
				decoded = id;
			}
			double high = range[2 * (by * blocks + bx) + 1];
			bound = high > bound ? high : bound;
		}
	return bound > -INFINITY ? bound : global;
}

double relief_drawn_height_bound(const struct relief_file *f, const uint32_t *ids, uint32_t n, double x, double y)
{
	const struct relief_header *hd = &f->hdr;
	const uint32_t blocks = f->layout.blocks;
	/* metres east of the grid's origin and south of it (rows) */
	const double ex = x - hd->origin_x, ey = hd->origin_y - y;
	float range[MAX_BLOCK_RANGES];
	assert(relief_block_ranges_per_patch(hd->patch_size) <= MAX_BLOCK_RANGES);
	double bound = -INFINITY;
	bool found = false;
	for (uint32_t i = 0; i < n; i++) {
		uint32_t l, px, py;
		if (!relief_patch_coords(&f->layout, ids[i], &l, &px, &py))
			continue;
		const double cells = (double)((hd->patch_size - 1) << (hd->levels - 1 - l)) / blocks; /* finest, per block */
		const double sx = cells * hd->spacing_x, sy = cells * hd->spacing_y, side = sx > sy ? sx : sy;
		bool read = false;
		for (uint32_t by = 0; by < blocks; by++)
			for (uint32_t bx = 0; bx < blocks; bx++) {
				double x0 = ((double)px * blocks + bx) * sx, y0 = ((double)py * blocks + by) * sy;
				double dx = fmax(fmax(x0 - ex, ex - (x0 + sx)), 0.0), dy = fmax(fmax(y0 - ey, ey - (y0 + sy)), 0.0);
				if (fmax(dx, dy) > side)
					continue;
				if (!read)
					relief_file_block_ranges(f, ids[i], range);
				read = true;
				bound = fmax(bound, range[2 * (by * blocks + bx) + 1]);
				found |= dx <= 0.5 * hd->spacing_x && dy <= 0.5 * hd->spacing_y;
			}
	}
	return found ? bound : NAN;
}
