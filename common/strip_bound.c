/* Transition strip bounds (see strip_bound.h), the CPU twin of shaders/patch_strips.comp:
 * its comments say why each bound holds. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "layout.h"
#include "strip_bound.h"

struct strip {
	const int32_t *q;
	int P, ox, oy, edge; /* the block's first sample; 0 west, 1 north, 2 east, 3 south */
};

static void at(const struct strip *s, int along, int depth, int *x, int *y)
{
	const int n = RELIEF_BLOCK_CELLS;
	*x = s->ox + (s->edge == 0 ? depth : s->edge == 2 ? n - depth : along);
	*y = s->oy + (s->edge == 1 ? depth : s->edge == 3 ? n - depth : along);
}

static int32_t h(const struct strip *s, int along, int depth)
{
	int x, y;
	at(s, along, depth, &x, &y);
	return s->q[(size_t)(y + 1) * (size_t)(s->P + 2) + (size_t)x + 1];
}

void relief_strip_ring(int c0, int so, int si, int *first, int *last)
{
	const int n = RELIEF_BLOCK_CELLS;
	*first = c0 > si ? c0 : si;
	*last = c0 + so < n - si ? c0 + so : n - si;
}

/* D against the column's square (either half) for rings at depth si. */
static float coarse_edge(const struct strip *s, int so, int si)
{
	const int n = RELIEF_BLOCK_CELLS;
	float worst = 0.0f;
	for (int c0 = 0; c0 < n; c0 += so) {
		const int32_t h00 = h(s, c0, 0);
		const float dx = (float)(h(s, c0 + so, 0) - h00) / (float)so;
		const float dy_lo = (float)(h(s, c0, so) - h00) / (float)so;
		const float dy_hi = (float)(h(s, c0 + so, so) - h(s, c0 + so, 0)) / (float)so;
		int first, last;
		relief_strip_ring(c0, so, si, &first, &last);
		for (int t = first; t <= last; t += si) {
			const int x = t - c0;
			const float a = (float)(h(s, t, si) - h00) - dx * (float)x;
			if (x + si <= so)
				worst = fmaxf(worst, fabsf(a - dy_lo * (float)si));
			if (x >= si)
				worst = fmaxf(worst, fabsf(a - dy_hi * (float)si));
		}
	}
	return worst;
}

/* The 4-term points of an edge's columns (of `column` samples), in column order: column
 * k's are p[first[k]] up to p[first[k + 1]]. */
struct point_list {
	struct relief_strip_point *p;
	int first[RELIEF_BLOCK_CELLS + 1];
};

enum column_kind {
	COLUMN_INTERIOR,    /* relief_strip_interior_points() */
	COLUMN_FINE_OWN,    /* relief_strip_fine_points() */
	COLUMN_FINE_FULL,   /* relief_strip_full_points() */
	COLUMN_COARSE_FULL, /* relief_strip_interior_full_points() */
};

static int column_points(enum column_kind kind, int so, int si, int c0, struct relief_strip_point *out, int cap)
{
	switch (kind) {
	case COLUMN_INTERIOR:
		return relief_strip_interior_points(so, si, c0, out, cap);
	case COLUMN_FINE_OWN:
		return relief_strip_fine_points(so, c0, out, cap);
	case COLUMN_FINE_FULL:
		return relief_strip_full_points(so, c0, out, cap);
	default:
		return relief_strip_interior_full_points(so, si, c0, out, cap);
	}
}

static int point_list_init(struct point_list *l, enum column_kind kind, int so, int si, int column)
{
	const int columns = RELIEF_BLOCK_CELLS / column;
	int n = 0;
	for (int k = 0; k < columns; k++)
		n += column_points(kind, so, si, k * column, NULL, 0);
	if (!(l->p = malloc(sizeof(struct relief_strip_point) * (size_t)n)))
		return -1;
	l->first[0] = 0;
	for (int k = 0; k < columns; k++)
		l->first[k + 1] = l->first[k] + column_points(kind, so, si, k * column, l->p + l->first[k], n - l->first[k]);
	return 0;
}

/* The points of every kind of column, listed once per relief_strip_bounds() call: for a
 * coarse-edge strip along an edge at level e = 1..4 against an interior at i < e,
 * interior[e - 1][i] and (i > 0) coarse_full[e - 1][i] (against full resolution); for a
 * fine-edge strip along an edge at level e = 0..2, fine[e] (the edge's own level) and
 * full[e]. */
struct strip_points {
	struct point_list interior[4][4], coarse_full[4][4], fine[3], full[3];
};

static int strip_points_init(struct strip_points *sp)
{
	*sp = (struct strip_points){ 0 };
	for (int e = 1; e <= 4; e++)
		for (int i = 0; i < e; i++) {
			const int so = 1 << e, si = 1 << i;
			if (point_list_init(&sp->interior[e - 1][i], COLUMN_INTERIOR, so, si, so) < 0 ||
			    (i > 0 && point_list_init(&sp->coarse_full[e - 1][i], COLUMN_COARSE_FULL, so, si, so) < 0))
				return -1;
		}
	for (int e = 0; e <= 2; e++)
		if (point_list_init(&sp->fine[e], COLUMN_FINE_OWN, 1 << e, 0, 2 << e) < 0 ||
		    point_list_init(&sp->full[e], COLUMN_FINE_FULL, 1 << e, 0, 2 << e) < 0)
			return -1;
	return 0;
}

static void strip_points_finish(struct strip_points *sp)
{
	for (int e = 0; e < 4; e++)
		for (int i = 0; i < 4; i++) {
			free(sp->interior[e][i].p);
			free(sp->coarse_full[e][i].p);
		}
	for (int e = 0; e <= 2; e++) {
		free(sp->fine[e].p);
		free(sp->full[e].p);
	}
}

/* Half the largest twist of the cells in row r along the edge (depth r to r + 1): at the
 * finest level, how far the patch drawn at full resolution with either diagonal lies from
 * the finest surface there, quanta. */
static float row_eps(const struct strip *s, int r)
{
	float worst = 0.0f;
	for (int k = 0; k < RELIEF_BLOCK_CELLS; k++) {
		const int32_t twist = h(s, k, r) + h(s, k + 1, r + 1) - h(s, k + 1, r) - h(s, k, r + 1);
		worst = fmaxf(worst, 0.5f * (float)abs(twist));
	}
	return worst;
}

static float fine_edge(const struct strip *s, int so)
{
	const int n = RELIEF_BLOCK_CELLS, c = 2 * so;
	float worst = 0.0f;
	for (int c0 = 0; c0 < n; c0 += c) {
		const int32_t o = h(s, c0, 0);
		const float m = (float)(h(s, c0 + so, 0) - o), cc = (float)(h(s, c0 + c, 0) - o);
		const float a = (float)(h(s, c0, c) - o), b = (float)(h(s, c0 + c, c) - o);
		const float mid = fabsf(m - 0.5f * cc);
		worst = fmaxf(worst, mid);
		if (c0 >= c && c0 + c <= n - c) {
			const float e1 = fabsf(b + 2.0f * m - a - 2.0f * cc) / 3.0f, e2 = fabsf(a + 2.0f * m - b) / 3.0f;
			worst = fmaxf(worst, fmaxf(mid, fminf(e1, e2)));
		}
	}
	return worst;
}

/* Writes point k (its samples pts with weights w, the terms of weight 0 left out) when it
 * fits in out; returns k + 1, so that a call with out NULL counts the points. Why the
 * points listed are where T - L peaks: strip_bound.h, at each list's function;
 * test_strip_bound checks the lists against a dense evaluation. */
static int add_point(struct relief_strip_point *out, int cap, int k, const int (*pts)[2], const double *w)
{
	if (out && k < cap) {
		struct relief_strip_point *p = &out[k];
		p->n = 0;
		for (int i = 0; i < RELIEF_STRIP_POINT_TERMS; i++)
			if (w[i] != 0.0) {
				p->s[p->n][0] = (int8_t)pts[i][0];
				p->s[p->n][1] = (int8_t)pts[i][1];
				p->w[p->n++] = (float)w[i];
			}
	}
	return k + 1;
}

/* Where the side from a to b crosses the segment from g0 to g1 strictly inside both: the
 * parameters along each, or false (parallel, or no such crossing). */
static bool crossing(const int a[2], const int b[2], const int g0[2], const int g1[2], double *u, double *v)
{
	const double ex = b[0] - a[0], ey = b[1] - a[1], fx = g1[0] - g0[0], fy = g1[1] - g0[1];
	const double den = ex * fy - ey * fx;
	if (den == 0.0)
		return false;
	const double rx = g0[0] - a[0], ry = g0[1] - a[1];
	*u = (rx * fy - ry * fx) / den;
	*v = (rx * ey - ry * ex) / den;
	return *u > 1e-9 && *u < 1 - 1e-9 && *v > 1e-9 && *v < 1 - 1e-9;
}

/* Whether lattice point g lies on the side from a to b, strictly between its ends: its
 * parameter along it in *u. */
static bool on_side(const int a[2], const int b[2], const int g[2], double *u)
{
	const long ex = b[0] - a[0], ey = b[1] - a[1], gx = g[0] - a[0], gy = g[1] - a[1];
	if (ex * gy - ey * gx != 0)
		return false;
	*u = (double)(ex * gx + ey * gy) / (double)(ex * ex + ey * ey);
	return *u > 1e-9 && *u < 1 - 1e-9;
}

/* The triangles a strip's column can hold: vertices (along, depth) and triangles as
 * indices into them, within the rectangle from along c0, `width` along and `depth` deep. */
struct column_tris {
	int v[RELIEF_BLOCK_CELLS + 3][2];
	int t[4 * RELIEF_BLOCK_CELLS][3];
	int nv, nt, c0, width, depth;
};

static int tris_vertex(struct column_tris *ct, int along, int depth)
{
	ct->v[ct->nv][0] = along;
	ct->v[ct->nv][1] = depth;
	return ct->nv++;
}

static void tris_add(struct column_tris *ct, int a, int b, int c)
{
	ct->t[ct->nt][0] = a;
	ct->t[ct->nt][1] = b;
	ct->t[ct->nt++][2] = c;
}

/* A fine-edge column from along c0 (segments of so, a ring at depth c = 2 so, every c
 * along, inset by c from the block's ends): an edge segment joined to a ring vertex of
 * the column, the ring segment joined to any vertex of the edge. */
static void fine_tris(int so, int c0, struct column_tris *ct)
{
	const int c = 2 * so;
	*ct = (struct column_tris){ .c0 = c0, .width = c, .depth = c };
	int first, last;
	relief_strip_ring(c0, c, c, &first, &last);
	const bool ha = first == c0 && first <= last, hb = last == c0 + c && first <= last;
	const int o = tris_vertex(ct, c0, 0), m = tris_vertex(ct, c0 + so, 0), cc = tris_vertex(ct, c0 + c, 0);
	const int a = tris_vertex(ct, c0, c), b = tris_vertex(ct, c0 + c, c);
	if (ha) {
		tris_add(ct, o, m, a);
		tris_add(ct, m, cc, a);
	}
	if (hb) {
		tris_add(ct, o, m, b);
		tris_add(ct, m, cc, b);
	}
	if (ha && hb)
		for (int v = 0; v < 3; v++)
			tris_add(ct, a, b, v == 0 ? o : v == 1 ? m : cc);
}

/* A coarse-edge column from along c0 (a segment of so) against an interior of cells of
 * si < so (a ring at depth si, every si along, inset by si from the block's ends): the
 * segment joined to a ring vertex, a ring segment joined to an end of the segment. */
static void coarse_tris(int so, int si, int c0, struct column_tris *ct)
{
	const int n = RELIEF_BLOCK_CELLS;
	*ct = (struct column_tris){ .c0 = c0, .width = so, .depth = si };
	const int a = tris_vertex(ct, c0, 0), b = tris_vertex(ct, c0 + so, 0);
	int first, last;
	relief_strip_ring(c0, so, si, &first, &last);
	for (int t = first, prev = -1; t <= last; t += si) {
		const int r = tris_vertex(ct, t, si);
		tris_add(ct, a, b, r);
		if (prev >= 0) {
			tris_add(ct, a, prev, r);
			tris_add(ct, b, prev, r);
		}
		prev = t + si <= last && t + si <= n - si ? r : -1;
	}
}

/* The points of the triangles of ct against the lattice of cells of side `cell` over the
 * column's rectangle, with both diagonals of every cell or none: the lattice's vertices
 * strictly inside a triangle (its three corners against the vertex), and along each
 * distinct side the vertices strictly between its ends and its crossings with the cells'
 * sides (and diagonals): T there is the side's own interpolation, so a side shared by two
 * triangles is listed once. */
static int lattice_points(const struct column_tris *ct, int cell, bool diagonals, struct relief_strip_point *out,
                          int cap)
{
	const int na = ct->width / cell, nd = ct->depth / cell, x1 = ct->c0 + ct->width;
	int k = 0;
	/* inside each triangle: barycentric weights */
	for (int t = 0; t < ct->nt; t++) {
		const int *p[3] = { ct->v[ct->t[t][0]], ct->v[ct->t[t][1]], ct->v[ct->t[t][2]] };
		const double det = (double)(p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) -
		                   (double)(p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
		for (int j = 0; j <= nd; j++)
			for (int i = 0; i <= na; i++) {
				const int g[2] = { ct->c0 + i * cell, j * cell };
				const double l1 = ((double)(g[0] - p[0][0]) * (p[2][1] - p[0][1]) -
				                   (double)(p[2][0] - p[0][0]) * (g[1] - p[0][1])) / det;
				const double l2 = ((double)(p[1][0] - p[0][0]) * (g[1] - p[0][1]) -
				                   (double)(g[0] - p[0][0]) * (p[1][1] - p[0][1])) / det;
				const double l0 = 1.0 - l1 - l2;
				if (l0 < 1e-9 || l1 < 1e-9 || l2 < 1e-9)
					continue;
				const int pts[4][2] = { { p[0][0], p[0][1] }, { p[1][0], p[1][1] }, { p[2][0], p[2][1] }, { g[0], g[1] } };
				k = add_point(out, cap, k, pts, (const double[]){ l0, l1, l2, -1.0 });
			}
	}
	/* along each distinct side */
	for (int t = 0; t < ct->nt; t++)
		for (int e = 0; e < 3; e++) {
			const int ia = ct->t[t][e], ib = ct->t[t][(e + 1) % 3];
			bool seen = false;
			for (int t2 = 0; t2 < t && !seen; t2++)
				for (int e2 = 0; e2 < 3; e2++) {
					const int ja = ct->t[t2][e2], jb = ct->t[t2][(e2 + 1) % 3];
					seen = seen || (ja == ia && jb == ib) || (ja == ib && jb == ia);
				}
			if (seen)
				continue;
			const int *pa = ct->v[ia], *pb = ct->v[ib];
			for (int j = 0; j <= nd; j++)
				for (int i = 0; i <= na; i++) {
					const int g0[2] = { ct->c0 + i * cell, j * cell };
					double u, v;
					if (on_side(pa, pb, g0, &u)) {
						const int pts[4][2] = { { pa[0], pa[1] }, { pb[0], pb[1] }, { g0[0], g0[1] }, { 0, 0 } };
						k = add_point(out, cap, k, pts, (const double[]){ 1 - u, u, -1.0, 0.0 });
					}
					/* the cell sides from g0 (east, south), and the diagonals of the cell at g0 */
					const int ends[4][2][2] = { { { g0[0], g0[1] }, { g0[0] + cell, g0[1] } },
						                    { { g0[0], g0[1] }, { g0[0], g0[1] + cell } },
						                    { { g0[0], g0[1] }, { g0[0] + cell, g0[1] + cell } },
						                    { { g0[0] + cell, g0[1] }, { g0[0], g0[1] + cell } } };
					for (int l = 0; l < (diagonals ? 4 : 2); l++) {
						const int *l0 = ends[l][0], *l1 = ends[l][1];
						if (l1[0] > x1 || l1[1] > ct->depth || l0[0] > x1 || !crossing(pa, pb, l0, l1, &u, &v))
							continue;
						const int pts[4][2] = { { pa[0], pa[1] }, { pb[0], pb[1] }, { l0[0], l0[1] }, { l1[0], l1[1] } };
						k = add_point(out, cap, k, pts, (const double[]){ 1 - u, u, -(1 - v), -v });
					}
				}
		}
	return k;
}

int relief_strip_interior_points(int so, int si, int c0, struct relief_strip_point *out, int cap)
{
	struct column_tris ct;
	coarse_tris(so, si, c0, &ct);
	return lattice_points(&ct, si, true, out, cap);
}

int relief_strip_fine_points(int so, int c0, struct relief_strip_point *out, int cap)
{
	struct column_tris ct;
	fine_tris(so, c0, &ct);
	return lattice_points(&ct, so, false, out, cap);
}

int relief_strip_full_points(int so, int c0, struct relief_strip_point *out, int cap)
{
	struct column_tris ct;
	fine_tris(so, c0, &ct);
	return lattice_points(&ct, 1, true, out, cap);
}

int relief_strip_interior_full_points(int so, int si, int c0, struct relief_strip_point *out, int cap)
{
	struct column_tris ct;
	coarse_tris(so, si, c0, &ct);
	return lattice_points(&ct, 1, true, out, cap);
}

/* The largest deviation of a strip over the points of `l` (columns of `column` samples,
 * each against its first sample for smaller numbers), quanta. */
static float list_deviation(const struct strip *s, const struct point_list *l, int column)
{
	float worst = 0.0f;
	for (int k = 0; k < RELIEF_BLOCK_CELLS / column; k++) {
		const int32_t ref = h(s, k * column, 0);
		for (int i = l->first[k]; i < l->first[k + 1]; i++) {
			const struct relief_strip_point *p = &l->p[i];
			float d = p->w[0] * (float)(h(s, p->s[0][0], p->s[0][1]) - ref);
			for (int t = 1; t < p->n; t++)
				d = d + p->w[t] * (float)(h(s, p->s[t][0], p->s[t][1]) - ref);
			worst = fmaxf(worst, fabsf(d));
		}
	}
	return worst;
}

int relief_strip_bounds(const int32_t *q, uint32_t P, float q2, const float *eps, bool finest, float e0_patch,
                        float *out)
{
	const uint32_t blocks = (P - 1) / RELIEF_BLOCK_CELLS;
	struct strip s = { .q = q, .P = (int)P };
	struct strip_points sp;
	if (strip_points_init(&sp) < 0) {
		strip_points_finish(&sp);
		return -ENOMEM;
	}
	for (uint32_t b = 0; b < blocks * blocks; b++)
		for (int e = 0; e < 4; e++) {
			s.ox = (int)(b % blocks) * RELIEF_BLOCK_CELLS;
			s.oy = (int)(b / blocks) * RELIEF_BLOCK_CELLS;
			s.edge = e;
			float *r = out + ((size_t)b * 4 + (size_t)e) * RELIEF_STRIP_FLOATS;
			const float *eb = eps + (size_t)b * 4;
			/* eps_0, for the strips against full resolution: above the finest level the
			 * caller's bound for the whole patch. At the finest level the patch is the finest
			 * surface, with some diagonal in each cell: the interior's points (at i = 0)
			 * and full resolution's take every diagonal, so they need none; the edge's own
			 * level takes one per cell, so at level 0 it needs half the largest twist of
			 * the two rows a fine-edge strip there spans. */
			const float e0 = finest ? 0.0f : e0_patch;
			for (int l = 1; l <= 4; l++) {
				float charge = 0.0f;
				for (int i = 0; i < l; i++) {
					const float b1 = eb[l - 1] + q2 * coarse_edge(&s, 1 << l, 1 << i);
					const float ei = i == 0 ? e0 : eb[i - 1];
					const float b2 = isinf(ei) ? INFINITY
					                           : ei + q2 * list_deviation(&s, &sp.interior[l - 1][i], 1 << l);
					/* through full resolution with every diagonal (the interior's own at i = 0) */
					const float b3 = i == 0 || isinf(e0) ? INFINITY
					                                     : e0 + q2 * list_deviation(&s, &sp.coarse_full[l - 1][i], 1 << l);
					charge = fmaxf(charge, fminf(fminf(b1, b2), b3));
				}
				r[l - 1] = charge;
			}
			const float e0_2 = finest ? fmaxf(q2 * row_eps(&s, 0), q2 * row_eps(&s, 1)) : e0_patch;
			for (int l = 0; l <= 2; l++) {
				const float b1 = eb[l] + q2 * fine_edge(&s, 1 << l);
				const float el = l == 0 ? e0_2 : eb[l - 1];
				const float b2 = isinf(el) ? INFINITY : el + q2 * list_deviation(&s, &sp.fine[l], 2 << l);
				const float b3 = isinf(e0) ? INFINITY : e0 + q2 * list_deviation(&s, &sp.full[l], 2 << l);
				r[4 + l] = fminf(fminf(b1, b2), b3);
			}
			r[7] = 0.0f;
		}
	strip_points_finish(&sp);
	return 0;
}
