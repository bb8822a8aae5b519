/* The patch codec's prediction side (codec.h): geometry, refined values, the integer
 * bilinear prediction of children and the MED prediction of the root, in analysis (packing)
 * and reconstruction (the CPU reference; shaders/patch_decode.comp does the same arithmetic).
 * The entropy coding of the labels and residuals is codec_entropy.c. */
#include <errno.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "codec.h"
#include "codec_plane.h"

/* The predictors shift negative sums: C leaves >> of negative values implementation-
 * defined, GLSL defines it as arithmetic. Refuse to build where C's is not. */
_Static_assert((-3 >> 1) == -2, "arithmetic right shift required");

int relief_patch_geom_init(struct relief_patch_geom *g, uint32_t P)
{
	if (P < 3 || P > RELIEF_PATCH_MAX || ((P - 1) & (P - 2)) != 0)
		return -EINVAL;
	g->P = P;
	g->E = P + 2;
	g->half = (P - 1) / 2;
	g->L = (P + 1) / 2;
	g->R = (P + 5) / 2;
	g->n_labels = g->L * g->L;
	g->n_residuals = g->E * g->E - g->n_labels;
	return 0;
}

/* Refined values over even local positions -2..P+1 (R x R): k * parent, plus the label
 * where the position is inside the patch. */
static void refined_values(const struct relief_patch_geom *g, uint32_t k, unsigned quadrant,
                           const int32_t *parent, const int8_t *labels, int32_t *R)
{
	uint32_t ox = (quadrant & 1) ? g->half : 0, oy = (quadrant & 2) ? g->half : 0;
	for (uint32_t ry = 0; ry < g->R; ry++) {
		/* child local e = 2r - 2 -> parent local o + r - 1 -> parent storage o + r */
		const int32_t *prow = parent + (size_t)(oy + ry) * g->E + ox;
		int32_t *row = R + (size_t)ry * g->R;
		for (uint32_t rx = 0; rx < g->R; rx++)
			row[rx] = (int32_t)k * prow[rx];
		if (labels && ry >= 1 && ry <= g->L) {
			const int8_t *lrow = labels + (size_t)(ry - 1) * g->L;
			for (uint32_t i = 0; i < g->L; i++)
				row[i + 1] += lrow[i];
		}
	}
}

/* Where plane p's samples and their predictions are: in a block (E x E, storage index of
 * local (x, y) is (y + 1) E + x + 1) its sample (u, v) sits at out0 + 2 v E + 2 u, and its
 * prediction is the rounded mean of `taps` refined values from r = R + r0 + v Rw + u (the
 * refined index of local even e is (e + 2) / 2): r[0] and r[t1] (2 taps), or r[0], r[1],
 * r[Rw], r[Rw + 1] (4 taps). Plane layouts as in planes(). */
struct plane_taps {
	size_t r0, out0, t1;
	uint32_t taps;
};

static struct plane_taps plane_taps(const struct relief_patch_geom *g, int p)
{
	const size_t E = g->E, Rw = g->R;
	if (p == 0) /* H: x = 2u - 1, y = 2v; between refined (u, v + 1) and (u + 1, v + 1) */
		return (struct plane_taps){ Rw, E, 1, 2 };
	if (p == 1) /* V: x = 2u, y = 2v - 1; between refined (u + 1, v) and (u + 1, v + 1) */
		return (struct plane_taps){ 1, 1, Rw, 2 };
	/* C: x = 2u - 1, y = 2v - 1; the four refined values (u, v)..(u + 1, v + 1) */
	return (struct plane_taps){ 0, 0, 0, 4 };
}

/* The one rounding rule of the bilinear prediction (the GPU decoder's too). */
static inline int32_t plane_predict(const int32_t *r, const struct plane_taps *t, size_t Rw)
{
	return t->taps == 2 ? (r[0] + r[t->t1] + 1) >> 1 : (r[0] + r[1] + r[Rw] + r[Rw + 1] + 2) >> 2;
}

static int32_t *refined_scratch(const struct relief_patch_geom *g)
{
	return malloc(sizeof(int32_t) * g->R * g->R);
}

int relief_patch_analyse(const struct relief_patch_geom *g, uint32_t ratio, unsigned quadrant,
                         const int32_t *parent, const int32_t *child, int8_t *labels, int32_t *residuals)
{
	int32_t *R = refined_scratch(g);
	if (!R)
		return -ENOMEM;
	uint32_t ox = (quadrant & 1) ? g->half : 0, oy = (quadrant & 2) ? g->half : 0;
	int ret = 0;
	for (uint32_t j = 0; j < g->L && ret == 0; j++)
		for (uint32_t i = 0; i < g->L; i++) {
			int32_t qp = parent[(size_t)(oy + j + 1) * g->E + ox + i + 1];
			int32_t r = child[(size_t)(2 * j + 1) * g->E + 2 * i + 1] - (int32_t)ratio * qp;
			if (r < -1 || r > 1) {
				ret = -ERANGE;
				break;
			}
			labels[j * g->L + i] = (int8_t)r;
		}
	if (ret == 0) {
		refined_values(g, ratio, quadrant, parent, labels, R);
		struct plane pl[3];
		planes(g, pl);
		const size_t Rw = g->R;
		size_t n = 0;
		for (int p = 0; p < 3; p++) {
			struct plane_taps t = plane_taps(g, p);
			for (uint32_t v = 0; v < pl[p].h; v++)
				for (uint32_t u = 0; u < pl[p].w; u++)
					residuals[n++] = child[t.out0 + 2 * (size_t)v * g->E + 2 * (size_t)u] -
					                 plane_predict(R + t.r0 + v * Rw + u, &t, Rw);
		}
	}
	free(R);
	return ret;
}

static inline bool q_ok(int32_t v)
{
	return v >= -RELIEF_Q_MAX && v <= RELIEF_Q_MAX;
}

/* q_ok() of n values, in four independent lanes that compilers vectorise at -O2 (the
 * plain loop was 3 % of a decode). */
static bool all_q_ok(const int32_t *v, size_t n)
{
	int32_t bad[4] = { 0, 0, 0, 0 };
	size_t i = 0;
	for (; i + 4 <= n; i += 4)
		for (int k = 0; k < 4; k++)
			bad[k] |= (v[i + k] < -RELIEF_Q_MAX) | (v[i + k] > RELIEF_Q_MAX);
	for (; i < n; i++)
		bad[0] |= !q_ok(v[i]);
	return !(bad[0] | bad[1] | bad[2] | bad[3]);
}

/* One residual plane: q = prediction + d over its w x h samples, one branch-free loop per
 * row (a generic per-sample form, branching on parity, cost 17 % of a Puget Sound decode).
 * Errors (a residual outside (-2^29, 2^29) or a value outside [-RELIEF_Q_MAX,
 * RELIEF_Q_MAX]) are collected, not branched on; the sum is done in 64 bits so that hostile
 * residuals cannot overflow (the parent is checked, so the prediction cannot). */
static bool reconstruct_plane(const struct relief_patch_geom *g, const int32_t *R, const int32_t *d, int32_t *out,
                              const struct plane *pl, const struct plane_taps *t)
{
	const size_t Rw = g->R;
	bool bad = false;
	R += t->r0;
	out += t->out0;
	for (uint32_t v = 0; v < pl->h; v++, d += pl->w, R += Rw, out += 2 * (size_t)g->E) {
		for (uint32_t u = 0; u < pl->w; u++) {
			int64_t q = (int64_t)plane_predict(R + u, t, Rw) + d[u];
			bad |= (d[u] <= -(1 << 29)) | (d[u] >= (1 << 29)) | (q < -RELIEF_Q_MAX) | (q > RELIEF_Q_MAX);
			out[2 * (size_t)u] = (int32_t)q;
		}
	}
	return bad;
}

int relief_patch_reconstruct(const struct relief_patch_geom *g, uint32_t ratio, unsigned quadrant,
                             const int32_t *parent, const int8_t *labels, const int32_t *residuals,
                             int32_t *out)
{
	/* Parent values are checked too: the caller may hand in any buffer. */
	if (!all_q_ok(parent, (size_t)g->E * g->E))
		return -EBADMSG;
	bool bad = false;
	int32_t *R = refined_scratch(g);
	if (!R)
		return -ENOMEM;
	refined_values(g, ratio, quadrant, parent, labels, R);
	const size_t E = g->E, Rw = g->R;
	for (uint32_t j = 0; j < g->L; j++)
		for (uint32_t i = 0; i < g->L; i++) {
			int32_t v = R[(j + 1) * Rw + i + 1];
			bad |= !q_ok(v);
			out[(2 * j + 1) * E + 2 * i + 1] = v;
		}
	struct plane pl[3];
	planes(g, pl);
	const int32_t *d = residuals;
	for (int p = 0; p < 3; p++) {
		struct plane_taps t = plane_taps(g, p);
		bad |= reconstruct_plane(g, R, d, out, &pl[p], &t);
		d += (size_t)pl[p].w * pl[p].h;
	}
	free(R);
	return bad ? -EBADMSG : 0;
}

static inline int32_t med(int32_t a, int32_t b, int32_t c)
{
	int32_t mx = a > b ? a : b, mn = a < b ? a : b;
	if (c >= mx)
		return mn;
	if (c <= mn)
		return mx;
	return a + b - c;
}

int32_t relief_root_predict(const int32_t *q, uint32_t E, uint32_t x, uint32_t y)
{
	if (y == 0)
		return x ? q[x - 1] : 0;
	if (x == 0)
		return q[(y - 1) * E];
	return med(q[y * E + x - 1], q[(y - 1) * E + x], q[(y - 1) * E + x - 1]);
}

void relief_root_analyse(const struct relief_patch_geom *g, const int32_t *q, int32_t *residuals)
{
	for (uint32_t y = 0; y < g->E; y++)
		for (uint32_t x = 0; x < g->E; x++)
			residuals[y * g->E + x] = q[y * g->E + x] - relief_root_predict(q, g->E, x, y);
}

int relief_root_reconstruct(const struct relief_patch_geom *g, const int32_t *residuals, int32_t *out)
{
	for (uint32_t y = 0; y < g->E; y++)
		for (uint32_t x = 0; x < g->E; x++) {
			int32_t d = residuals[y * g->E + x];
			if (d <= -(1 << 29) || d >= (1 << 29))
				return -EBADMSG;
			int32_t v = relief_root_predict(out, g->E, x, y) + d;
			if (!q_ok(v))
				return -EBADMSG;
			out[y * g->E + x] = v;
		}
	return 0;
}
