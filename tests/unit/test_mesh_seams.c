/* relief_mesh_seams() on hand-made meshes: a conforming grid (large enough to grow the
 * table) has no seam; a T-junction on the edge's line is found and closed, one off it is
 * open by the right gap; a corner drawn at two heights is split; curtains (vertical) and
 * corners on diagonal edges are left out, as documented. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "mesh_seams.h"

typedef struct relief_mesh_vertex vtx;

static struct relief_mesh_seams check(const vtx *t, uint64_t n)
{
	struct relief_mesh_seams s;
	assert_int_equal(relief_mesh_seams(t, n, 1e-3, &s), 0);
	return s;
}

/* An n x n grid of cells, each split along its diagonal, heights col + 2 row. */
static void test_grid_is_watertight(void **state)
{
	enum { N = 100 };
	vtx *t = malloc(sizeof(*t) * 6 * N * N), *p = t;
	assert_non_null(t);
	for (int64_t r = 0; r < N; r++)
		for (int64_t c = 0; c < N; c++) {
#define V(dc, dr) ((vtx){ c + (dc), r + (dr), (float)(c + (dc) + 2 * (r + (dr))), 7 })
			*p++ = V(0, 0), *p++ = V(1, 0), *p++ = V(1, 1);
			*p++ = V(0, 0), *p++ = V(1, 1), *p++ = V(0, 1);
#undef V
		}
	struct relief_mesh_seams s = check(t, 2 * N * N);
	assert_int_equal(s.positions, (N + 1) * (N + 1));
	assert_int_equal(s.split, 0);
	assert_int_equal(s.junctions, 0);
	assert_int_equal(s.open, 0);
	free(t);
}

/* A coarse square (0,0)-(2,2) beside two fine ones (2,0)-(3,1) and (2,1)-(3,2): the fine
 * corner (2,1) lies inside the coarse edge (2,0)-(2,2), whose heights are 0 and 10. */
static void coarse_beside_fine(vtx *t, float h21)
{
	const vtx m[] = {
		{ 0, 0, 0, 1 }, { 2, 0, 0, 1 }, { 2, 2, 10, 1 }, { 0, 0, 0, 1 }, { 2, 2, 10, 1 }, { 0, 2, 10, 1 },
		{ 2, 0, 0, 2 }, { 3, 0, 0, 2 }, { 3, 1, 5, 2 }, { 2, 0, 0, 2 }, { 3, 1, 5, 2 }, { 2, 1, h21, 2 },
		{ 2, 1, h21, 2 }, { 3, 1, 5, 2 }, { 3, 2, 10, 2 }, { 2, 1, h21, 2 }, { 3, 2, 10, 2 }, { 2, 2, 10, 2 },
	};
	for (size_t i = 0; i < sizeof(m) / sizeof(m[0]); i++)
		t[i] = m[i];
}

static void test_t_junction(void **state)
{
	vtx t[18];
	coarse_beside_fine(t, 5.0f); /* on the coarse edge: sealed */
	struct relief_mesh_seams s = check(t, 6);
	assert_int_equal(s.split, 0);
	assert_int_equal(s.junctions, 1);
	assert_int_equal(s.open, 0);
	assert_true(s.max_gap_m == 0.0);

	coarse_beside_fine(t, 5.0005f); /* within the tolerance */
	s = check(t, 6);
	assert_int_equal(s.junctions, 1);
	assert_int_equal(s.open, 0);

	coarse_beside_fine(t, 7.0f); /* the fine patch's own sample: a crack */
	s = check(t, 6);
	assert_int_equal(s.split, 0);
	assert_int_equal(s.junctions, 1);
	assert_int_equal(s.open, 1);
	assert_true(s.max_gap_m > 1.999 && s.max_gap_m < 2.001);
	assert_true(s.worst.col == 2 && s.worst.row == 1 && s.worst.height == 7.0f);
	assert_true(s.worst_edge[0].row + s.worst_edge[1].row == 2 && s.worst_edge[0].col == 2);
}

static void test_split_corner(void **state)
{
	vtx t[18];
	coarse_beside_fine(t, 5.0f);
	t[11].height = 5.25f; /* one fine triangle draws (2,1) elsewhere */
	struct relief_mesh_seams s = check(t, 6);
	assert_int_equal(s.split, 1);
	assert_true(s.split_at.col == 2 && s.split_at.row == 1);
	/* The junction sees the first height drawn there, 5.25: open too. */
	assert_int_equal(s.open, 1);
}

static void test_left_out(void **state)
{
	/* A curtain below the edge row 0 of a conforming square, hanging to -100 m: vertical, so
	 * its corners at the square's (other heights) split nothing. */
	const vtx curtain[] = {
		{ 0, 0, 0, 1 }, { 1, 0, 1, 1 }, { 1, 1, 3, 1 }, { 0, 0, 0, 1 }, { 1, 1, 3, 1 }, { 0, 1, 2, 1 },
		{ 0, 0, -100, 1 }, { 1, 0, -100, 1 }, { 1, 0, 1, 1 }, { 0, 0, -100, 1 }, { 1, 0, 1, 1 }, { 0, 0, 0, 1 },
	};
	struct relief_mesh_seams s = check(curtain, 4);
	assert_int_equal(s.positions, 4);
	assert_int_equal(s.split, 0);
	/* A corner inside a diagonal edge ((0,0)-(2,2) holds (1,1)) is not searched for. */
	const vtx diagonal[] = {
		{ 0, 0, 0, 1 }, { 2, 0, 0, 1 }, { 2, 2, 0, 1 }, { 0, 0, 0, 1 }, { 1, 1, 50, 2 }, { 0, 2, 0, 2 },
	};
	s = check(diagonal, 2);
	assert_int_equal(s.junctions, 0);
	assert_int_equal(s.split, 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_grid_is_watertight),
		cmocka_unit_test(test_t_junction),
		cmocka_unit_test(test_split_corner),
		cmocka_unit_test(test_left_out),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
