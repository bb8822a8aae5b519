/* Range coder, CRC32C and the patch codec on synthetic data, hostile streams included. */
#include <errno.h>
#include <string.h>

#include "../test_util.h"
#include "codec.h"
#include "crc32c.h"
#include "layout.h"
#include "rangecoder.h"

static uint32_t rng_state = 12345;
static uint32_t rng(void)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 17;
	rng_state ^= rng_state << 5;
	return rng_state;
}

static void test_crc32c_check_value(void **state)
{
	assert_int_equal(relief_crc32c(0, "123456789", 9), 0xE3069283u);
	assert_int_equal(relief_crc32c_portable(0, "123456789", 9), 0xE3069283u);
	/* Incremental equals one-shot. */
	assert_int_equal(relief_crc32c(relief_crc32c(0, "1234", 4), "56789", 5), 0xE3069283u);
	/* Both paths agree on every length and alignment of random data. */
	uint8_t buf[4096 + 8];
	for (size_t i = 0; i < sizeof(buf); i++)
		buf[i] = (uint8_t)rng();
	for (size_t off = 0; off < 8; off++)
		for (size_t len = 0; len < 300; len++)
			assert_int_equal(relief_crc32c(7, buf + off, len), relief_crc32c_portable(7, buf + off, len));
	assert_int_equal(relief_crc32c(0, buf, 4096), relief_crc32c_portable(0, buf, 4096));
	print_message("crc32c: %s path\n", relief_crc32c_hardware() ? "SSE4.2" : "table");
}

static void test_rangecoder_roundtrip(void **state)
{
	enum { N = 200000 };
	uint8_t *bits = malloc(N);
	uint32_t *direct = malloc(sizeof(uint32_t) * N / 16);
	for (int i = 0; i < N; i++) /* skewed, changing statistics */
		bits[i] = (rng() % 100) < (i < N / 2 ? 5u : 70u);
	for (int i = 0; i < N / 16; i++)
		direct[i] = rng() & 0xfffff;
	struct rc_encoder e;
	rc_encoder_init(&e);
	rc_prob p[2] = { RC_PROB_INIT, RC_PROB_INIT };
	for (int i = 0; i < N; i++) {
		rc_encode_bit(&e, &p[i & 1], bits[i]);
		if (i % 16 == 0)
			rc_encode_direct(&e, direct[i / 16], 20);
	}
	assert_int_equal(rc_encoder_flush(&e), 0);
	/* Skewed bits compress: far fewer than N/8 + 20 bits per direct value. */
	assert_true(e.size < N / 8 + N / 16 * 20 / 8);
	struct rc_decoder d;
	rc_decoder_init(&d, e.buf, e.size);
	rc_prob q[2] = { RC_PROB_INIT, RC_PROB_INIT };
	for (int i = 0; i < N; i++) {
		assert_int_equal(rc_decode_bit(&d, &q[i & 1]), bits[i]);
		if (i % 16 == 0)
			assert_int_equal(rc_decode_direct(&d, 20), direct[i / 16]);
	}
	assert_false(d.overrun);
	/* Truncation is noticed, never read past. */
	rc_decoder_init(&d, e.buf, e.size / 2);
	q[0] = q[1] = RC_PROB_INIT;
	for (int i = 0; i < N; i++) {
		rc_decode_bit(&d, &q[i & 1]);
		if (i % 16 == 0)
			rc_decode_direct(&d, 20);
	}
	assert_true(d.overrun);
	rc_encoder_finish(&e);
	free(bits);
	free(direct);
}

static void test_geom(void **state)
{
	struct relief_patch_geom g;
	assert_int_equal(relief_patch_geom_init(&g, 129), 0);
	assert_int_equal(g.E, 131);
	assert_int_equal(g.L, 65);
	assert_int_equal(g.n_labels + g.n_residuals, 131 * 131);
	assert_int_equal(relief_patch_geom_init(&g, 128), -EINVAL);
	assert_int_equal(relief_patch_geom_init(&g, 2), -EINVAL);
}

/* A parent block and a child quantised from it the way the packer does. */
static void make_pair(const struct relief_patch_geom *g, uint32_t k, unsigned quadrant, int32_t *parent,
                      int32_t *child)
{
	const uint32_t E = g->E;
	for (uint32_t i = 0; i < E * E; i++)
		parent[i] = 1000 + (int32_t)(rng() % 64) - 32;
	uint32_t ox = (quadrant & 1) ? g->half : 0, oy = (quadrant & 2) ? g->half : 0;
	for (uint32_t y = 0; y < E; y++)
		for (uint32_t x = 0; x < E; x++) {
			int lx = (int)x - 1, ly = (int)y - 1;
			if (!(lx & 1) && !(ly & 1) && lx >= 0 && ly >= 0 && lx < (int)g->P && ly < (int)g->P)
				child[y * E + x] = (int32_t)k * parent[(oy + ly / 2 + 1) * E + ox + lx / 2 + 1] +
				                   (int32_t)(rng() % 3) - 1;
			else
				child[y * E + x] = (int32_t)k * 1000 + (int32_t)(rng() % 200) - 100;
		}
}

static void roundtrip(uint32_t P, uint32_t k, unsigned quadrant)
{
	struct relief_patch_geom g;
	assert_int_equal(relief_patch_geom_init(&g, P), 0);
	size_t EE = (size_t)g.E * g.E;
	int32_t *parent = malloc(sizeof(int32_t) * EE), *child = malloc(sizeof(int32_t) * EE);
	int32_t *res = malloc(sizeof(int32_t) * EE), *res2 = malloc(sizeof(int32_t) * EE);
	int32_t *out = malloc(sizeof(int32_t) * EE);
	int8_t *labels = malloc(g.n_labels), *labels2 = malloc(g.n_labels);
	make_pair(&g, k, quadrant, parent, child);
	assert_int_equal(relief_patch_analyse(&g, k, quadrant, parent, child, labels, res), 0);
	uint8_t *buf;
	size_t size;
	assert_int_equal(relief_patch_encode(&g, false, NULL, labels, res, &buf, &size), 0);
	assert_int_equal(relief_patch_decode_symbols(&g, false, NULL, buf, size, labels2, res2), 0);
	assert_memory_equal(labels, labels2, g.n_labels);
	assert_memory_equal(res, res2, sizeof(int32_t) * g.n_residuals);
	assert_int_equal(relief_patch_reconstruct(&g, k, quadrant, parent, labels2, res2, out), 0);
	assert_memory_equal(out, child, sizeof(int32_t) * EE);
	/* A truncated stream is reported. */
	assert_int_equal(relief_patch_decode_symbols(&g, false, NULL, buf, size / 2, labels2, res2), -EBADMSG);
	free(buf);
	/* Root: MED residuals. */
	relief_root_analyse(&g, child, res);
	assert_int_equal(relief_patch_encode(&g, true, NULL, NULL, res, &buf, &size), 0);
	assert_int_equal(relief_patch_decode_symbols(&g, true, NULL, buf, size, NULL, res2), 0);
	assert_int_equal(relief_root_reconstruct(&g, res2, out), 0);
	assert_memory_equal(out, child, sizeof(int32_t) * EE);
	free(buf);
	free(parent); free(child); free(res); free(res2); free(out); free(labels); free(labels2);
}

static void test_patch_roundtrip(void **state)
{
	for (unsigned q = 0; q < 4; q++) {
		roundtrip(129, 2, q);
		roundtrip(65, 3, q);
	}
	roundtrip(257, 2, 3);
}

/* The largest patch the format allows: the decoder's per-row state must hold the root's
 * plane, P + 2 samples wide (a buffer sized for the child planes overflowed here). */
static void test_patch_roundtrip_largest(void **state) { roundtrip(RELIEF_PATCH_MAX, 2, 1); }

/* Whether local sample (x, y) is coded under a window, restated from codec.h. */
static bool window_codes(const struct relief_window *w, int x, int y)
{
	return (x >= w->x0 && x < w->x1 && y >= w->y0 && y < w->y1) || (w->ring_west && x == -1) ||
	       (w->ring_north && y == -1);
}

/* A stream that skips what lies outside a window decodes to the same labels and residuals
 * (0 outside), is shorter than the whole patch's, and the encoder refuses a window whose
 * outside is not 0. Windows with and without the ring tails, odd and even ends. */
static void test_window_roundtrip(void **state)
{
	struct relief_patch_geom g;
	assert_int_equal(relief_patch_geom_init(&g, 65), 0);
	const struct relief_window wins[] = {
		{ -1, -1, 12, 36, true, true }, { -1, -1, 66, 8, false, true }, { -1, -1, 2, 66, true, false },
		{ -1, -1, 7, 9, false, false }, { -1, -1, 66, 66, true, true },
	};
	const uint32_t odd = (g.P + 3) / 2, L = g.L;
	const struct {
		uint32_t w, h;
		int x0, y0;
	} pl[3] = { { odd, L, -1, 0 }, { L, odd, 0, -1 }, { odd, odd, -1, -1 } };
	int32_t *res = malloc(sizeof(int32_t) * g.n_residuals), *res2 = malloc(sizeof(int32_t) * g.n_residuals);
	int8_t *labels = malloc(g.n_labels), *labels2 = malloc(g.n_labels);
	for (size_t k = 0; k < sizeof(wins) / sizeof(wins[0]); k++) {
		const struct relief_window *w = &wins[k];
		for (uint32_t j = 0; j < L; j++)
			for (uint32_t i = 0; i < L; i++)
				labels[j * L + i] = window_codes(w, 2 * (int)i, 2 * (int)j) ? (int8_t)(rng() % 3) - 1 : 0;
		size_t n = 0;
		for (int p = 0; p < 3; p++)
			for (uint32_t v = 0; v < pl[p].h; v++)
				for (uint32_t u = 0; u < pl[p].w; u++, n++)
					res[n] = window_codes(w, pl[p].x0 + 2 * (int)u, pl[p].y0 + 2 * (int)v)
					                 ? (int32_t)(rng() % 41) - 20
					                 : 0;
		uint8_t *buf, *whole;
		size_t size, whole_size;
		assert_int_equal(relief_patch_encode(&g, false, w, labels, res, &buf, &size), 0);
		assert_int_equal(relief_patch_encode(&g, false, NULL, labels, res, &whole, &whole_size), 0);
		memset(labels2, 0x55, g.n_labels);
		memset(res2, 0x55, sizeof(int32_t) * g.n_residuals);
		assert_int_equal(relief_patch_decode_symbols(&g, false, w, buf, size, labels2, res2), 0);
		assert_memory_equal(labels, labels2, g.n_labels);
		assert_memory_equal(res, res2, sizeof(int32_t) * g.n_residuals);
		if (k + 1 < sizeof(wins) / sizeof(wins[0]))
			assert_true(size < whole_size);
		free(buf);
		free(whole);
		/* A non-zero value outside: the last residual of the centre plane, (P, P), is
		 * outside every window above but the last. */
		if (k + 1 < sizeof(wins) / sizeof(wins[0])) {
			res[g.n_residuals - 1] = 3;
			assert_int_equal(relief_patch_encode(&g, false, w, labels, res, &buf, &size), -EINVAL);
		}
	}
	/* The root: a plain rectangle of its raster-order values. */
	const struct relief_window rw = { 0, 0, 40, 50, false, false };
	const uint32_t E = g.E;
	int32_t *rv = calloc((size_t)E * E, sizeof(int32_t)), *rv2 = malloc(sizeof(int32_t) * E * E);
	for (uint32_t y = 0; y < E; y++)
		for (uint32_t x = 0; x < E; x++)
			if ((int)x - 1 >= rw.x0 && (int)x - 1 < rw.x1 && (int)y - 1 >= rw.y0 && (int)y - 1 < rw.y1)
				rv[y * E + x] = (int32_t)(rng() % 41) - 20;
	uint8_t *buf, *whole;
	size_t size, whole_size;
	assert_int_equal(relief_patch_encode(&g, true, &rw, NULL, rv, &buf, &size), 0);
	assert_int_equal(relief_patch_encode(&g, true, NULL, NULL, rv, &whole, &whole_size), 0);
	assert_true(size < whole_size);
	memset(rv2, 0x55, sizeof(int32_t) * E * E);
	assert_int_equal(relief_patch_decode_symbols(&g, true, &rw, buf, size, NULL, rv2), 0);
	assert_memory_equal(rv, rv2, sizeof(int32_t) * E * E);
	free(buf);
	free(whole);
	rv[0] = 1; /* the ring corner (-1, -1) is outside */
	assert_int_equal(relief_patch_encode(&g, true, &rw, NULL, rv, &buf, &size), -EINVAL);
	free(rv);
	free(rv2);
	free(res);
	free(res2);
	free(labels);
	free(labels2);
}

/* The windows of Mont Blanc's 647 x 647 raster in a 1025 x 1025 grid (P = 129, 4 levels):
 * the padding from the first even column at or beyond the extent is skipped inside the
 * grid, the grid's ring never. */
static void test_patch_windows(void **state)
{
	struct relief_layout lay;
	assert_int_equal(relief_layout_init(&lay, 129, 4, 2, 1.0), 0);
	struct relief_window w;
	relief_patch_window(&lay, 647, 647, 3, 5, 0, false, &w); /* level 3: columns 640..768, 647 valid */
	assert_int_equal(w.x0, -1);
	assert_int_equal(w.x1, 8);   /* 648 - 640 */
	assert_int_equal(w.y1, 130); /* rows 0..128: all inside */
	assert_true(!w.ring_west && w.ring_north);
	relief_patch_window(&lay, 647, 647, 3, 4, 5, false, &w);
	assert_int_equal(w.x1, 130);
	assert_int_equal(w.y1, 8);
	relief_patch_window(&lay, 647, 647, 2, 2, 2, false, &w); /* level 2: 324 samples, columns from 256 */
	assert_int_equal(w.x1, 68);
	assert_int_equal(w.y1, 68);
	relief_patch_window(&lay, 647, 647, 1, 1, 0, false, &w); /* the last column holds the grid's ring */
	assert_int_equal(w.x1, 130);
	relief_patch_window(&lay, 647, 647, 0, 0, 0, false, &w); /* the root: 81 samples (647 / 8), no ring */
	assert_int_equal(w.x0, 0);
	assert_int_equal(w.y0, 0);
	assert_int_equal(w.x1, 81);
	assert_int_equal(w.y1, 81);
	assert_true(!w.ring_west && !w.ring_north);
	relief_patch_window(&lay, 647, 647, 2, 0, 0, false, &w);
	assert_int_equal(w.x1, 130);
	assert_true(w.ring_west && w.ring_north);
	relief_patch_window(&lay, 645, 1025, 3, 5, 0, false, &w); /* 645 valid: the first even beyond is 646 */
	assert_int_equal(w.x1, 6);
	assert_int_equal(w.y1, 130);
	/* Format version 9 (rim): the first sample past the extent is coded too, so where the
	 * extent's level width is even the window grows by two (rounded up to even again). */
	relief_patch_window(&lay, 647, 647, 3, 5, 0, true, &w); /* 647 odd: 648 already coded */
	assert_int_equal(w.x1, 8);
	relief_patch_window(&lay, 647, 647, 2, 2, 2, true, &w); /* 324 even: to 326 */
	assert_int_equal(w.x1, 70);
	assert_int_equal(w.y1, 70);
	relief_patch_window(&lay, 647, 647, 0, 0, 0, true, &w); /* the root: 81 + 1 */
	assert_int_equal(w.x1, 82);
	assert_int_equal(w.y1, 82);
	assert_int_equal(relief_level_coded(&lay, 647, 1, false), 162);
	assert_int_equal(relief_level_coded(&lay, 647, 1, true), 164);
	assert_int_equal(relief_level_coded(&lay, 1025, 0, true), 130); /* the root's east ring */
}

static void test_analyse_rejects_foreign_child(void **state)
{
	struct relief_patch_geom g;
	relief_patch_geom_init(&g, 65);
	size_t EE = (size_t)g.E * g.E;
	int32_t *parent = calloc(EE, 4), *child = calloc(EE, 4), *res = calloc(EE, 4);
	int8_t *labels = calloc(g.n_labels, 1);
	child[1 * g.E + 1] = 2; /* refined sample 2 away from k * 0 */
	assert_int_equal(relief_patch_analyse(&g, 2, 0, parent, child, labels, res), -ERANGE);
	free(parent); free(child); free(res); free(labels);
}

/* Hostile values: out-of-range parents or residuals never overflow, they are refused. */
static void test_reconstruct_refuses_out_of_range(void **state)
{
	struct relief_patch_geom g;
	relief_patch_geom_init(&g, 65);
	size_t EE = (size_t)g.E * g.E;
	int32_t *parent = calloc(EE, 4), *res = calloc(EE, 4), *out = calloc(EE, 4);
	int8_t *labels = calloc(g.n_labels, 1);
	parent[5] = RELIEF_Q_MAX + 1;
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), -EBADMSG);
	parent[5] = 0;
	parent[(g.E / 2) * g.E + g.E / 2] = RELIEF_Q_MAX; /* used by every quadrant; 3 * max overflows the range */
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), -EBADMSG);
	parent[(g.E / 2) * g.E + g.E / 2] = 0;
	res[7] = (1 << 29) - 1;
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), -EBADMSG);
	res[7] = -(1 << 29);
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), -EBADMSG);
	res[7] = INT32_MIN; /* must be refused, not overflow (UBSan watches) */
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), -EBADMSG);
	res[7] = INT32_MAX;
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), -EBADMSG);
	res[7] = 0;
	assert_int_equal(relief_patch_reconstruct(&g, 3, 1, parent, labels, res, out), 0);
	res[0] = INT32_MIN;
	assert_int_equal(relief_root_reconstruct(&g, res, out), -EBADMSG);
	free(parent); free(res); free(out); free(labels);
}

/* Random bytes decode to something or to -EBADMSG, never to a crash. */
static void test_random_streams(void **state)
{
	struct relief_patch_geom g;
	relief_patch_geom_init(&g, 65);
	int8_t *labels = malloc(g.n_labels);
	int32_t *res = malloc(sizeof(int32_t) * g.E * g.E);
	uint8_t buf[4096];
	for (int t = 0; t < 200; t++) {
		size_t n = rng() % sizeof(buf);
		for (size_t i = 0; i < n; i++)
			buf[i] = (uint8_t)rng();
		int r = relief_patch_decode_symbols(&g, t & 1, NULL, buf, n, labels, res);
		assert_true(r == 0 || r == -EBADMSG);
	}
	free(labels);
	free(res);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_crc32c_check_value),
		cmocka_unit_test(test_rangecoder_roundtrip),
		cmocka_unit_test(test_geom),
		cmocka_unit_test(test_patch_roundtrip),
		cmocka_unit_test(test_patch_roundtrip_largest),
		cmocka_unit_test(test_window_roundtrip),
		cmocka_unit_test(test_patch_windows),
		cmocka_unit_test(test_analyse_rejects_foreign_child),
		cmocka_unit_test(test_reconstruct_refuses_out_of_range),
		cmocka_unit_test(test_random_streams),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
