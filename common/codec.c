#include <errno.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "codec.h"

/* The predictors shift negative sums: C leaves >> of negative values implementation-
 * defined, GLSL defines it as arithmetic. Refuse to build where C's is not. */
_Static_assert((-3 >> 1) == -2, "arithmetic right shift required");

int relief_patch_geom_init(struct relief_patch_geom *g, uint32_t P)
{
	if (P < 3 || P > 4097 || ((P - 1) & (P - 2)) != 0)
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

/* Residual planes, in stream order: H (y even inside, x odd incl. ring), V (y odd incl.
 * ring, x even inside), C (x and y odd incl. ring). Dimensions w x h each. */
struct plane {
	uint32_t w, h;
	int x0, y0; /* local coordinates of the plane's first sample; step 2 */
};

static void planes(const struct relief_patch_geom *g, struct plane p[3])
{
	uint32_t odd = (g->P + 3) / 2; /* odd local indices in [-1, P] */
	uint32_t even = g->L;          /* even local indices in [0, P-1] */
	p[0] = (struct plane){ odd, even, -1, 0 };
	p[1] = (struct plane){ even, odd, 0, -1 };
	p[2] = (struct plane){ odd, odd, -1, -1 };
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
		bool yin = ry >= 1 && ry <= g->L;
		for (uint32_t rx = 0; rx < g->R; rx++) {
			int32_t v = (int32_t)k * prow[rx];
			if (labels && yin && rx >= 1 && rx <= g->L)
				v += labels[(ry - 1) * g->L + (rx - 1)];
			R[ry * g->R + rx] = v;
		}
	}
}

/* Prediction of the sample at local (x, y) (not refined) from the refined values. */
static inline int32_t predict(const struct relief_patch_geom *g, const int32_t *R, int x, int y)
{
	/* Refined index of local even e is (e + 2) / 2. */
	if ((y & 1) == 0) { /* H: between (x-1, y) and (x+1, y) */
		const int32_t *r = R + (size_t)((y + 2) / 2) * g->R + (x + 1) / 2;
		return (r[0] + r[1] + 1) >> 1;
	}
	if ((x & 1) == 0) { /* V: between (x, y-1) and (x, y+1) */
		const int32_t *r = R + (size_t)((y + 1) / 2) * g->R + (x + 2) / 2;
		return (r[0] + r[g->R] + 1) >> 1;
	}
	const int32_t *r = R + (size_t)((y + 1) / 2) * g->R + (x + 1) / 2; /* C */
	return (r[0] + r[1] + r[g->R] + r[g->R + 1] + 2) >> 2;
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
		size_t n = 0;
		for (int p = 0; p < 3; p++)
			for (uint32_t v = 0; v < pl[p].h; v++)
				for (uint32_t u = 0; u < pl[p].w; u++) {
					int x = pl[p].x0 + 2 * (int)u, y = pl[p].y0 + 2 * (int)v;
					residuals[n++] = child[(size_t)(y + 1) * g->E + x + 1] - predict(g, R, x, y);
				}
	}
	free(R);
	return ret;
}

static inline bool q_ok(int32_t v)
{
	return v >= -RELIEF_Q_MAX && v <= RELIEF_Q_MAX;
}

int relief_patch_reconstruct(const struct relief_patch_geom *g, uint32_t ratio, unsigned quadrant,
                             const int32_t *parent, const int8_t *labels, const int32_t *residuals,
                             int32_t *out)
{
	/* Parent values are checked too: the caller may hand in any buffer. */
	for (size_t i = 0; i < (size_t)g->E * g->E; i++)
		if (!q_ok(parent[i]))
			return -EBADMSG;
	int32_t *R = refined_scratch(g);
	if (!R)
		return -ENOMEM;
	refined_values(g, ratio, quadrant, parent, labels, R);
	int ret = 0;
	for (uint32_t j = 0; j < g->L; j++)
		for (uint32_t i = 0; i < g->L; i++) {
			int32_t v = R[(j + 1) * g->R + i + 1];
			ret |= !q_ok(v);
			out[(size_t)(2 * j + 1) * g->E + 2 * i + 1] = v;
		}
	struct plane pl[3];
	planes(g, pl);
	size_t n = 0;
	for (int p = 0; p < 3; p++)
		for (uint32_t v = 0; v < pl[p].h; v++)
			for (uint32_t u = 0; u < pl[p].w; u++) {
				int x = pl[p].x0 + 2 * (int)u, y = pl[p].y0 + 2 * (int)v;
				int32_t d = residuals[n++];
				if (d <= -(1 << 29) || d >= (1 << 29)) {
					ret = 1;
					continue;
				}
				int32_t q = predict(g, R, x, y) + d;
				ret |= !q_ok(q);
				out[(size_t)(y + 1) * g->E + x + 1] = q;
			}
	free(R);
	return ret ? -EBADMSG : 0;
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

static inline int32_t root_predict(const int32_t *q, uint32_t E, uint32_t x, uint32_t y)
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
			residuals[y * g->E + x] = q[y * g->E + x] - root_predict(q, g->E, x, y);
}

int relief_root_reconstruct(const struct relief_patch_geom *g, const int32_t *residuals, int32_t *out)
{
	for (uint32_t y = 0; y < g->E; y++)
		for (uint32_t x = 0; x < g->E; x++) {
			int32_t d = residuals[y * g->E + x];
			if (d <= -(1 << 29) || d >= (1 << 29))
				return -EBADMSG;
			int32_t v = root_predict(out, g->E, x, y) + d;
			if (!q_ok(v))
				return -EBADMSG;
			out[y * g->E + x] = v;
		}
	return 0;
}

/* ---- entropy models ---- */

#define ACTIVITY_CONTEXTS 7
#define MAX_EXP 28 /* magnitudes below 2^29 */

struct residual_models {
	rc_prob zero[ACTIVITY_CONTEXTS];
	rc_prob sign[ACTIVITY_CONTEXTS];
	rc_prob exp[ACTIVITY_CONTEXTS][MAX_EXP + 1];
	rc_prob mant[ACTIVITY_CONTEXTS][MAX_EXP + 1];
};

struct label_models {
	rc_prob nonzero[3];
	rc_prob sign[3];
};

static void models_init(rc_prob *p, size_t n)
{
	for (size_t i = 0; i < n; i++)
		p[i] = RC_PROB_INIT;
}

/* Local activity from the left and upper neighbours' magnitudes in the same plane. */
static inline unsigned activity(uint32_t s)
{
	if (s < 3)
		return s;
	if (s <= 4)
		return 3;
	if (s <= 8)
		return 4;
	if (s <= 16)
		return 5;
	return 6;
}

static inline uint32_t mag(int32_t v)
{
	return v < 0 ? (uint32_t)(-(int64_t)v) : (uint32_t)v;
}

static inline unsigned plane_context(const int32_t *v, uint32_t w, uint32_t u, uint32_t row)
{
	uint32_t s = 0;
	if (u)
		s += mag(v[row * w + u - 1]);
	if (row)
		s += mag(v[(row - 1) * w + u]);
	return activity(s > 1000000 ? 1000000 : s);
}

static void encode_residual(struct rc_encoder *e, struct residual_models *m, unsigned c, int32_t d)
{
	rc_encode_bit(e, &m->zero[c], d != 0);
	if (!d)
		return;
	rc_encode_bit(e, &m->sign[c], d < 0);
	uint32_t v = mag(d); /* >= 1; code v with an adaptive Elias-gamma-like code */
	unsigned k = 31 - (unsigned)__builtin_clz(v); /* v in [2^k, 2^(k+1)) */
	for (unsigned i = 0; i < k; i++)
		rc_encode_bit(e, &m->exp[c][i], 1);
	if (k < MAX_EXP)
		rc_encode_bit(e, &m->exp[c][k], 0);
	if (k == 0)
		return;
	rc_encode_bit(e, &m->mant[c][k], (v >> (k - 1)) & 1);
	if (k > 1)
		rc_encode_direct(e, v & ((1u << (k - 1)) - 1), k - 1);
}

static int32_t decode_residual(struct rc_decoder *d, struct residual_models *m, unsigned c)
{
	if (!rc_decode_bit(d, &m->zero[c]))
		return 0;
	unsigned neg = rc_decode_bit(d, &m->sign[c]);
	unsigned k = 0;
	while (k < MAX_EXP && rc_decode_bit(d, &m->exp[c][k]))
		k++;
	uint32_t v = 1u << k;
	if (k > 0) {
		v |= rc_decode_bit(d, &m->mant[c][k]) << (k - 1);
		if (k > 1)
			v |= rc_decode_direct(d, k - 1);
	}
	return neg ? -(int32_t)v : (int32_t)v;
}

static void encode_plane(struct rc_encoder *e, struct residual_models *m, const int32_t *v, uint32_t w, uint32_t h)
{
	for (uint32_t row = 0; row < h; row++)
		for (uint32_t u = 0; u < w; u++)
			encode_residual(e, m, plane_context(v, w, u, row), v[row * w + u]);
}

static void decode_plane(struct rc_decoder *d, struct residual_models *m, int32_t *v, uint32_t w, uint32_t h)
{
	for (uint32_t row = 0; row < h; row++)
		for (uint32_t u = 0; u < w; u++)
			v[row * w + u] = decode_residual(d, m, plane_context(v, w, u, row));
}

static inline unsigned label_context(const int8_t *l, uint32_t L, uint32_t i, uint32_t j)
{
	return (i && l[j * L + i - 1] != 0) + (j && l[(j - 1) * L + i] != 0);
}

int relief_patch_encode(const struct relief_patch_geom *g, bool root, const int8_t *labels,
                        const int32_t *residuals, uint8_t **out, size_t *out_size)
{
	struct rc_encoder e;
	rc_encoder_init(&e);
	struct residual_models *m = malloc(sizeof(*m) * 3);
	if (!m)
		return -ENOMEM;
	models_init((rc_prob *)m, sizeof(*m) * 3 / sizeof(rc_prob));
	if (root) {
		encode_plane(&e, &m[0], residuals, g->E, g->E);
	} else {
		struct label_models lm;
		models_init((rc_prob *)&lm, sizeof(lm) / sizeof(rc_prob));
		for (uint32_t j = 0; j < g->L; j++)
			for (uint32_t i = 0; i < g->L; i++) {
				int8_t r = labels[j * g->L + i];
				unsigned c = label_context(labels, g->L, i, j);
				rc_encode_bit(&e, &lm.nonzero[c], r != 0);
				if (r)
					rc_encode_bit(&e, &lm.sign[c], r < 0);
			}
		struct plane pl[3];
		planes(g, pl);
		const int32_t *v = residuals;
		for (int p = 0; p < 3; p++) {
			encode_plane(&e, &m[p], v, pl[p].w, pl[p].h);
			v += (size_t)pl[p].w * pl[p].h;
		}
	}
	free(m);
	int ret = rc_encoder_flush(&e);
	if (ret < 0) {
		rc_encoder_finish(&e);
		return ret;
	}
	*out = e.buf;
	*out_size = e.size;
	return 0;
}

int relief_patch_decode_symbols(const struct relief_patch_geom *g, bool root, const uint8_t *buf, size_t size,
                                int8_t *labels, int32_t *residuals)
{
	struct rc_decoder d;
	rc_decoder_init(&d, buf, size);
	struct residual_models *m = malloc(sizeof(*m) * 3);
	if (!m)
		return -ENOMEM;
	models_init((rc_prob *)m, sizeof(*m) * 3 / sizeof(rc_prob));
	if (root) {
		decode_plane(&d, &m[0], residuals, g->E, g->E);
	} else {
		struct label_models lm;
		models_init((rc_prob *)&lm, sizeof(lm) / sizeof(rc_prob));
		for (uint32_t j = 0; j < g->L; j++)
			for (uint32_t i = 0; i < g->L; i++) {
				unsigned c = label_context(labels, g->L, i, j);
				int8_t r = 0;
				if (rc_decode_bit(&d, &lm.nonzero[c]))
					r = rc_decode_bit(&d, &lm.sign[c]) ? -1 : 1;
				labels[j * g->L + i] = r;
			}
		struct plane pl[3];
		planes(g, pl);
		int32_t *v = residuals;
		for (int p = 0; p < 3; p++) {
			decode_plane(&d, &m[p], v, pl[p].w, pl[p].h);
			v += (size_t)pl[p].w * pl[p].h;
		}
	}
	free(m);
	return d.overrun ? -EBADMSG : 0;
}
