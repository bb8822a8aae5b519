/* The error of a drawn mesh, triangle by triangle (see mesh_error.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "layout.h"
#include "mesh_error.h"

/* One triangle being measured, and what the measurement needs. */
struct probe {
	const struct relief_file *f;
	const struct relief_view *v;
	const float *z;
	const uint8_t *valid; /* NULL: every sample valid */
	uint32_t w, h;
	struct relief_mat4 vp; /* for positions relative to the eye */
	/* the triangle: corners (finest-grid column, row), heights, twice its signed area */
	const struct relief_mesh_vertex *tri;
	double x[3], y[3], hz[3], area;
	/* a regular triangle's side (finest cells), or a transition triangle */
	int64_t cell;
	bool transition;
	enum relief_mesh_kind kind;
	bool seen; /* a point of it was in the frustum */
	struct relief_mesh_error *out;
};

/* Barycentric weights of corners 1 and 2 at (x, y). */
static void weights(const struct probe *p, double x, double y, double *l1, double *l2)
{
	*l1 = ((x - p->x[0]) * (p->y[2] - p->y[0]) - (p->x[2] - p->x[0]) * (y - p->y[0])) / p->area;
	*l2 = ((p->x[1] - p->x[0]) * (y - p->y[0]) - (x - p->x[0]) * (p->y[1] - p->y[0])) / p->area;
}

/* Whether (x, y) lies in the triangle (its border included: grid points on an edge count). */
static bool inside(const struct probe *p, double x, double y)
{
	double l1, l2;
	weights(p, x, y, &l1, &l2);
	const double eps = 1e-12;
	return l1 >= -eps && l2 >= -eps && 1.0 - l1 - l2 >= -eps;
}

/* The triangle's error at (x, y), a point of it (finest-grid coordinates). */
static void probe_at(struct probe *p, double x, double y)
{
	if (!(x >= 0 && y >= 0 && x <= p->w - 1.0 && y <= p->h - 1.0))
		return; /* outside the samples: no reference */
	const uint32_t i = x >= p->w - 1.0 ? p->w - 2 : (uint32_t)x, j = y >= p->h - 1.0 ? p->h - 2 : (uint32_t)y;
	const float *r0 = p->z + (size_t)j * p->w + i, *r1 = r0 + p->w;
	const double a = r0[0], b = r0[1], c = r1[0], d = r1[1];
	if (p->valid) {
		const uint8_t *v0 = p->valid + (size_t)j * p->w + i, *v1 = v0 + p->w;
		if (!v0[0] && !v0[1] && !v1[0] && !v1[1])
			return; /* no valid corner: nothing of the cell is drawn */
	}
	const double u = x - i, t = y - j;
	/* the cell's two triangulations: diagonal a-d, then b-c */
	const double fa = u >= t ? a + u * (b - a) + t * (d - b) : a + t * (c - a) + u * (d - c);
	const double fb = u + t <= 1 ? a + u * (b - a) + t * (c - a) : d + (1 - u) * (c - d) + (1 - t) * (b - d);
	double l1, l2;
	weights(p, x, y, &l1, &l2);
	const double hz = p->hz[0] + l1 * (p->hz[1] - p->hz[0]) + l2 * (p->hz[2] - p->hz[0]);
	const struct relief_header *hd = &p->f->hdr;
	const struct relief_vec3 at = { hd->origin_x + x * hd->spacing_x - p->v->eye.x,
		                        hd->origin_y - y * hd->spacing_y - p->v->eye.y, hz - p->v->eye.z };
	double cw;
	const struct relief_vec3 c4 = relief_mat4_transform(&p->vp, at, &cw);
	if (!(cw > 0 && fabs(c4.x) <= cw && fabs(c4.y) <= cw && c4.z >= 0 && c4.z <= cw))
		return; /* outside the frustum */
	p->seen = true;
	struct relief_mesh_error *o = p->out;
	o->points++;
	/* The segment from the drawn point to the finest surface, for each triangulation. */
	const double ea = fa - hz, eb = fb - hz;
	const double worse = fabs(ea) >= fabs(eb) ? ea : eb, nearer = fabs(ea) >= fabs(eb) ? eb : ea;
	const double px = nearer == 0.0 ? 0.0 : relief_segment_px(&p->vp, p->v->width, p->v->height, at, nearer);
	if (px > o->max_px) {
		o->max_px = px;
		o->max_m = fabs(nearer);
		o->worst = (struct relief_vec3){ at.x + p->v->eye.x, at.y + p->v->eye.y, hz };
		memcpy(o->worst_tri, p->tri, sizeof(o->worst_tri));
	}
	const double pw = worse == 0.0 ? 0.0 : relief_segment_px(&p->vp, p->v->width, p->v->height, at, worse);
	o->max_px_worse = fmax(o->max_px_worse, pw);
	o->kind_max_px[p->kind] = fmax(o->kind_max_px[p->kind], px);
	if (p->transition)
		o->max_px_transition = fmax(o->max_px_transition, px);
	else if (p->cell > 1) /* a regular triangle above full resolution */
		o->max_px_regular_worse = fmax(o->max_px_regular_worse, pw);
}

/* Every point where edge (x0, y0) - (x1, y1) crosses a line g(x, y) = k, k an integer
 * strictly between the ends' values s0 and s1 (g: x, y, x - y or x + y). */
static void probe_crossings(struct probe *p, double x0, double y0, double x1, double y1, double s0, double s1)
{
	if (s0 == s1)
		return;
	const double lo = fmin(s0, s1), hi = fmax(s0, s1);
	for (double k = floor(lo) + 1; k < hi; k++) {
		const double t = (k - s0) / (s1 - s0);
		probe_at(p, x0 + t * (x1 - x0), y0 + t * (y1 - y0));
	}
}

static void measure_triangle(struct probe *p)
{
	p->seen = false;
	for (int k = 0; k < 3; k++)
		probe_at(p, p->x[k], p->y[k]);
	/* the finest samples and cells' centres inside */
	const double cmin = floor(fmin(fmin(p->x[0], p->x[1]), p->x[2])), cmax = ceil(fmax(fmax(p->x[0], p->x[1]), p->x[2]));
	const double rmin = floor(fmin(fmin(p->y[0], p->y[1]), p->y[2])), rmax = ceil(fmax(fmax(p->y[0], p->y[1]), p->y[2]));
	for (double r = rmin; r <= rmax; r++)
		for (double c = cmin; c <= cmax; c++) {
			if (inside(p, c, r))
				probe_at(p, c, r);
			if (c < cmax && r < rmax && inside(p, c + 0.5, r + 0.5))
				probe_at(p, c + 0.5, r + 0.5);
		}
	/* where the edges cross the grid's columns, rows and both diagonals */
	for (int k = 0; k < 3; k++) {
		const int n = (k + 1) % 3;
		const double x0 = p->x[k], y0 = p->y[k], x1 = p->x[n], y1 = p->y[n];
		probe_crossings(p, x0, y0, x1, y1, x0, x1);
		probe_crossings(p, x0, y0, x1, y1, y0, y1);
		probe_crossings(p, x0, y0, x1, y1, x0 - y0, x1 - y1);
		probe_crossings(p, x0, y0, x1, y1, x0 + y0, x1 + y1);
	}
	p->out->triangles += p->seen;
}

/* The side of a regular triangle (half of a square cell of side 2^k finest cells whose
 * corners are multiples of 2^k: a triangle of some level's triangulation), 0 for any other
 * (a transition triangle between an edge and a finer or coarser interior). */
static int64_t regular_side(const struct relief_mesh_vertex *c)
{
	for (int k = 0; k < 3; k++) { /* k: the right angle's corner */
		const struct relief_mesh_vertex *a = &c[k], *b = &c[(k + 1) % 3], *d = &c[(k + 2) % 3];
		int64_t bx = b->col - a->col, by = b->row - a->row, dx = d->col - a->col, dy = d->row - a->row;
		if (!((bx == 0) != (by == 0) && (dx == 0) != (dy == 0) && (bx == 0) != (dx == 0)))
			continue; /* the legs are not one along each axis */
		int64_t side = bx ? llabs(bx) : llabs(by);
		if (side != (dx ? llabs(dx) : llabs(dy)) || (side & (side - 1)) != 0)
			return 0;
		for (int m = 0; m < 3; m++)
			if ((c[m].col % side + side) % side != 0 || (c[m].row % side + side) % side != 0)
				return 0;
		return side;
	}
	return 0;
}

/* Which edge's strip of the quad a transition triangle lies in, with corners at patch
 * samples (a, b) of the quad and an inner ring si samples in from the edges: every corner
 * on the edge or on the ring, at least one on each; the edge holding two corners if two
 * edges qualify (a triangle at a quad's corner). -1 if none. */
static int strip_edge(const int a[3], const int b[3], int si)
{
	const int n = RELIEF_BLOCK_CELLS;
	int edge = -1, most = 0;
	for (int k = 0; k < 4; k++) { /* west, north, east, south */
		int on = 0, ring = 0;
		for (int j = 0; j < 3; j++) {
			const int d = k == 0 ? a[j] : k == 1 ? b[j] : k == 2 ? n - a[j] : n - b[j];
			on += d == 0;
			ring += d == si;
		}
		if (on + ring == 3 && on && ring && on > most) {
			edge = k;
			most = on;
		}
	}
	return edge;
}

/* The kind of a triangle that is not regular (regular_side() 0) drawn in quad q. */
static enum relief_mesh_kind transition_kind(const struct relief_mesh_vertex *c, const struct relief_mesh_quad *q)
{
	const int n = RELIEF_BLOCK_CELLS;
	if (!q || q->cells < (uint32_t)n || q->cells % n)
		return RELIEF_MESH_UNKNOWN;
	const int64_t scale = q->cells / n;
	int a[3], b[3];
	for (int j = 0; j < 3; j++) {
		const int64_t dx = c[j].col - q->col, dy = c[j].row - q->row;
		if (dx % scale || dy % scale || dx < 0 || dy < 0 || dx / scale > n || dy / scale > n)
			return RELIEF_MESH_UNKNOWN;
		a[j] = (int)(dx / scale);
		b[j] = (int)(dy / scale);
	}
	const int inner = q->inner < 2 ? 2 : q->inner;
	if (inner > n || n % inner)
		return RELIEF_MESH_UNKNOWN;
	const int si = n / inner, k = strip_edge(a, b, si);
	if (k < 0)
		return RELIEF_MESH_OTHER;
	if (!q->outer[k] || q->outer[k] > n || n % q->outer[k])
		return RELIEF_MESH_UNKNOWN;
	const int so = n / q->outer[k];
	if (so == si)
		return RELIEF_MESH_OTHER; /* equal factors along this edge, yet not a regular triangle */
	/* within one column of the strip: along the edge, between two multiples of the coarser
	 * of the edge's segments and the interior's cells */
	const int *along = k == 0 || k == 2 ? b : a, col = so > si ? so : si;
	int lo = along[0], hi = along[0];
	for (int j = 1; j < 3; j++) {
		lo = along[j] < lo ? along[j] : lo;
		hi = along[j] > hi ? along[j] : hi;
	}
	if (hi > (lo / col + 1) * col)
		return RELIEF_MESH_OTHER;
	return so > si ? RELIEF_MESH_COARSE_EDGE : inner == 2 ? RELIEF_MESH_FAN : RELIEF_MESH_FINE_EDGE;
}

enum relief_mesh_kind relief_mesh_kind(const struct relief_mesh_vertex *c, const struct relief_mesh_quad *q)
{
	return regular_side(c) ? RELIEF_MESH_REGULAR : transition_kind(c, q);
}

void relief_mesh_error(const struct relief_file *f, const struct relief_view *v, const float *finest,
                       const uint8_t *valid, uint32_t w, uint32_t h, const struct relief_mesh_vertex *tri,
                       const struct relief_mesh_quad *quads, uint64_t n, struct relief_mesh_error *out)
{
	memset(out, 0, sizeof(*out));
	if (w < 2 || h < 2)
		return;
	struct probe p = { .f = f, .v = v, .z = finest, .valid = valid, .w = w, .h = h, .out = out };
	p.vp = relief_view_projection(v, v->eye);
	for (uint64_t t = 0; t < n; t++) {
		const struct relief_mesh_vertex *c = tri + 3 * t;
		for (int k = 0; k < 3; k++) {
			p.x[k] = (double)c[k].col;
			p.y[k] = (double)c[k].row;
			p.hz[k] = c[k].height;
		}
		p.area = (p.x[1] - p.x[0]) * (p.y[2] - p.y[0]) - (p.x[2] - p.x[0]) * (p.y[1] - p.y[0]);
		if (p.area == 0.0) {
			out->vertical++;
			continue;
		}
		p.tri = c;
		p.cell = regular_side(c);
		p.transition = p.cell == 0;
		p.kind = !quads ? RELIEF_MESH_UNKNOWN : p.transition ? transition_kind(c, &quads[t]) : RELIEF_MESH_REGULAR;
		out->transition += p.transition;
		out->kind_triangles[p.kind]++;
		measure_triangle(&p);
	}
}
