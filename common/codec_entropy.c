/* Entropy coding of patch streams: labels and residual planes through rANS with adaptive
 * models (the layout below), the version 3 windows that leave out padding, and the
 * validity masks through the binary range coder. The prediction side is codec.c. */
#include <errno.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "codec.h"
#include "codec_plane.h"
#include "rans.h"

void relief_window_full(const struct relief_patch_geom *g, struct relief_window *w)
{
	*w = (struct relief_window){ -1, -1, (int32_t)g->P + 1, (int32_t)g->P + 1, false, false };
}

/* The indices [a, b) of a plane's or the labels' samples along one axis (local positions
 * origin + 2i, i < n) that fall inside [lo, hi). */
struct span {
	uint32_t a, b;
};

static uint32_t span_bound(int64_t lim, int origin, uint32_t n)
{
	int64_t t = lim - origin; /* first index at or beyond lim: ceil(t / 2) */
	int64_t i = t <= 0 ? 0 : (t + 1) / 2;
	return i > (int64_t)n ? n : (uint32_t)i;
}

static struct span span_of(int32_t lo, int32_t hi, int origin, uint32_t n)
{
	struct span s = { span_bound(lo, origin, n), span_bound(hi, origin, n) };
	if (s.b < s.a)
		s.b = s.a;
	return s;
}

/* What a window covers of one w x h array (a residual plane, or the labels): the rectangle
 * su x sv, then, coded after it, the rest of row 0 (tail_row: the window's ring_north,
 * for a plane whose row 0 is local y = -1) and the rest of column 0 (tail_col). */
struct cover {
	struct span su, sv;
	bool tail_row, tail_col;
};

static struct cover cover_of(const struct relief_window *win, int x0, int y0, uint32_t w, uint32_t h)
{
	struct cover c = { span_of(win->x0, win->x1, x0, w), span_of(win->y0, win->y1, y0, h), false, false };
	c.tail_row = win->ring_north && y0 == -1 && c.sv.a == 0 && c.sv.b > 0 && c.su.b < w;
	c.tail_col = win->ring_west && x0 == -1 && c.su.a == 0 && c.su.b > 0 && c.sv.b < h;
	return c;
}

/* The root codes its E x E values in raster order (storage index = local + 1), step 1. */
static struct cover root_cover(const struct relief_window *win, uint32_t E)
{
	struct cover c = { { 0, E }, { 0, E }, false, false };
	if (win) {
		int32_t lo[2] = { win->x0, win->y0 }, hi[2] = { win->x1, win->y1 };
		struct span *sp[2] = { &c.su, &c.sv };
		for (int a = 0; a < 2; a++) {
			int64_t l = (int64_t)lo[a] + 1, h = (int64_t)hi[a] + 1;
			sp[a]->a = l <= 0 ? 0 : l >= E ? E : (uint32_t)l;
			sp[a]->b = h <= sp[a]->a ? sp[a]->a : h >= E ? E : (uint32_t)h;
		}
	}
	return c;
}

static bool cover_full(const struct cover *c, uint32_t w, uint32_t h)
{
	return c->su.a == 0 && c->su.b == w && c->sv.a == 0 && c->sv.b == h;
}

static bool covered(const struct cover *c, uint32_t u, uint32_t r)
{
	return (u >= c->su.a && u < c->su.b && r >= c->sv.a && r < c->sv.b) ||
	       (c->tail_row && r == 0 && u >= c->su.b) || (c->tail_col && u == 0 && r >= c->sv.b);
}

/* True when every value (elem bytes each) of the w x h array outside the cover is 0. */
static bool outside_zero(const void *v, size_t elem, uint32_t w, uint32_t h, const struct cover *c)
{
	const uint8_t *b = v;
	for (uint32_t r = 0; r < h; r++)
		for (uint32_t u = 0; u < w; u++)
			if (!covered(c, u, r))
				for (size_t k = 0; k < elem; k++)
					if (b[((size_t)r * w + u) * elem + k])
						return false;
	return true;
}

/* ---- entropy coding ----
 *
 * A residual d is one symbol of an adaptive 16-symbol model chosen by local activity,
 * plus raw bits:
 *   symbol 0: d = 0; symbols 2k+1 / 2k+2 (k = 0..6): d > 0 / d < 0 with |d| - 1 in
 *   [2^(k-1), 2^k) (k = 0: |d| = 1), followed by k - 1 raw bits of |d| - 1 below its top
 *   bit; symbol 15: escape for |d| > 64: raw sign bit, the exponent k <= 28 of |d| - 64 as
 *   a symbol of the plane's escape model (15: k >= 15, then 5 raw bits of k), then the k
 *   low bits of |d| - 64 (whose top bit is implied).
 * Labels r = 0, +1, -1 are symbols 0, 1, 2 of such a model (the other symbols keep the
 * minimum frequency); context = number of non-zero left and upper labels.
 * Symbols go through rANS (rans.h) in two streams: row r of every plane and of the labels
 * goes to stream r & 1, each stream with its own models, and the decoder runs both in
 * lockstep (row 2j at column u, then row 2j+1 at column u), so that two serial chains
 * overlap on the CPU. Every context is available in that order: (r, u-1) is in the same
 * stream, (r-1, u) was decoded one step earlier. Raw bits share one bit stream in the same
 * order. Patch stream layout: u32 LE byte sizes of rANS stream 0, rANS stream 1 and the
 * raw bits, then the three. */

#define ACTIVITY_CONTEXTS 7
#define MAX_EXP 28
#define ESCAPE_SYMBOL 15
#define ESCAPE_BASE 65

struct stream_models {
	struct rc_cdf16 labels[3];
	struct rc_cdf16 res[3][ACTIVITY_CONTEXTS]; /* per plane, per activity */
	struct rc_cdf16 esc[3];                    /* escape exponents, per plane */
};

static void stream_models_init(struct stream_models *m)
{
	for (int c = 0; c < 3; c++)
		rc_cdf16_init(&m->labels[c]);
	for (int p = 0; p < 3; p++) {
		for (int c = 0; c < ACTIVITY_CONTEXTS; c++)
			rc_cdf16_init(&m->res[p][c]);
		rc_cdf16_init(&m->esc[p]);
	}
}

static inline uint32_t mag(int32_t v)
{
	return v < 0 ? (uint32_t)(-(int64_t)v) : (uint32_t)v;
}

/* Magnitude class of a residual: 0 for 0, k + 1 for |d| - 1 in [2^(k-1), 2^k) (k = 0:
 * |d| = 1), 8 above 64. It is what a residual's symbol says without its raw bits (the
 * class of symbol s is (s + 1) / 2), so a decoder knows a context before it reads them. */
static inline unsigned class_of(int32_t d)
{
	uint32_t a = mag(d) - 1;
	return d == 0 ? 0 : a >= ESCAPE_BASE - 1 ? 8 : a ? 33 - (unsigned)__builtin_clz(a) : 1;
}

#define CLASSES 9

/* Local activity from the left and upper neighbours' classes in the same plane (a missing
 * neighbour counts as class 0): the bucket (0, 1, 2, 3-4, 5-8, 9-16, 17+) of the sum of
 * the two classes' smallest magnitudes (0, 1, 2, 3, 5, 9, 17, 33, 65). A table, so that
 * no branch depends on the data. */
static const uint8_t class_activity[CLASSES][CLASSES] = {
	{ 0, 1, 2, 3, 4, 5, 6, 6, 6 }, { 1, 2, 3, 3, 4, 5, 6, 6, 6 }, { 2, 3, 3, 4, 4, 5, 6, 6, 6 },
	{ 3, 3, 4, 4, 4, 5, 6, 6, 6 }, { 4, 4, 4, 4, 5, 5, 6, 6, 6 }, { 5, 5, 5, 5, 5, 6, 6, 6, 6 },
	{ 6, 6, 6, 6, 6, 6, 6, 6, 6 }, { 6, 6, 6, 6, 6, 6, 6, 6, 6 }, { 6, 6, 6, 6, 6, 6, 6, 6, 6 },
};

static inline unsigned plane_context(const int32_t *v, uint32_t w, uint32_t u, uint32_t row)
{
	return class_activity[u ? class_of(v[row * w + u - 1]) : 0][row ? class_of(v[(row - 1) * w + u]) : 0];
}

static inline unsigned label_context(const int8_t *l, uint32_t L, uint32_t i, uint32_t j)
{
	return (i && l[j * L + i - 1] != 0) + (j && l[(j - 1) * L + i] != 0);
}

/* Symbol -> magnitude base and raw bit count. */
static const uint8_t sym_bits[16] = { 0, 0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 0 };
static const uint8_t sym_base[16] = { 0, 1, 1, 2, 2, 3, 3, 5, 5, 9, 9, 17, 17, 33, 33, 0 };
static const uint8_t sym_negative[16] = { 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0 };

/* ---- encoder: models run forward in decoding order, rANS encodes afterwards ---- */

struct encoder {
	struct rans_record rec[2];
	struct bitwriter bits;
	struct stream_models m[2];
};

static void put_residual(struct encoder *e, int stream, int plane, unsigned c, int32_t d)
{
	uint32_t v = mag(d);
	unsigned s;
	if (v == 0) {
		s = 0;
	} else if (v < ESCAPE_BASE) {
		uint32_t a = v - 1;
		unsigned k = a ? 32 - (unsigned)__builtin_clz(a) : 0; /* a in [2^(k-1), 2^k) */
		s = 2 * k + 1 + (d < 0);
	} else {
		s = ESCAPE_SYMBOL;
	}
	rans_record_put(&e->rec[stream], &e->m[stream].res[plane][c], s);
	if (s != ESCAPE_SYMBOL) {
		bitwriter_put(&e->bits, v - sym_base[s], sym_bits[s]);
		return;
	}
	uint32_t x = v - ESCAPE_BASE + 1; /* >= 1, < 2^29 */
	unsigned k = 31 - (unsigned)__builtin_clz(x);
	bitwriter_put(&e->bits, d < 0, 1);
	rans_record_put(&e->rec[stream], &e->m[stream].esc[plane], k < 15 ? k : 15);
	if (k >= 15)
		bitwriter_put(&e->bits, k, 5);
	if (k > 16) {
		bitwriter_put(&e->bits, x >> 16 & ((1u << (k - 16)) - 1), k - 16);
		bitwriter_put(&e->bits, x & 0xffff, 16);
	} else {
		bitwriter_put(&e->bits, x & ((1u << k) - 1), k);
	}
}

/* Rows sv.a, sv.a + 2, ... of the cover's rectangle go to stream 0 and the rows after
 * them to stream 1, then its tails to stream 0. Values outside the cover are 0, so
 * plane_context() sees what the decoder sees. */
static void put_plane(struct encoder *e, int p, const int32_t *v, uint32_t w, uint32_t h, const struct cover *c)
{
	struct span su = c->su, sv = c->sv;
	uint32_t row = sv.a;
	for (; row + 1 < sv.b; row += 2)
		for (uint32_t u = su.a; u < su.b; u++) {
			put_residual(e, 0, p, plane_context(v, w, u, row), v[row * w + u]);
			put_residual(e, 1, p, plane_context(v, w, u, row + 1), v[(row + 1) * w + u]);
		}
	if (row < sv.b)
		for (uint32_t u = su.a; u < su.b; u++)
			put_residual(e, 0, p, plane_context(v, w, u, row), v[row * w + u]);
	if (c->tail_row)
		for (uint32_t u = su.b; u < w; u++)
			put_residual(e, 0, p, plane_context(v, w, u, 0), v[u]);
	if (c->tail_col)
		for (uint32_t r = sv.b; r < h; r++)
			put_residual(e, 0, p, plane_context(v, w, 0, r), v[r * w]);
}

static inline unsigned label_symbol(int8_t r)
{
	return r == 0 ? 0 : r > 0 ? 1 : 2;
}

int relief_patch_encode(const struct relief_patch_geom *g, bool root, const struct relief_window *win,
                        const int8_t *labels, const int32_t *residuals, uint8_t **out, size_t *out_size)
{
	struct relief_window full;
	if (!win) {
		relief_window_full(g, &full);
		win = &full;
	}
	struct encoder *e = calloc(1, sizeof(*e));
	if (!e)
		return -ENOMEM;
	stream_models_init(&e->m[0]);
	stream_models_init(&e->m[1]);
	bool outside_ok = true;
	if (root) {
		struct cover rc = root_cover(win, g->E);
		outside_ok = outside_zero(residuals, sizeof(int32_t), g->E, g->E, &rc);
		put_plane(e, 0, residuals, g->E, g->E, &rc);
	} else {
		const uint32_t L = g->L;
		struct cover lc = cover_of(win, 0, 0, L, L);
		struct span si = lc.su, sj = lc.sv;
		outside_ok = outside_zero(labels, 1, L, L, &lc);
		uint32_t j = sj.a;
		for (; j + 1 < sj.b; j += 2)
			for (uint32_t i = si.a; i < si.b; i++) {
				rans_record_put(&e->rec[0], &e->m[0].labels[label_context(labels, L, i, j)],
				                label_symbol(labels[j * L + i]));
				rans_record_put(&e->rec[1], &e->m[1].labels[label_context(labels, L, i, j + 1)],
				                label_symbol(labels[(j + 1) * L + i]));
			}
		if (j < sj.b)
			for (uint32_t i = si.a; i < si.b; i++)
				rans_record_put(&e->rec[0], &e->m[0].labels[label_context(labels, L, i, j)],
				                label_symbol(labels[j * L + i]));
		struct plane pl[3];
		planes(g, pl);
		const int32_t *v = residuals;
		for (int p = 0; p < 3; p++) {
			struct cover c = cover_of(win, pl[p].x0, pl[p].y0, pl[p].w, pl[p].h);
			outside_ok &= outside_zero(v, sizeof(int32_t), pl[p].w, pl[p].h, &c);
			put_plane(e, p, v, pl[p].w, pl[p].h, &c);
			v += (size_t)pl[p].w * pl[p].h;
		}
	}
	if (!outside_ok) {
		free(e->rec[0].sym);
		free(e->rec[1].sym);
		free(e->bits.buf);
		free(e);
		return -EINVAL;
	}
	bitwriter_flush(&e->bits);
	uint8_t *s0 = NULL, *s1 = NULL, *buf = NULL;
	size_t n0 = 0, n1 = 0, nb = e->bits.size;
	int ret = e->bits.oom ? -ENOMEM : 0;
	if (ret == 0)
		ret = rans_encode(&e->rec[0], &s0, &n0);
	if (ret == 0)
		ret = rans_encode(&e->rec[1], &s1, &n1);
	if (ret == 0 && (n0 > UINT32_MAX || n1 > UINT32_MAX || nb > UINT32_MAX))
		ret = -EOVERFLOW;
	if (ret == 0 && !(buf = malloc(12 + n0 + n1 + nb)))
		ret = -ENOMEM;
	if (ret == 0) {
		const size_t sizes[3] = { n0, n1, nb };
		for (int i = 0; i < 3; i++)
			for (int b = 0; b < 4; b++)
				buf[4 * i + b] = (uint8_t)(sizes[i] >> (8 * b));
		memcpy(buf + 12, s0, n0);
		memcpy(buf + 12 + n0, s1, n1);
		if (nb)
			memcpy(buf + 12 + n0 + n1, e->bits.buf, nb);
		*out = buf;
		*out_size = 12 + n0 + n1 + nb;
	}
	free(s0);
	free(s1);
	free(e->rec[0].sym);
	free(e->rec[1].sym);
	free(e->bits.buf);
	free(e);
	return ret;
}

/* ---- decoder ---- */

struct decoder {
	struct rans_dec d[2];
	struct bitreader bits;
	bool corrupt;
};

/* One residual, and its class in *cls. */
__attribute__((always_inline)) static inline int32_t get_residual(struct decoder *dc, int stream,
                                                                    struct rc_cdf16 *m, struct rc_cdf16 *esc,
                                                                    unsigned *cls)
{
	unsigned s = rans_decode_sym16(&dc->d[stream], m);
	*cls = (s + 1) >> 1;
	if (__builtin_expect(s != ESCAPE_SYMBOL, 1)) {
		/* The sign is applied as (v ^ m) - m: a residual's sign is a coin toss, which a
		 * branch (what a conditional expression compiled to) mispredicts half the time. */
		int32_t v = (int32_t)(sym_base[s] + bitreader_get(&dc->bits, sym_bits[s]));
		int32_t neg = -(int32_t)sym_negative[s];
		return (v ^ neg) - neg;
	}
	unsigned neg = bitreader_get(&dc->bits, 1);
	unsigned k = rans_decode_sym16(&dc->d[stream], esc);
	if (k == 15)
		k = bitreader_get(&dc->bits, 5);
	if (k > MAX_EXP) {
		dc->corrupt = true;
		return 0;
	}
	uint32_t x;
	if (k > 16) {
		x = bitreader_get(&dc->bits, k - 16) << 16;
		x |= bitreader_get(&dc->bits, 16);
	} else {
		x = bitreader_get(&dc->bits, k);
	}
	int32_t v = (int32_t)(((1u << k) | x) - 1 + ESCAPE_BASE);
	return neg ? -v : v;
}

/* Contexts come from the classes the symbols give (class_of() of the values, which the
 * encoder uses), so the raw bits stay off the chain from one symbol to the next context. */
static void get_plane(struct decoder *dc, struct stream_models m[2], int p, int32_t *v, uint32_t w, uint32_t h,
                      const struct cover *c)
{
	uint8_t up[RELIEF_PATCH_MAX + 2]; /* classes of the row above: w <= P + 2 (the root's plane) */
	memset(up, 0, w);
	const struct span su = c->su, sv = c->sv;
	const bool full = cover_full(c, w, h);
	if (!full)
		memset(v, 0, sizeof(*v) * w * h);
	struct rc_cdf16 *res0 = m[0].res[p], *res1 = m[1].res[p];
	uint32_t row = sv.a;
	for (; row + 1 < sv.b; row += 2) {
		int32_t *a = v + row * w, *b = a + w;
		unsigned left_a = 0, left_b = 0, ca, cb;
		for (uint32_t u = su.a; u < su.b; u++) {
			a[u] = get_residual(dc, 0, &res0[class_activity[left_a][up[u]]], &m[0].esc[p], &ca);
			b[u] = get_residual(dc, 1, &res1[class_activity[left_b][ca]], &m[1].esc[p], &cb);
			up[u] = (uint8_t)cb;
			left_a = ca;
			left_b = cb;
		}
	}
	if (row < sv.b) {
		unsigned left = 0, cl;
		for (uint32_t u = su.a; u < su.b; u++) {
			v[row * w + u] = get_residual(dc, 0, &res0[class_activity[left][up[u]]], &m[0].esc[p], &cl);
			left = cl;
		}
	}
	if (full)
		return;
	/* The tails (put_plane()): rare and short, so contexts are recomputed from the values. */
	unsigned cls;
	if (c->tail_row)
		for (uint32_t u = su.b; u < w; u++)
			v[u] = get_residual(dc, 0, &res0[plane_context(v, w, u, 0)], &m[0].esc[p], &cls);
	if (c->tail_col)
		for (uint32_t r = sv.b; r < h; r++)
			v[r * w] = get_residual(dc, 0, &res0[plane_context(v, w, 0, r)], &m[0].esc[p], &cls);
}

static inline int8_t get_label(struct rans_dec *d, struct rc_cdf16 *m)
{
	static const int8_t value[16] = { 0, 1, -1 }; /* other symbols only in corrupt streams */
	return value[rans_decode_sym16(d, m)];
}

/* The labels in the encoder's order and contexts (label_context()), with the left and
 * just-decoded upper neighbours kept in registers rather than read back from memory. */
static void get_labels(struct decoder *dc, struct stream_models m[2], int8_t *labels, uint32_t L, struct span si,
                       struct span sj)
{
	if (si.a > 0 || si.b < L || sj.a > 0 || sj.b < L)
		memset(labels, 0, (size_t)L * L);
	for (uint32_t j = sj.a; j < sj.b; j += 2) {
		int8_t *a = labels + j * L, *b = a + L;
		const int8_t *up = j ? a - L : NULL;
		unsigned left_a = 0, left_b = 0;
		bool pair = j + 1 < sj.b;
		for (uint32_t i = si.a; i < si.b; i++) {
			unsigned ca = left_a + (up && up[i] != 0);
			int8_t la = get_label(&dc->d[0], &m[0].labels[ca]);
			a[i] = la;
			left_a = la != 0;
			if (pair) {
				int8_t lb = get_label(&dc->d[1], &m[1].labels[left_b + (la != 0)]);
				b[i] = lb;
				left_b = lb != 0;
			}
		}
	}
}

int relief_patch_decode_symbols(const struct relief_patch_geom *g, bool root, const struct relief_window *win,
                                const uint8_t *buf, size_t size, int8_t *labels, int32_t *residuals)
{
	struct relief_window full;
	if (!win) {
		relief_window_full(g, &full);
		win = &full;
	}
	if (size < 12)
		return -EBADMSG;
	uint64_t n[3];
	for (int i = 0; i < 3; i++)
		n[i] = (uint32_t)buf[4 * i] | (uint32_t)buf[4 * i + 1] << 8 | (uint32_t)buf[4 * i + 2] << 16 |
		       (uint32_t)buf[4 * i + 3] << 24;
	if (n[0] + n[1] + n[2] != size - 12)
		return -EBADMSG;
	struct decoder dc = { .corrupt = false };
	rans_dec_init(&dc.d[0], buf + 12, n[0]);
	rans_dec_init(&dc.d[1], buf + 12 + n[0], n[1]);
	bitreader_init(&dc.bits, buf + 12 + n[0] + n[1], n[2]);
	struct stream_models *m = malloc(sizeof(*m) * 2);
	if (!m)
		return -ENOMEM;
	stream_models_init(&m[0]);
	stream_models_init(&m[1]);
	if (root) {
		struct cover rc = root_cover(win, g->E);
		get_plane(&dc, m, 0, residuals, g->E, g->E, &rc);
	} else {
		struct cover lc = cover_of(win, 0, 0, g->L, g->L);
		get_labels(&dc, m, labels, g->L, lc.su, lc.sv);
		struct plane pl[3];
		planes(g, pl);
		int32_t *v = residuals;
		for (int p = 0; p < 3; p++) {
			struct cover c = cover_of(win, pl[p].x0, pl[p].y0, pl[p].w, pl[p].h);
			get_plane(&dc, m, p, v, pl[p].w, pl[p].h, &c);
			v += (size_t)pl[p].w * pl[p].h;
		}
	}
	free(m);
	bool ok = !dc.corrupt && rans_dec_done(&dc.d[0]) && rans_dec_done(&dc.d[1]) &&
	          bitreader_consumed(&dc.bits) <= bitreader_available(&dc.bits) &&
	          bitreader_available(&dc.bits) - bitreader_consumed(&dc.bits) < 8;
	return ok ? 0 : -EBADMSG;
}

static inline unsigned mask_context(const uint8_t *m, uint32_t P, uint32_t x, uint32_t y)
{
	return (x ? m[y * P + x - 1] : 1u) + 2u * (y ? m[(y - 1) * P + x] : 1u);
}

int relief_mask_encode(uint32_t P, const uint8_t *mask, uint8_t **out, size_t *out_size)
{
	struct rc_encoder e;
	rc_encoder_init(&e);
	rc_prob p[4] = { RC_PROB_INIT, RC_PROB_INIT, RC_PROB_INIT, RC_PROB_INIT };
	for (uint32_t y = 0; y < P; y++)
		for (uint32_t x = 0; x < P; x++)
			rc_encode_bit(&e, &p[mask_context(mask, P, x, y)], mask[y * P + x] != 0);
	int ret = rc_encoder_flush(&e);
	if (ret < 0) {
		rc_encoder_finish(&e);
		return ret;
	}
	*out = e.buf;
	*out_size = e.size;
	return 0;
}

int relief_mask_decode(uint32_t P, const uint8_t *buf, size_t size, uint8_t *mask)
{
	struct rc_decoder d;
	rc_decoder_init(&d, buf, size);
	rc_prob p[4] = { RC_PROB_INIT, RC_PROB_INIT, RC_PROB_INIT, RC_PROB_INIT };
	for (uint32_t y = 0; y < P; y++)
		for (uint32_t x = 0; x < P; x++)
			mask[y * P + x] = (uint8_t)rc_decode_bit(&d, &p[mask_context(mask, P, x, y)]);
	return d.overrun ? -EBADMSG : 0;
}
