/* Quads of two mesh captures compared place by place (mesh_diff.h). */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "mesh_diff.h"

/* Orders by place (side, row, column). */
static int place_cmp(const struct relief_mesh_quad *a, const struct relief_mesh_quad *b)
{
	if (a->cells != b->cells)
		return a->cells < b->cells ? -1 : 1;
	if (a->row != b->row)
		return a->row < b->row ? -1 : 1;
	if (a->col != b->col)
		return a->col < b->col ? -1 : 1;
	return 0;
}

static int factors_cmp(const struct relief_mesh_quad *a, const struct relief_mesh_quad *b)
{
	int c = memcmp(a->outer, b->outer, sizeof(a->outer));
	return c ? c : (int)a->inner - (int)b->inner;
}

/* By place, then by factors: the copies of one quad are adjacent. */
static int quad_cmp(const void *pa, const void *pb)
{
	const struct relief_mesh_quad *a = pa, *b = pb;
	int c = place_cmp(a, b);
	return c ? c : factors_cmp(a, b);
}

/* Copies the n records of src to dst leaving out each that equals the one kept before it
 * (quad_cmp(): a record's padding is not part of its quad); returns how many are kept. dst
 * may be src. */
static uint64_t drop_adjacent_copies(struct relief_mesh_quad *dst, const struct relief_mesh_quad *src, uint64_t n)
{
	uint64_t m = 0;
	for (uint64_t k = 0; k < n; k++)
		if (m == 0 || quad_cmp(&dst[m - 1], &src[k]) != 0)
			dst[m++] = src[k];
	return m;
}

int mesh_quads_init(struct mesh_quads *qs, const struct relief_mesh_quad *tri_quads, uint64_t n)
{
	*qs = (struct mesh_quads){ 0 };
	if (n == 0)
		return 0;
	if (!(qs->q = malloc(sizeof(*qs->q) * n)))
		return -ENOMEM;
	/* A quad's triangles mostly come one after another: their copies are left out before the
	 * sort, so that it sees about one record a quad, not one a triangle; after it, every
	 * copy is adjacent. */
	uint64_t m = drop_adjacent_copies(qs->q, tri_quads, n);
	qsort(qs->q, m, sizeof(*qs->q), quad_cmp);
	qs->n = drop_adjacent_copies(qs->q, qs->q, m);
	return 0;
}

void mesh_quads_finish(struct mesh_quads *qs)
{
	if (!qs)
		return;
	free(qs->q);
	*qs = (struct mesh_quads){ 0 };
}

static void trace_factors(FILE *f, const struct relief_mesh_quad *q)
{
	if (q)
		fprintf(f, "%u %u %u %u / %u", q->outer[0], q->outer[1], q->outer[2], q->outer[3], q->inner);
	else
		fprintf(f, "-");
}

static void trace_place(FILE *f, const struct relief_mesh_quad *a, const struct relief_mesh_quad *b)
{
	const struct relief_mesh_quad *p = a ? a : b;
	fprintf(f, "  quad at column %lld row %lld, %u cells: ", (long long)p->col, (long long)p->row, p->cells);
	trace_factors(f, a);
	fprintf(f, " -> ");
	trace_factors(f, b);
	fprintf(f, " (outer west north east south / inner)\n");
}

void mesh_quads_compare(const struct mesh_quads *a, const struct mesh_quads *b, FILE *trace,
                        struct mesh_quad_changes *out)
{
	uint64_t i = 0, j = 0;
	/* A place has one quad per mesh: a capture draws each block once per frame. */
	while (i < a->n || j < b->n) {
		const int c = i == a->n ? 1 : j == b->n ? -1 : place_cmp(&a->q[i], &b->q[j]);
		if (c != 0) {
			out->coarse++;
			if (trace)
				trace_place(trace, c < 0 ? &a->q[i] : NULL, c < 0 ? NULL : &b->q[j]);
			if (c < 0)
				i++;
			else
				j++;
			continue;
		}
		if (factors_cmp(&a->q[i], &b->q[j]) != 0) {
			if (a->q[i].inner != b->q[j].inner)
				out->interiors++;
			else
				out->edges++;
			if (trace)
				trace_place(trace, &a->q[i], &b->q[j]);
		}
		i++;
		j++;
	}
}
