/* Range coder, CRC32C and the patch codec on synthetic data, hostile streams included. */
#include <errno.h>
#include <string.h>

#include "../test_util.h"
#include "codec.h"
#include "crc32c.h"
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
	assert_int_equal(relief_patch_encode(&g, false, labels, res, &buf, &size), 0);
	assert_int_equal(relief_patch_decode_symbols(&g, false, buf, size, labels2, res2), 0);
	assert_memory_equal(labels, labels2, g.n_labels);
	assert_memory_equal(res, res2, sizeof(int32_t) * g.n_residuals);
	assert_int_equal(relief_patch_reconstruct(&g, k, quadrant, parent, labels2, res2, out), 0);
	assert_memory_equal(out, child, sizeof(int32_t) * EE);
	/* A truncated stream is reported. */
	assert_int_equal(relief_patch_decode_symbols(&g, false, buf, size / 2, labels2, res2), -EBADMSG);
	free(buf);
	/* Root: MED residuals. */
	relief_root_analyse(&g, child, res);
	assert_int_equal(relief_patch_encode(&g, true, NULL, res, &buf, &size), 0);
	assert_int_equal(relief_patch_decode_symbols(&g, true, buf, size, NULL, res2), 0);
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
		int r = relief_patch_decode_symbols(&g, t & 1, buf, n, labels, res);
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
		cmocka_unit_test(test_analyse_rejects_foreign_child),
		cmocka_unit_test(test_reconstruct_refuses_out_of_range),
		cmocka_unit_test(test_random_streams),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
