/* relief_strip_bounds() (the CPU twin of shaders/patch_strips.comp) against an independent
 * evaluation: every triangle a transition strip can hold (docs/lod.md, "Transition
 * triangles: what bounds them": corners on the edge's vertices and the inner ring,
 * within one column of the strip) measured densely against both triangulations of its
 * column's square, the better one kept, and, for a coarse-edge strip, against the finer
 * interior's triangulation (either diagonal in every cell): the stored charge is never
 * below the smaller of the two bounds those give with the block's errors; for a fine-edge
 * strip, against its square and against the edge's own level's cells (the better diagonal
 * in every cell), likewise; and a single bump gives the values worked out by hand. */
#include <math.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "layout.h"
#include "strip_bound.h"

enum { P = 33, B = (P - 1) / RELIEF_BLOCK_CELLS, N = RELIEF_BLOCK_CELLS };

static int32_t q[(P + 2) * (P + 2)];

/* Sample (along, depth) of block (bx, by)'s edge (0 west, 1 north, 2 east, 3 south), as
 * a height in quanta. */
static double sample(int bx, int by, int edge, int along, int depth)
{
	int x = bx * N + (edge == 0 ? depth : edge == 2 ? N - depth : along);
	int y = by * N + (edge == 1 ? depth : edge == 3 ? N - depth : along);
	return q[(y + 1) * (P + 2) + x + 1];
}

struct tri {
	double a[3], d[3], z[3]; /* along, depth, height */
};

/* The points of T's dense sampling: point (i, j) of a barycentric grid of DENSE steps,
 * as (along, depth, height). */
enum { DENSE = 48 };
static void tri_point(const struct tri *t, int i, int j, double *a, double *d, double *z)
{
	double l1 = (double)i / DENSE, l2 = (double)j / DENSE, l0 = 1 - l1 - l2;
	*a = l0 * t->a[0] + l1 * t->a[1] + l2 * t->a[2];
	*d = l0 * t->d[0] + l1 * t->d[1] + l2 * t->d[2];
	*z = l0 * t->z[0] + l1 * t->z[1] + l2 * t->z[2];
}

/* The largest |T - L| over T, densely sampled, L the column square's triangulation (corners
 * at along c0, c0 + c and depth 0, c) by diagonal `diag` (0: from (c0, 0) to (c0 + c, c),
 * 1: from (c0, c) to (c0 + c, 0)). */
static double worst_against(const struct tri *t, const double h[4], double c0, double c, int diag)
{
	double worst = 0;
	for (int i = 0; i <= DENSE; i++)
		for (int j = 0; i + j <= DENSE; j++) {
			double a, d, z;
			tri_point(t, i, j, &a, &d, &z);
			double u = (a - c0) / c, v = d / c; /* in the square, 0..1; h: 00, 10, 01, 11 */
			double lz;
			if (diag == 0)
				lz = u >= v ? h[0] + u * (h[1] - h[0]) + v * (h[3] - h[1]) : h[0] + v * (h[2] - h[0]) + u * (h[3] - h[2]);
			else
				lz = u + v <= 1 ? h[0] + u * (h[1] - h[0]) + v * (h[2] - h[0])
				                : h[3] + (1 - u) * (h[2] - h[3]) + (1 - v) * (h[1] - h[3]);
			worst = fmax(worst, fabs(z - lz));
		}
	return worst;
}

/* At (u, v) in the cell of side si from sample (x0, y0) (along, depth), the cell's
 * triangulation by the diagonal from (x0, y0) (*lz0) and by the other (*lz1). */
static void cell_planes(int bx, int by, int edge, int x0, int y0, int si, double u, double v, double *lz0, double *lz1)
{
	double h00 = sample(bx, by, edge, x0, y0), h10 = sample(bx, by, edge, x0 + si, y0);
	double h01 = sample(bx, by, edge, x0, y0 + si), h11 = sample(bx, by, edge, x0 + si, y0 + si);
	*lz0 = u >= v ? h00 + u * (h10 - h00) + v * (h11 - h10) : h00 + v * (h01 - h00) + u * (h11 - h01);
	*lz1 = u + v <= 1 ? h00 + u * (h10 - h00) + v * (h01 - h00) : h11 + (1 - u) * (h01 - h11) + (1 - v) * (h10 - h11);
}

/* The largest |T - L| over T, densely sampled, L the triangulation of the cells of side si
 * (the interior's, or full resolution's at si = 1), the worse of both diagonals at every
 * point. */
static double worst_against_cells(int bx, int by, int edge, const struct tri *t, int si)
{
	double worst = 0;
	for (int i = 0; i <= DENSE; i++)
		for (int j = 0; i + j <= DENSE; j++) {
			double a, d, z;
			tri_point(t, i, j, &a, &d, &z);
			/* the cell holding the point; a corner's barycentric sum may round just outside */
			int x0 = (int)floor(a / si) * si, y0 = (int)floor(d / si) * si;
			x0 = x0 < 0 ? 0 : x0 > N - si ? N - si : x0;
			y0 = y0 < 0 ? 0 : y0 > N - si ? N - si : y0;
			double lz0, lz1;
			cell_planes(bx, by, edge, x0, y0, si, (a - x0) / si, (d - y0) / si, &lz0, &lz1);
			worst = fmax(worst, fmax(fabs(z - lz0), fabs(z - lz1)));
		}
	return worst;
}

static void fill_tri(int bx, int by, int edge, const int pts[3][2], struct tri *t)
{
	for (int k = 0; k < 3; k++) {
		t->a[k] = pts[k][0];
		t->d[k] = pts[k][1];
		t->z[k] = sample(bx, by, edge, pts[k][0], pts[k][1]);
	}
}

/* The bound a triangle of the strip gets from its square: the better triangulation's. */
static double triangle_bound(int bx, int by, int edge, double c0, double c, const int pts[3][2])
{
	struct tri t;
	fill_tri(bx, by, edge, pts, &t);
	const double h[4] = { sample(bx, by, edge, (int)c0, 0), sample(bx, by, edge, (int)(c0 + c), 0),
		              sample(bx, by, edge, (int)c0, (int)c), sample(bx, by, edge, (int)(c0 + c), (int)c) };
	return fmin(worst_against(&t, h, c0, c, 0), worst_against(&t, h, c0, c, 1));
}

/* The largest |T - L_e| over T, densely sampled, L_e the triangulation of the cells of
 * side so in the fine-edge column from along c0 (2 x 2 cells, depth 0 to 2 so), with the
 * better diagonal in each cell. */
static double worst_against_level(int bx, int by, int edge, const struct tri *t, int c0, int so)
{
	double worst[2][2][2] = { { { 0 } } }; /* [row][column][diagonal] */
	for (int i = 0; i <= DENSE; i++)
		for (int j = 0; i + j <= DENSE; j++) {
			double a, d, z;
			tri_point(t, i, j, &a, &d, &z);
			/* the cell holding the point; a corner's barycentric sum may round just outside */
			int cx = (int)floor((a - c0) / so), cy = (int)floor(d / so);
			cx = cx < 0 ? 0 : cx > 1 ? 1 : cx;
			cy = cy < 0 ? 0 : cy > 1 ? 1 : cy;
			const int x0 = c0 + cx * so, y0 = cy * so;
			double lz0, lz1;
			cell_planes(bx, by, edge, x0, y0, so, (a - x0) / so, (d - y0) / so, &lz0, &lz1);
			worst[cy][cx][0] = fmax(worst[cy][cx][0], fabs(z - lz0));
			worst[cy][cx][1] = fmax(worst[cy][cx][1], fabs(z - lz1));
		}
	double w = 0;
	for (int k = 0; k < 4; k++)
		w = fmax(w, fmin(worst[k / 2][k % 2][0], worst[k / 2][k % 2][1]));
	return w;
}

/* Half the largest twist of the first `rows` rows of cells along the edge, quanta. */
static double first_rows_twist(int bx, int by, int edge, int rows)
{
	double worst = 0;
	for (int r = 0; r < rows; r++)
		for (int k = 0; k < N; k++)
			worst = fmax(worst, 0.5 * fabs(sample(bx, by, edge, k, r) + sample(bx, by, edge, k + 1, r + 1) -
			                               sample(bx, by, edge, k + 1, r) - sample(bx, by, edge, k, r + 1)));
	return worst;
}

/* What the checks saw: the largest ratio for the fine-edge charges (as check_candidates()
 * returns for the coarse-edge ones), how many fine-edge charges the edge's own level and
 * full resolution gave (the tightest of the three), and how many coarse-edge level pairs
 * full resolution bounded most tightly. */
struct seen {
	double fine_ratio;
	unsigned own_level, full, coarse_full;
};

/* Every candidate triangle of every strip of every block within its bound (metres; q2
 * metres per quantum, eps the blocks' errors as given to relief_strip_bounds()). A
 * coarse-edge strip triangle T against an interior at level i must be within the stored
 * charge of its edge's level e: at most the least of eps_e + its D against the square,
 * eps_i + its D against the interior's cells and eps_0 + its D against full resolution.
 * Returns the largest ratio, over every edge and level, of the charge worked out here from
 * the dense measures (per level pair, the least of the largest bounds of each kind) to the
 * stored one: close to 1 when relief_strip_bounds() finds the same maxima (the dense grid
 * may miss a peak slightly). */
static double check_candidates(const float *out, double q2, const float *eps, bool finest, double e0_patch,
                               struct seen *seen)
{
	double ratio = 0;
	for (int by = 0; by < B; by++)
		for (int bx = 0; bx < B; bx++)
			for (int edge = 0; edge < 4; edge++) {
				const float *r = out + ((size_t)(by * B + bx) * 4 + (size_t)edge) * RELIEF_STRIP_FLOATS;
				const float *eb = eps + (size_t)(by * B + bx) * 4;
				/* at the finest level the dense measure against every diagonal of the full
				 * resolution is the distance from the finest surface itself */
				const double e0 = finest ? 0.0 : e0_patch;
				/* coarse-edge strips: an edge of segments so, rings at si < so */
				for (int e = 1; e <= 4; e++) {
					const int so = 1 << e;
					const double stored = r[e - 1] * (1 + 1e-5) + 1e-6; /* float rounding */
					double charge = 0;
					for (int i = 0; i < e; i++) {
						const int si = 1 << i;
						const double ei = i == 0 ? e0 : eb[i - 1];
						double worst_c = 0, worst_i = 0, worst_f = 0;
						for (int c0 = 0; c0 < N; c0 += so)
							for (int t = c0 > si ? c0 : si; t <= c0 + so && t <= N - si; t += si) {
								int tris[3][3][2] = { { { c0, 0 }, { c0 + so, 0 }, { t, si } } };
								int nt = 1;
								if (t + si <= c0 + so && t + si <= N - si)
									for (int end = 0; end < 2; end++) {
										const int ring[3][2] = { { end ? c0 + so : c0, 0 }, { t, si }, { t + si, si } };
										memcpy(tris[nt++], ring, sizeof(ring));
									}
								for (int k = 0; k < nt; k++) {
									struct tri tt;
									fill_tri(bx, by, edge, (const int(*)[2])tris[k], &tt);
									const double dc = triangle_bound(bx, by, edge, c0, so, (const int(*)[2])tris[k]);
									const double di = worst_against_cells(bx, by, edge, &tt, si);
									const double df = si == 1 ? di : worst_against_cells(bx, by, edge, &tt, 1);
									const double own = fmin(fmin(eb[e - 1] + q2 * dc, ei + q2 * di), e0 + q2 * df);
									assert_true(own <= stored);
									worst_c = fmax(worst_c, dc);
									worst_i = fmax(worst_i, di);
									worst_f = fmax(worst_f, df);
								}
							}
						const double bc = eb[e - 1] + q2 * worst_c, bi = ei + q2 * worst_i, bf = e0 + q2 * worst_f;
						charge = fmax(charge, fmin(fmin(bc, bi), bf));
						seen->coarse_full += i > 0 && bf < fmin(bc, bi);
					}
					if (charge > 0)
						ratio = fmax(ratio, charge / stored);
				}
				/* fine-edge strips: an edge of segments so, a ring at c = 2 so, against an
				 * interior at e + 1: each triangle within the smallest of eps_(e+1) + its D
				 * against the column's square, eps_e + its D against the edge's level and
				 * eps_0 + its D against full resolution (every diagonal) */
				const double e0_2 = finest ? q2 * first_rows_twist(bx, by, edge, 2) : e0_patch;
				for (int e = 0; e <= 2; e++) {
					const int so = 1 << e, c = 2 * so;
					const double stored = r[4 + e] * (1 + 1e-5) + 1e-6, ee = e == 0 ? e0_2 : eb[e - 1];
					double worst_q = 0, worst_e = 0, worst_f = 0;
					for (int c0 = 0; c0 < N; c0 += c) {
						int tris[7][3][2], nt = 0;
						for (int end = 0; end < 2; end++) {
							const int top = end ? c0 + c : c0;
							if (top < c || top > N - c)
								continue; /* the ring is inset from the block's corners */
							for (int s = 0; s < 2; s++) {
								const int seg[3][2] = { { c0 + s * so, 0 }, { c0 + (s + 1) * so, 0 }, { top, c } };
								memcpy(tris[nt++], seg, sizeof(seg));
							}
						}
						if (c0 >= c && c0 + c <= N - c)
							for (int v = 0; v <= 2; v++) {
								const int tent[3][2] = { { c0, c }, { c0 + c, c }, { c0 + v * so, 0 } };
								memcpy(tris[nt++], tent, sizeof(tent));
							}
						for (int k = 0; k < nt; k++) {
							struct tri tt;
							fill_tri(bx, by, edge, (const int(*)[2])tris[k], &tt);
							const double dq = triangle_bound(bx, by, edge, c0, c, (const int(*)[2])tris[k]);
							const double de = worst_against_level(bx, by, edge, &tt, c0, so);
							const double df = worst_against_cells(bx, by, edge, &tt, 1);
							assert_true(fmin(fmin(eb[e] + q2 * dq, ee + q2 * de), e0 + q2 * df) <= stored);
							worst_q = fmax(worst_q, dq);
							worst_e = fmax(worst_e, de);
							worst_f = fmax(worst_f, df);
						}
					}
					const double bq = eb[e] + q2 * worst_q, be = ee + q2 * worst_e, bf = e0 + q2 * worst_f;
					const double charge = fmin(fmin(bq, be), bf);
					if (charge > 0)
						seen->fine_ratio = fmax(seen->fine_ratio, charge / stored);
					seen->own_level += be < bq && be <= bf;
					seen->full += bf < fmin(bq, be);
				}
			}
	return ratio;
}

static void test_random_patches_within_bounds(void **state)
{
	(void)state;
	float *out = malloc(sizeof(float) * B * B * 4 * RELIEF_STRIP_FLOATS);
	float eps[B * B * 4];
	srand(7);
	double ratio = 0;
	struct seen seen = { 0 };
	for (int run = 0; run < 8; run++) {
		const int amp = run % 2 ? 20 : 2000; /* rough and gentle */
		for (size_t k = 0; k < sizeof(q) / sizeof(q[0]); k++)
			q[k] = rand() % (2 * amp + 1) - amp + (int32_t)(k % (P + 2)) * 37;
		/* errors growing with the level, of the size of the strips' own deviations or not */
		for (int b = 0; b < B * B; b++)
			for (int l = 0; l < 4; l++)
				eps[b * 4 + l] = (float)(0.25 * amp * (l + 1) * (rand() % 100) / 50.0);
		/* above the finest level, eps_0 unknown or given (a patch's drawn error) */
		const bool finest = run < 4;
		const float e0 = run < 6 ? INFINITY : (float)(0.25 * amp * (rand() % 100) / 50.0);
		assert_int_equal(relief_strip_bounds(q, P, 0.25f, eps, finest, e0, out), 0);
		ratio = fmax(ratio, check_candidates(out, 0.25, eps, finest, e0, &seen));
	}
	/* The charge is reached, not only respected: the dense measures come close to it. */
	print_message("largest charge from the dense measures over the stored one: %.3f coarse-edge, %.3f fine-edge "
	              "(fine-edge charges from the edge's own level: %u, from full resolution: %u; coarse-edge level "
	              "pairs from full resolution: %u)\n",
	              ratio, seen.fine_ratio, seen.own_level, seen.full, seen.coarse_full);
	assert_true(ratio > 0.95);
	assert_true(seen.fine_ratio > 0.95);
	assert_true(seen.own_level > 0);
	assert_true(seen.full > 0);
	assert_true(seen.coarse_full > 0);
	free(out);
}

/* One quantum up at sample (4, 1) of a flat patch, q2 = 2 m, eps_1 = 2 m: along block
 * (0, 0)'s north edge a ring vertex at depth 1. For an edge at level 1 (segments of 2,
 * rings at depth 1) the column square's bound is eps_1 + 1 quantum (the bump off its
 * square's plane) = 4 m; the full resolution's is eps_0 plus 2/3 of a quantum: the side
 * from (2, 0) to the bump crosses the diagonal from (4, 0) to (3, 1), flat, two thirds of
 * the way up. At the finest level eps_0 is 0 (the full resolution is the finest surface,
 * and every diagonal is taken), so the charge is 4/3 m; above it 4 m with eps_0 unknown,
 * 1 + 4/3 m with eps_0 given as 1 m. Without errors, the bounds of the edges that do not
 * reach the bump are 0. */
static void test_bump(void **state)
{
	(void)state;
	memset(q, 0, sizeof(q));
	q[(1 + 1) * (P + 2) + 4 + 1] = 1;
	float out[B * B * 4 * RELIEF_STRIP_FLOATS], eps[B * B * 4];
	for (int k = 0; k < B * B * 4; k++)
		eps[k] = 2.0f;
	assert_int_equal(relief_strip_bounds(q, P, 2.0f, eps, false, INFINITY, out), 0);
	assert_true(fabsf(out[1 * RELIEF_STRIP_FLOATS] - 4.0f) < 1e-6f);
	assert_int_equal(relief_strip_bounds(q, P, 2.0f, eps, true, INFINITY, out), 0);
	assert_true(fabsf(out[1 * RELIEF_STRIP_FLOATS] - 4.0f / 3.0f) < 1e-5f);
	assert_int_equal(relief_strip_bounds(q, P, 2.0f, eps, false, 1.0f, out), 0);
	assert_true(fabsf(out[1 * RELIEF_STRIP_FLOATS] - (1.0f + 4.0f / 3.0f)) < 1e-5f);
	/* Without errors, the strips' own deviations: none where the bump is out of reach. */
	memset(eps, 0, sizeof(eps));
	assert_int_equal(relief_strip_bounds(q, P, 2.0f, eps, false, INFINITY, out), 0);
	assert_true(out[1 * RELIEF_STRIP_FLOATS] > 0.0f);
	for (size_t k = 0; k < sizeof(out) / sizeof(out[0]); k++)
		if (k / RELIEF_STRIP_FLOATS != 0 && k / RELIEF_STRIP_FLOATS != 1)
			assert_true(out[k] == 0.0f);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bump),
		cmocka_unit_test(test_random_patches_within_bounds),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
