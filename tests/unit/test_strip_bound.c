/* relief_strip_bounds() (the CPU twin of shaders/patch_strips.comp) against an independent
 * evaluation: every triangle a transition strip can hold (docs/lod.md, "Transition
 * triangles: what bounds them": corners on the edge's vertices and the inner ring,
 * within one column of the strip) measured densely against both triangulations of its
 * column's square, the better one kept, never exceeds the stored bound; and a single bump
 * gives the values worked out by hand. */
#include <math.h>
#include <setjmp.h>
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

/* The largest |T - L| over T, densely sampled, L the column square's triangulation (corners
 * at along c0, c0 + c and depth 0, c) by diagonal `diag` (0: from (c0, 0) to (c0 + c, c),
 * 1: from (c0, c) to (c0 + c, 0)). */
static double worst_against(const struct tri *t, const double h[4], double c0, double c, int diag)
{
	const int n = 48;
	double worst = 0;
	for (int i = 0; i <= n; i++)
		for (int j = 0; i + j <= n; j++) {
			double l1 = (double)i / n, l2 = (double)j / n, l0 = 1 - l1 - l2;
			double a = l0 * t->a[0] + l1 * t->a[1] + l2 * t->a[2];
			double d = l0 * t->d[0] + l1 * t->d[1] + l2 * t->d[2];
			double z = l0 * t->z[0] + l1 * t->z[1] + l2 * t->z[2];
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

/* The bound a triangle of the strip gets from its square: the better triangulation's. */
static double triangle_bound(int bx, int by, int edge, double c0, double c, const int pts[3][2])
{
	struct tri t;
	for (int k = 0; k < 3; k++) {
		t.a[k] = pts[k][0];
		t.d[k] = pts[k][1];
		t.z[k] = sample(bx, by, edge, pts[k][0], pts[k][1]);
	}
	const double h[4] = { sample(bx, by, edge, (int)c0, 0), sample(bx, by, edge, (int)(c0 + c), 0),
		              sample(bx, by, edge, (int)c0, (int)c), sample(bx, by, edge, (int)(c0 + c), (int)c) };
	return fmin(worst_against(&t, h, c0, c, 0), worst_against(&t, h, c0, c, 1));
}

/* Every candidate triangle of every strip of every block within its bound (quanta; the
 * bounds are in metres at q2). Returns the largest ratio of a triangle's own bound to the
 * stored one. */
static double check_candidates(const float *out, double q2)
{
	double ratio = 0;
	for (int by = 0; by < B; by++)
		for (int bx = 0; bx < B; bx++)
			for (int edge = 0; edge < 4; edge++) {
				const float *r = out + ((size_t)(by * B + bx) * 4 + (size_t)edge) * RELIEF_STRIP_FLOATS;
				/* coarse-edge strips: an edge of segments so, rings at si < so */
				for (int e = 1; e <= 4; e++) {
					const int so = 1 << e;
					const double bound = r[e - 1] / q2 * (1 + 1e-5) + 1e-6; /* float rounding */
					for (int c0 = 0; c0 < N; c0 += so)
						for (int si = 1; si < so; si *= 2)
							for (int t = c0 > si ? c0 : si; t <= c0 + so && t <= N - si; t += si) {
								const int seg[3][2] = { { c0, 0 }, { c0 + so, 0 }, { t, si } };
								double w = triangle_bound(bx, by, edge, c0, so, seg);
								if (t + si <= c0 + so && t + si <= N - si)
									for (int end = 0; end < 2; end++) {
										const int ring[3][2] = { { end ? c0 + so : c0, 0 }, { t, si }, { t + si, si } };
										w = fmax(w, triangle_bound(bx, by, edge, c0, so, ring));
									}
								assert_true(w <= bound);
								ratio = fmax(ratio, w / bound);
							}
				}
				/* fine-edge strips: an edge of segments so, a ring at c = 2 so */
				for (int e = 0; e <= 2; e++) {
					const int so = 1 << e, c = 2 * so;
					const double bound = r[4 + e] / q2 * (1 + 1e-5) + 1e-6;
					for (int c0 = 0; c0 < N; c0 += c) {
						double w = 0;
						for (int end = 0; end < 2; end++) {
							const int top = end ? c0 + c : c0;
							if (top < c || top > N - c)
								continue; /* the ring is inset from the block's corners */
							for (int s = 0; s < 2; s++) {
								const int seg[3][2] = { { c0 + s * so, 0 }, { c0 + (s + 1) * so, 0 }, { top, c } };
								w = fmax(w, triangle_bound(bx, by, edge, c0, c, seg));
							}
						}
						if (c0 >= c && c0 + c <= N - c)
							for (int v = 0; v <= 2; v++) {
								const int tent[3][2] = { { c0, c }, { c0 + c, c }, { c0 + v * so, 0 } };
								w = fmax(w, triangle_bound(bx, by, edge, c0, c, tent));
							}
						assert_true(w <= bound);
						ratio = fmax(ratio, w / bound);
					}
				}
			}
	return ratio;
}

static void test_random_patches_within_bounds(void **state)
{
	float *out = malloc(sizeof(float) * B * B * 4 * RELIEF_STRIP_FLOATS);
	srand(7);
	double ratio = 0;
	for (int run = 0; run < 6; run++) {
		const int amp = run % 2 ? 20 : 2000; /* rough and gentle */
		for (size_t k = 0; k < sizeof(q) / sizeof(q[0]); k++)
			q[k] = rand() % (2 * amp + 1) - amp + (int32_t)(k % (P + 2)) * 37;
		relief_strip_bounds(q, P, 0.25f, NULL, out);
		ratio = fmax(ratio, check_candidates(out, 0.25));
	}
	/* The bound is reached, not only respected: some triangle measures close to it. */
	print_message("largest triangle bound over the stored bound: %.3f\n", ratio);
	assert_true(ratio > 0.5);
	free(out);
}

/* One quantum up at sample (4, 2) of a flat patch: along block (0, 0)'s north edge a ring
 * vertex at depth 2, so 1 quantum off every coarse-edge square with rings that deep (levels
 * 2, 3, 4), half a quantum off level 1's rings at depth 1 (the bump is a corner of their
 * squares), a third of a quantum on the tents of level 0 (it is a corner of their far
 * side), nothing elsewhere; as no-data, nothing at all. */
static void test_bump(void **state)
{
	memset(q, 0, sizeof(q));
	q[(2 + 1) * (P + 2) + 4 + 1] = 1;
	float out[B * B * 4 * RELIEF_STRIP_FLOATS];
	relief_strip_bounds(q, P, 2.0f, NULL, out);
	const float north[RELIEF_STRIP_FLOATS] = { 1.0f, 2.0f, 2.0f, 2.0f, 2.0f / 3.0f, 0, 0, 0 };
	for (int k = 0; k < RELIEF_STRIP_FLOATS; k++)
		assert_true(fabsf(out[1 * RELIEF_STRIP_FLOATS + k] - north[k]) < 1e-6f);
	for (size_t k = 0; k < sizeof(out) / sizeof(out[0]); k++)
		if (k / RELIEF_STRIP_FLOATS != 1)
			assert_true(out[k] == 0.0f);
	uint8_t valid[P * P];
	memset(valid, 1, sizeof(valid));
	valid[2 * P + 4] = 0;
	relief_strip_bounds(q, P, 2.0f, valid, out);
	for (size_t k = 0; k < sizeof(out) / sizeof(out[0]); k++)
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
