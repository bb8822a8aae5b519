/* relief_mesh_error() on hand-made surfaces and triangles whose answers are known: it finds
 * a peak between a triangle's corners, a crossing of a cell's diagonal, tells the two
 * diagonals apart, skips the cells without a valid corner (a validity mask), vertical
 * triangles and points outside the frustum; the pixel measure
 * (relief_surface_vertical_error()) takes the same cells. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "layout.h"
#include "lod.h"
#include "mesh_error.h"

enum { N = 9 }; /* a 9 x 9 sample grid, 10 m apart, origin (0, 80): rows run south */

static struct relief_file file;
static float z[N * N];

static struct relief_view view_down(void)
{
	/* From 100 m south of the grid and 100 m up, towards its centre (world (40, 40)): the
	 * whole grid in view, vertical segments seen from the side (straight down they would
	 * project to points). */
	return (struct relief_view){ .eye = { 40, -60, 100 }, .target = { 40, 40, 0 }, .fovy = 1.2, .width = 100,
		                     .height = 100, .znear = 1, .zfar = 1e4, .tau = 1 };
}

static void flat(float h)
{
	for (int i = 0; i < N * N; i++)
		z[i] = h;
}

static struct relief_mesh_error measure(const struct relief_mesh_vertex *t, uint64_t n, const struct relief_view *v)
{
	struct relief_mesh_error e;
	relief_mesh_error(&file, v, z, NULL, N, N, t, NULL, n, &e);
	return e;
}

static int setup(void **state)
{
	file.hdr.origin_x = 0;
	file.hdr.origin_y = 80;
	file.hdr.spacing_x = file.hdr.spacing_y = 10;
	return 0;
}

/* A peak at one sample strictly inside a flat triangle's footprint, and one on its edge. */
static void test_peak_inside_and_on_edge(void **state)
{
	struct relief_view v = view_down();
	const struct relief_mesh_vertex t[3] = { { 0, 0, 0, 1 }, { 8, 0, 0, 1 }, { 0, 8, 0, 1 } };
	flat(0);
	z[2 * N + 3] = 7; /* (col 3, row 2): inside */
	struct relief_mesh_error e = measure(t, 1, &v);
	assert_true(fabs(e.max_m - 7) < 1e-9);
	assert_true(fabs(e.worst.x - 30) < 1e-9 && fabs(e.worst.y - 60) < 1e-9 && e.worst.z == 0);
	assert_int_equal(e.triangles, 1);
	assert_int_equal(e.transition, 0); /* half of the 8 x 8 cell at (0, 0): regular */
	flat(0);
	z[4 * N + 4] = -3; /* (4, 4): on the hypotenuse */
	e = measure(t, 1, &v);
	assert_true(fabs(e.max_m - 3) < 1e-9);
	/* In pixels: the segment from the drawn point down to the peak. */
	double px = relief_view_segment_px(&v, (struct relief_vec3){ 40, 40, 0 }, -3.0);
	assert_true(px > 1 && fabs(e.max_px - px) < 1e-9 * px);
}

/* A flat triangle over a cell whose two diagonals differ: against the nearer one the
 * error is where the triangle's edge crosses the cell, against the worse one at its centre. */
static void test_diagonals(void **state)
{
	struct relief_view v = view_down();
	flat(0);
	/* cell (4, 4): corners a (4, 4) = 0, b (5, 4) = 4, c (4, 5) = 4, d (5, 5) = 0: at the centre the
	 * a-d diagonal gives 0, the b-c one 4 */
	z[4 * N + 5] = 4;
	z[5 * N + 4] = 4;
	const struct relief_mesh_vertex t[3] = { { 4, 4, 0, 1 }, { 6, 4, 0, 1 }, { 4, 6, 0, 1 } };
	struct relief_mesh_error e = measure(t, 1, &v);
	/* 4 m at the samples b and c themselves, where both diagonals agree, is the largest. */
	assert_true(fabs(e.max_m - 4) < 1e-9);
	z[4 * N + 5] = 2;
	z[5 * N + 4] = 2;
	const struct relief_mesh_vertex t0[3] = { { 4, 4, 0, 1 }, { 5, 4, 2, 1 }, { 4, 5, 2, 1 } };
	e = measure(t0, 1, &v);
	/* With b and c at 2, t0 is the b-c triangulation's own triangle over the cell's upper-left
	 * half: no error against that diagonal, 2 m against a-d at the centre (a-d gives 0). */
	assert_true(e.max_px == 0.0);
	assert_true(e.max_px_worse > 0.0);
	/* A regular triangle of side 1 is the finest level itself: not counted as above it. */
	assert_true(e.max_px_regular_worse == 0.0);
	assert_int_equal(e.transition, 0);
}

/* A triangle whose regular shape and alignment make it part of a level's triangulation. */
static void test_regular_and_transition(void **state)
{
	struct relief_view v = view_down();
	flat(0);
	const struct relief_mesh_vertex regular[3] = { { 4, 0, 0, 1 }, { 8, 0, 0, 1 }, { 8, 4, 0, 1 } };
	const struct relief_mesh_vertex misaligned[3] = { { 2, 0, 0, 1 }, { 6, 0, 0, 1 }, { 6, 4, 0, 1 } };
	const struct relief_mesh_vertex strip[3] = { { 0, 0, 0, 1 }, { 4, 0, 0, 1 }, { 0, 2, 0, 1 } };
	assert_int_equal(measure(regular, 1, &v).transition, 0);
	assert_int_equal(measure(misaligned, 1, &v).transition, 1);
	assert_int_equal(measure(strip, 1, &v).transition, 1);
}

/* Triangle t (corners in patch samples of quad q, scaled) with its kind. */
static enum relief_mesh_kind kind_of(const struct relief_mesh_quad *q, const int t[3][2])
{
	const int64_t s = q->cells / RELIEF_BLOCK_CELLS;
	struct relief_mesh_vertex c[3];
	for (int k = 0; k < 3; k++)
		c[k] = (struct relief_mesh_vertex){ q->col + s * t[k][0], q->row + s * t[k][1], 0, 1 };
	return relief_mesh_kind(c, q);
}

/* Transition triangles told apart by the strip they lie in (docs/lod.md, "Transition
 * triangles"), on a quad of 2 finest cells per patch cell at (32, 64). */
static void test_kinds(void **state)
{
	/* west: 2 segments (8 samples), north 4 (4), east 16 (1), south 1 (16); inner 8 (2) */
	const struct relief_mesh_quad q = { 32, 64, 32, { 2, 4, 16, 1 }, 8 };
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 0, 0 }, { 2, 0 }, { 2, 2 } }), RELIEF_MESH_REGULAR);
	/* a west segment to the inner ring, within the segment's column, and beyond it */
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 0, 0 }, { 0, 8 }, { 2, 4 } }), RELIEF_MESH_COARSE_EDGE);
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 0, 0 }, { 0, 8 }, { 2, 10 } }), RELIEF_MESH_OTHER);
	/* the south edge's one segment to the ring's far end: still its column */
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 0, 16 }, { 16, 16 }, { 14, 14 } }), RELIEF_MESH_COARSE_EDGE);
	/* east: 1-sample segments against 2-sample cells, within one cell's column, or not */
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 16, 4 }, { 16, 5 }, { 14, 4 } }), RELIEF_MESH_FINE_EDGE);
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 16, 5 }, { 16, 6 }, { 14, 8 } }), RELIEF_MESH_OTHER);
	/* not in any strip: a corner deeper than the ring */
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 0, 0 }, { 0, 8 }, { 4, 4 } }), RELIEF_MESH_OTHER);
	/* at the north-west corner: two corners on the north edge make it the north strip's */
	assert_int_equal(kind_of(&q, (const int[3][2]){ { 0, 0 }, { 4, 0 }, { 2, 2 } }), RELIEF_MESH_COARSE_EDGE);
	/* a fan: the centre alone (inner factor 2, or 1, drawn as 2) to a north segment */
	const struct relief_mesh_quad fan = { 32, 64, 32, { 1, 4, 2, 2 }, 1 };
	assert_int_equal(kind_of(&fan, (const int[3][2]){ { 8, 8 }, { 0, 0 }, { 4, 0 } }), RELIEF_MESH_FAN);
	assert_int_equal(kind_of(&fan, (const int[3][2]){ { 8, 8 }, { 0, 16 }, { 0, 0 } }), RELIEF_MESH_COARSE_EDGE);
	/* equal factors along the edge, yet not regular: not a shape the tessellator makes */
	const struct relief_mesh_quad even = { 32, 64, 32, { 4, 4, 4, 4 }, 4 };
	assert_int_equal(kind_of(&even, (const int[3][2]){ { 0, 0 }, { 4, 0 }, { 8, 4 } }), RELIEF_MESH_OTHER);
	/* off the quad's samples (an odd finest column at 2 per sample), or no quad */
	struct relief_mesh_vertex off[3] = { { 33, 64, 0, 1 }, { 40, 64, 0, 1 }, { 36, 68, 0, 1 } };
	assert_int_equal(relief_mesh_kind(off, &q), RELIEF_MESH_UNKNOWN);
	off[0].col = 32;
	assert_int_equal(relief_mesh_kind(off, NULL), RELIEF_MESH_UNKNOWN);
	/* relief_mesh_error() counts and measures by kind */
	struct relief_view v = view_down();
	flat(0);
	const struct relief_mesh_quad at0 = { 0, 0, 16, { 2, 4, 16, 1 }, 8 };
	const struct relief_mesh_vertex t[3] = { { 0, 0, 3, 1 }, { 0, 8, 3, 1 }, { 2, 4, 3, 1 } };
	struct relief_mesh_error e;
	relief_mesh_error(&file, &v, z, NULL, N, N, t, &at0, 1, &e);
	assert_int_equal(e.kind_triangles[RELIEF_MESH_COARSE_EDGE], 1);
	assert_int_equal(e.transition, 1);
	assert_true(e.kind_max_px[RELIEF_MESH_COARSE_EDGE] > 0);
	assert_true(e.kind_max_px[RELIEF_MESH_COARSE_EDGE] == e.max_px_transition);
	assert_true(e.kind_max_px[RELIEF_MESH_FINE_EDGE] == 0.0);
	e = measure(t, 1, &v);
	assert_int_equal(e.kind_triangles[RELIEF_MESH_UNKNOWN], 1);
}

/* Cells without a valid corner, vertical triangles and points outside the frustum are left
 * out. */
static void test_left_out(void **state)
{
	struct relief_view v = view_down();
	flat(0);
	uint8_t valid[N * N];
	memset(valid, 1, sizeof(valid));
	for (int r = 1; r <= 4; r++) /* every cell the triangle touches has no valid corner */
		for (int c = 2; c <= 5; c++)
			valid[r * N + c] = 0;
	const struct relief_mesh_vertex t[3] = { { 2, 1, 5, 1 }, { 4, 1, 5, 1 }, { 2, 3, 5, 1 } };
	struct relief_mesh_error e;
	relief_mesh_error(&file, &v, z, valid, N, N, t, NULL, 1, &e);
	assert_int_equal(e.points, 0);
	assert_int_equal(e.triangles, 0);
	const struct relief_mesh_vertex curtain[3] = { { 0, 0, 0, 1 }, { 0, 0, -50, 1 }, { 0, 8, 0, 1 } };
	e = measure(curtain, 1, &v);
	assert_int_equal(e.vertical, 1);
	assert_int_equal(e.points, 0);
	/* Looking away (up): nothing in the frustum. */
	flat(0);
	struct relief_view up = v;
	up.target.z = 2000;
	const struct relief_mesh_vertex far[3] = { { 0, 0, 9, 1 }, { 8, 0, 9, 1 }, { 0, 8, 9, 1 } };
	e = measure(far, 1, &up);
	assert_int_equal(e.points, 0);
	assert_true(e.max_px == 0.0);
	e = measure(far, 1, &v);
	assert_true(e.points > 0 && fabs(e.max_m - 9) < 1e-9);
}

/* With a validity mask the no-data samples' decoded heights count: a cell with a valid
 * corner is measured whole (a renderer keeps its part nearest the valid corners, which
 * leans towards the others), a cell without one is left out. */
static void test_valid_mask(void **state)
{
	struct relief_view v = view_down();
	uint8_t valid[N * N];
	memset(valid, 1, sizeof(valid));
	flat(0);
	/* sample (4, 4) no-data, decoded 40 m up: the four cells around it each have three
	 * valid corners, so its 40 m count */
	valid[4 * N + 4] = 0;
	z[4 * N + 4] = 40;
	const struct relief_mesh_vertex t[3] = { { 0, 0, 0, 1 }, { 8, 0, 0, 1 }, { 0, 8, 0, 1 } };
	struct relief_mesh_error e;
	relief_mesh_error(&file, &v, z, valid, N, N, t, NULL, 1, &e);
	assert_true(fabs(e.max_m - 40) < 1e-9);
	/* a 5 x 5 no-data square: (4, 4) lies in cells without a valid corner, left out, while
	 * the ring's cells still count (0 m off) */
	for (int r = 2; r <= 6; r++)
		for (int c = 2; c <= 6; c++)
			valid[r * N + c] = 0;
	relief_mesh_error(&file, &v, z, valid, N, N, t, NULL, 1, &e);
	assert_true(e.points > 0 && e.max_m == 0.0);
	/* the mask with no no-data measures as NULL does */
	memset(valid, 1, sizeof(valid));
	struct relief_mesh_error all = measure(t, 1, &v);
	relief_mesh_error(&file, &v, z, valid, N, N, t, NULL, 1, &e);
	assert_true(e.points == all.points && e.max_m == all.max_m && fabs(e.max_m - 40) < 1e-9);
}

/* The pixel measure (lod.h) takes the same cells: those with a valid corner whole, at the
 * no-data corners' decoded heights; a cell without one reads 0. */
static void test_pixel_measure_mask(void **state)
{
	uint8_t valid[N * N];
	memset(valid, 1, sizeof(valid));
	flat(0);
	valid[4 * N + 4] = 0;
	z[4 * N + 4] = 40;
	/* finest (3.75, 3.75), in the cell whose south-east corner is the no-data sample: the
	 * diagonals through it put the surface 30 m (that corner's) and 20 m up, the nearer
	 * is 20 m from a point at 0 m */
	const struct relief_vec3 p = { 37.5, 80 - 37.5, 0 };
	double mid, e = relief_surface_vertical_error(&file, z, valid, N, N, 1, p, &mid);
	assert_true(fabs(e + 20) < 1e-9 && fabs(mid + 25) < 1e-9);
	assert_true(relief_surface_vertical_error(&file, z, NULL, N, N, 1, p, NULL) == e);
	/* a 5 x 5 no-data square around it: its inner cells read 0, its rim's cells count */
	for (int r = 2; r <= 6; r++)
		for (int c = 2; c <= 6; c++)
			valid[r * N + c] = 0;
	assert_true(relief_surface_vertical_error(&file, z, valid, N, N, 1, p, &mid) == 0.0 && mid == 0.0);
	z[2 * N + 2] = 8; /* the square's north-west corner; finest (1.5, 1.5), 10 m up */
	e = relief_surface_vertical_error(&file, z, valid, N, N, 1, (struct relief_vec3){ 15, 80 - 15, 10 }, &mid);
	assert_true(fabs(e - 6) < 1e-9 && fabs(mid - 8) < 1e-9);
	/* a point on the western edge's curtain, 30 m below the edge, reads 30 m on either side
	 * of the edge (rounding puts a drawn curtain point on either); beyond one cell out, 0 */
	assert_true(relief_surface_vertical_error(&file, z, valid, N, N, 1, (struct relief_vec3){ 0, 40, -30 }, NULL) ==
	            -30.0);
	assert_true(relief_surface_vertical_error(&file, z, valid, N, N, 1, (struct relief_vec3){ -1e-9, 40, -30 },
	                                          NULL) == -30.0);
	assert_true(relief_surface_vertical_error(&file, z, valid, N, N, 1, (struct relief_vec3){ -11, 40, -30 }, NULL) ==
	            0.0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_peak_inside_and_on_edge),
		cmocka_unit_test(test_diagonals),
		cmocka_unit_test(test_regular_and_transition),
		cmocka_unit_test(test_kinds),
		cmocka_unit_test(test_left_out),
		cmocka_unit_test(test_valid_mask),
		cmocka_unit_test(test_pixel_measure_mask),
	};
	return cmocka_run_group_tests(tests, setup, NULL);
}
