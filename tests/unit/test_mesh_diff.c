/* tools/mesh_diff.c: the quads of two mesh captures compared place by place (what
 * `relief bench lod` reports of each popping event). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "mesh_diff.h"

/* A triangle's quad record as a capture holds it: the padding is whatever the memory held,
 * different in every record. */
static struct relief_mesh_quad quad(int64_t col, int64_t row, uint32_t cells, const char outer[4], uint8_t inner)
{
	static uint8_t junk = 0xa5;
	struct relief_mesh_quad q;
	memset(&q, junk++, sizeof(q));
	q.col = col;
	q.row = row;
	q.cells = cells;
	for (int k = 0; k < 4; k++)
		q.outer[k] = (uint8_t)(outer[k] - '0');
	q.inner = inner;
	return q;
}

static void test_counts_by_kind(void **state)
{
	(void)state;
	/* Several triangles per quad, in no order. */
	const struct relief_mesh_quad a[] = {
		quad(16, 0, 16, "4444", 4), quad(0, 0, 16, "4444", 4), quad(0, 16, 16, "2222", 2),
		quad(16, 0, 16, "4444", 4), quad(32, 0, 16, "1111", 1), quad(0, 0, 16, "4444", 4),
		quad(0, 32, 32, "2222", 2),
	};
	const struct relief_mesh_quad b[] = {
		quad(0, 0, 16, "4444", 4),  /* the same */
		quad(16, 0, 16, "4448", 4), /* an edge refined, the interior as it was */
		quad(0, 16, 16, "2224", 4), /* an edge and the interior */
		quad(0, 16, 16, "2224", 4),
		quad(48, 0, 16, "1111", 1), /* a place only b draws; (32, 0) only a */
		quad(0, 32, 16, "2222", 2), /* the 32-cell quad split: another place */
		quad(16, 32, 16, "2222", 2), quad(0, 48, 16, "2222", 2), quad(16, 48, 16, "2222", 2),
	};
	struct mesh_quads qa, qb;
	assert_int_equal(mesh_quads_init(&qa, a, sizeof(a) / sizeof(a[0])), 0);
	assert_int_equal(mesh_quads_init(&qb, b, sizeof(b) / sizeof(b[0])), 0);
	assert_int_equal(qa.n, 5); /* one per place, padding ignored */
	assert_int_equal(qb.n, 8);
	struct mesh_quad_changes ch = { 0 };
	mesh_quads_compare(&qa, &qb, NULL, &ch);
	assert_int_equal(ch.interiors, 1);
	assert_int_equal(ch.edges, 1);
	assert_int_equal(ch.coarse, 2 + 5); /* (32, 0), (48, 0); the split: 1 place gone, 4 new */
	/* Counts add up over calls, and a mesh against itself changes nothing. */
	mesh_quads_compare(&qb, &qb, NULL, &ch);
	assert_int_equal(ch.interiors + ch.edges + ch.coarse, 9);
	/* The trace has a line per changed place. */
	FILE *t = tmpfile();
	assert_non_null(t);
	struct mesh_quad_changes again = { 0 };
	mesh_quads_compare(&qa, &qb, t, &again);
	rewind(t);
	int lines = 0, c;
	while ((c = fgetc(t)) != EOF)
		lines += c == '\n';
	fclose(t);
	assert_int_equal(lines, 9);
	mesh_quads_finish(&qa);
	mesh_quads_finish(&qb);
	mesh_quads_finish(&qb); /* twice, and NULL: accepted */
	mesh_quads_finish(NULL);
}

static void test_empty(void **state)
{
	(void)state;
	const struct relief_mesh_quad b[] = { quad(0, 0, 16, "8888", 8) };
	struct mesh_quads qa, qb;
	assert_int_equal(mesh_quads_init(&qa, NULL, 0), 0);
	assert_int_equal(mesh_quads_init(&qb, b, 1), 0);
	struct mesh_quad_changes ch = { 0 };
	mesh_quads_compare(&qa, &qa, NULL, &ch);
	assert_int_equal(ch.interiors + ch.edges + ch.coarse, 0);
	mesh_quads_compare(&qa, &qb, NULL, &ch);
	mesh_quads_compare(&qb, &qa, NULL, &ch);
	assert_int_equal(ch.coarse, 2);
	mesh_quads_finish(&qa);
	mesh_quads_finish(&qb);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_counts_by_kind),
		cmocka_unit_test(test_empty),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
