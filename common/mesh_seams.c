/* Whether a captured mesh is watertight (see mesh_seams.h). */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "mesh_seams.h"

/* The corners drawn, by position: an open-addressing table (linear probing, load at most
 * one half) of the first height drawn at each, and whether another was drawn there too. */
struct corner {
	int64_t col, row;
	float height;
	bool used, split;
};

struct corners {
	struct corner *slot;
	size_t mask, count;
};

static size_t corner_hash(int64_t col, int64_t row)
{
	uint64_t h = (uint64_t)col * 0x9e3779b97f4a7c15u ^ (uint64_t)row * 0xc2b2ae3d27d4eb4fu;
	return (size_t)(h ^ h >> 29);
}

static struct corner *corner_find(const struct corners *c, int64_t col, int64_t row)
{
	for (size_t i = corner_hash(col, row) & c->mask;; i = (i + 1) & c->mask) {
		struct corner *s = &c->slot[i];
		if (!s->used || (s->col == col && s->row == row))
			return s;
	}
}

static int corners_grow(struct corners *c)
{
	struct corners g = { calloc(2 * (c->mask + 1), sizeof(*g.slot)), 2 * (c->mask + 1) - 1, c->count };
	if (!g.slot)
		return -ENOMEM;
	for (size_t i = 0; i <= c->mask; i++)
		if (c->slot[i].used)
			*corner_find(&g, c->slot[i].col, c->slot[i].row) = c->slot[i];
	free(c->slot);
	*c = g;
	return 0;
}

static bool same_bits(float a, float b)
{
	return memcmp(&a, &b, sizeof(a)) == 0;
}

/* A triangle of no area in the plane: a curtain's, which hangs straight down. */
static bool vertical(const struct relief_mesh_vertex *t)
{
	return (t[1].col - t[0].col) * (t[2].row - t[0].row) - (t[2].col - t[0].col) * (t[1].row - t[0].row) == 0;
}

static void corner_add(struct corners *c, const struct relief_mesh_vertex *v, struct relief_mesh_seams *out)
{
	struct corner *s = corner_find(c, v->col, v->row);
	if (!s->used) {
		*s = (struct corner){ v->col, v->row, v->height, true, false };
		c->count++;
	} else if (!s->split && !same_bits(s->height, v->height)) {
		s->split = true;
		if (out->split++ == 0)
			out->split_at = *v;
	}
}

/* The corners strictly inside edge a-b, if it runs along a row or column. */
static void edge_check(const struct corners *c, const struct relief_mesh_vertex *a, const struct relief_mesh_vertex *b,
                       double tol_m, struct relief_mesh_seams *out)
{
	if (a->col != b->col && a->row != b->row)
		return;
	const int64_t dc = b->col > a->col ? 1 : b->col < a->col ? -1 : 0;
	const int64_t dr = b->row > a->row ? 1 : b->row < a->row ? -1 : 0;
	const int64_t len = dc ? llabs(b->col - a->col) : llabs(b->row - a->row);
	for (int64_t k = 1; k < len; k++) {
		const struct corner *s = corner_find(c, a->col + k * dc, a->row + k * dr);
		if (!s->used)
			continue;
		const double t = (double)k / (double)len, h = a->height + t * ((double)b->height - a->height);
		const double gap = fabs(s->height - h);
		out->junctions++;
		out->open += gap > tol_m;
		if (gap > out->max_gap_m) {
			out->max_gap_m = gap;
			out->worst = (struct relief_mesh_vertex){ s->col, s->row, s->height, 0 };
			out->worst_edge[0] = *a;
			out->worst_edge[1] = *b;
		}
	}
}

int relief_mesh_seams(const struct relief_mesh_vertex *tri, uint64_t n, double tol_m, struct relief_mesh_seams *out)
{
	memset(out, 0, sizeof(*out));
	struct corners c = { calloc(1024, sizeof(*c.slot)), 1023, 0 };
	if (!c.slot)
		return -ENOMEM;
	for (uint64_t i = 0; i < n; i++) {
		const struct relief_mesh_vertex *t = tri + 3 * i;
		if (vertical(t))
			continue;
		for (int k = 0; k < 3; k++) {
			if (2 * (c.count + 1) > c.mask + 1 && corners_grow(&c) < 0) {
				free(c.slot);
				return -ENOMEM;
			}
			corner_add(&c, &t[k], out);
		}
	}
	for (uint64_t i = 0; i < n; i++) {
		const struct relief_mesh_vertex *t = tri + 3 * i;
		if (vertical(t))
			continue;
		for (int k = 0; k < 3; k++)
			edge_check(&c, &t[k], &t[(k + 1) % 3], tol_m, out);
	}
	out->positions = c.count;
	free(c.slot);
	return 0;
}
