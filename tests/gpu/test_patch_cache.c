/* The GPU patch cache: GPU decoding is bit-exact with the CPU reference decoder on every
 * patch of the bundled DEMs; normals and block errors agree with the CPU; the budget and
 * the residency rules hold under eviction; corrupt and vanished patches are refused without
 * harming the rest. Validation layer on, zero messages. */
#include <errno.h>
#include <math.h>
#include <string.h>
#include <unistd.h>

#include "../data_load.h"
#include "crc32c.h"
#include "decode.h"
#include "format.h"
#include "gpu_test.h"
#include "normals.h"
#include "pack.h"
#include "patch_cache.h"
#include "strip_bound.h"

#define vk gpu_test_vk

static void pack_dem(enum test_dem d, uint32_t patch, double tol, uint8_t **img, size_t *size)
{
	struct relief_dem dem;
	test_dem_load(d, &dem);
	struct relief_pack_options o = { .patch = patch, .ratio = 2, .tolerance = tol };
	assert_int_equal(relief_pack_memory(&dem, &o, img, size, NULL), 0);
	relief_dem_finish(&dem);
}

/* A packed DEM opened from memory. */
struct terrain {
	uint8_t *img;
	size_t size;
	struct relief_file *f;
};

static void terrain_open(struct terrain *t, enum test_dem d, uint32_t patch, double tol)
{
	char err[256];
	pack_dem(d, patch, tol, &t->img, &t->size);
	assert_int_equal(relief_file_open_memory(t->img, t->size, &t->f, err, sizeof(err)), 0);
}

static void terrain_close(struct terrain *t)
{
	relief_file_close(t->f);
	free(t->img);
}

/* Requests every patch, coarse levels first, then waits until nothing more can become
 * resident. A child's request is accepted while its parent is on its way, so no request
 * here waits for a flush: the worker decodes deeper levels while the GPU reconstructs
 * shallower ones. */
static void load_all(struct relief_patch_cache *c, const struct relief_file *f, uint64_t frame)
{
	for (uint32_t id = 0; id < f->hdr.patch_count; id++) {
		int r = relief_patch_cache_request(c, id, (float)id);
		assert_true(r == 0 || r == -ENOENT || r == -EIO);
	}
	assert_int_equal(relief_patch_cache_flush(c, frame), 0);
}

/* CPU normal of sample (x, y) of a decoded block, as patch_normals.comp computes it. */
static void cpu_normal(const struct relief_file *f, uint32_t l, const int32_t *b, uint32_t x, uint32_t y, double n[3])
{
	const uint32_t E = f->layout.geom.E;
	double step = (double)(1u << (f->hdr.levels - 1 - l)), q2 = 2 * f->layout.delta[l];
	const int32_t *s = b + (y + 1) * E + x + 1;
	double dhdx = (s[1] - s[-1]) * q2 / (2 * f->hdr.spacing_x * step);
	double dhdy = (s[-(int)E] - s[E]) * q2 / (2 * f->hdr.spacing_y * step);
	double len = sqrt(dhdx * dhdx + dhdy * dhdy + 1);
	n[0] = -dhdx / len;
	n[1] = -dhdy / len;
	n[2] = 1 / len;
}

static void check_bit_exact(enum test_dem d, uint32_t patch, double tol, uint32_t workers)
{
	struct terrain t;
	terrain_open(&t, d, patch, tol);
	struct relief_file *f = t.f;
	/* The pass timestamps with one worker, a streaming cache's start and end only with more. */
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20, .workers = workers, .pass_timing = workers == 1 };
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, f, &o, &gpu_test_log, &c), 0);
	load_all(c, f, 1);

	const struct relief_layout *lay = &f->layout;
	const uint32_t E = lay->geom.E, P = lay->geom.P;
	const size_t EE = (size_t)E * E, ne = relief_block_errors_per_patch(P), nb = ne + relief_block_ranges_per_patch(P);
	int32_t *gpu_h = malloc(sizeof(int32_t) * EE);
	int8_t *gpu_n = malloc((size_t)P * P * 4);
	const size_t nrec = relief_patch_block_floats(P); /* errors, ranges, then which blocks have data */
	const size_t nlayer = relief_patch_layer_floats(P), nstrip = nlayer - nrec; /* then the strip bounds */
	float *gpu_e = malloc(sizeof(float) * nlayer), *cpu_e = malloc(sizeof(float) * nb);
	float *cpu_strips = malloc(sizeof(float) * nstrip);
	double strip_diff = 0, strip_max = 0; /* the strip bounds' GPU - CPU twin, and their largest */
	uint32_t checked = 0;
	double worst_normal = 0;
	int twin_steps = 0;      /* largest difference between the CPU twin and the GPU, snorm8 steps */
	uint64_t twin_same = 0; /* components where they agree */
	uint32_t blocks_with_data = 0, blocks_seen = 0; /* over every decoded patch */
	for (uint32_t l = 0; l < lay->levels; l++) {
		int32_t *blocks;
		assert_int_equal(relief_decode_level_blocks(f, l, 1, &blocks), 0);
		for (uint32_t i = 0; i < f->hdr.index_cols[l] * f->hdr.index_rows[l]; i++) { /* entry order */
			uint32_t id = relief_index_patch(&f->hdr, f->hdr.index_first[l] + i);
			enum relief_patch_state st = relief_patch_cache_state(c, id);
			if (st == RELIEF_PATCH_NONE)
				continue;
			assert_int_equal(st, RELIEF_PATCH_RESIDENT);
			int layer = relief_patch_cache_layer(c, id);
			assert_true(layer >= 0);
			assert_int_equal(relief_patch_cache_read_layer(c, (uint32_t)layer, gpu_h, gpu_n, gpu_e), 0);
			const int32_t *cpu = blocks + i * EE;
			if (memcmp(gpu_h, cpu, sizeof(int32_t) * EE) != 0) {
				for (size_t k = 0; k < EE; k++)
					if (gpu_h[k] != cpu[k])
						fail_msg("%s patch %u sample %zu,%zu: GPU %d, CPU %d", test_dem_name(d), id, k % E,
						         k / E, gpu_h[k], cpu[k]);
			}
			relief_file_block_errors(f, id, cpu_e);
			relief_file_block_ranges(f, id, cpu_e + ne);
			assert_memory_equal(gpu_e, cpu_e, sizeof(float) * nb);
			/* every sample of a block (its border included) within the block's height range */
			const double q2 = 2.0 * lay->delta[l];
			for (uint32_t y = 0; y < P; y++)
				for (uint32_t x = 0; x < P; x++) {
					double h = q2 * cpu[(y + 1) * E + x + 1];
					for (uint32_t by = y / RELIEF_BLOCK_CELLS - (y % RELIEF_BLOCK_CELLS == 0 && y > 0);
					     by <= y / RELIEF_BLOCK_CELLS && by < lay->blocks; by++)
						for (uint32_t bx = x / RELIEF_BLOCK_CELLS - (x % RELIEF_BLOCK_CELLS == 0 && x > 0);
						     bx <= x / RELIEF_BLOCK_CELLS && bx < lay->blocks; bx++) {
							const float *rg = cpu_e + ne + (by * lay->blocks + bx) * 2;
							if (h < rg[0] || h > rg[1])
								fail_msg("%s patch %u sample %u,%u: %g outside block %u,%u's range [%g, %g]",
								         test_dem_name(d), id, x, y, h, bx, by, rg[0], rg[1]);
						}
				}
			uint8_t *mask = malloc((size_t)P * P);
			assert_int_equal(relief_file_mask(f, id, mask), 0);
			for (size_t k = 0; k < (size_t)P * P; k++)
				assert_int_equal(gpu_n[k * 4 + 3], mask[k] ? 127 : -127); /* validity in w */
			/* A block's bit is set where any of its (16 + 1)^2 samples is valid: each valid
			 * sample sets the bits of the blocks it belongs to (up to four on block borders). */
			uint32_t want[RELIEF_MAX_BLOCKS / 16] = { 0 };
			const uint32_t nbl = lay->blocks;
			for (uint32_t y = 0; y < P; y++)
				for (uint32_t x = 0; x < P; x++) {
					if (!mask[(size_t)y * P + x])
						continue;
					for (uint32_t by = y / 16 - (y % 16 == 0 && y > 0); by <= y / 16 && by < nbl; by++)
						for (uint32_t bx = x / 16 - (x % 16 == 0 && x > 0); bx <= x / 16 && bx < nbl; bx++)
							want[(by * nbl + bx) / 16] |= 1u << ((by * nbl + bx) % 16);
				}
			for (size_t w = 0; w < nrec - nb; w++)
				if ((float)want[w] != gpu_e[nb + w])
					fail_msg("%s patch %u: blocks with data %g in word %zu, expected %u", test_dem_name(d), id,
					         gpu_e[nb + w], w, want[w]);
			for (size_t w = 0; w < nrec - nb; w++)
				blocks_with_data += (uint32_t)__builtin_popcount(want[w]);
			blocks_seen += nbl * nbl;
			/* The CPU twin (common/normals.c) within one snorm8 step of the shader. */
			uint32_t *twin = malloc(sizeof(uint32_t) * P * P);
			relief_normals_pack(f, l, cpu, mask, twin);
			for (size_t k = 0; k < (size_t)P * P; k++)
				for (int b = 0; b < 4; b++) {
					int tv = (int8_t)(twin[k] >> (8 * b)), gv = gpu_n[k * 4 + b], steps = abs(tv - gv);
					twin_steps = steps > twin_steps ? steps : twin_steps;
					twin_same += steps == 0;
				}
			free(twin);
			/* The strip bounds (patch_strips.comp) against their CPU twin (strip_bound.c). */
			struct relief_patch_record rec;
			relief_file_record(f, id, &rec);
			assert_int_equal(relief_strip_bounds(cpu, P, (float)q2, cpu_e, l + 1 == lay->levels,
			                                     relief_file_measured_draw_error(f, &rec), cpu_strips),
			                 0);
			for (size_t k = 0; k < nstrip; k++) {
				const double g = gpu_e[nrec + k], cs = cpu_strips[k];
				strip_diff = fmax(strip_diff, fabs(g - cs) / fmax(1.0, fabs(cs)));
				strip_max = fmax(strip_max, cs);
				if (!(g >= 0.0))
					fail_msg("%s patch %u strip bound %zu: %g", test_dem_name(d), id, k, g);
			}
			free(mask);
			for (uint32_t y = 0; y < P; y++)
				for (uint32_t x = 0; x < P; x++) {
					double n[3];
					cpu_normal(f, l, cpu, x, y, n);
					for (int k = 0; k < 3; k++) {
						double g = fmax(gpu_n[(y * P + x) * 4 + k] / 127.0, -1.0);
						worst_normal = fmax(worst_normal, fabs(g - n[k]));
					}
				}
			checked++;
		}
		free(blocks);
	}
	/* snorm8 quantisation (1/254) plus float arithmetic */
	print_message("%s: %u patches bit-exact, block errors and height ranges equal and holding every sample, "
	              "worst normal component error %.4f\n",
	              test_dem_name(d), checked, worst_normal);
	assert_true(worst_normal <= 0.006);
	print_message("%s: the CPU normals twin equals the GPU in %.4f %% of components, at most %d snorm8 step(s) off\n",
	              test_dem_name(d), 100.0 * (double)twin_same / ((double)checked * P * P * 4), twin_steps);
	assert_true(twin_steps <= 1);
	print_message("%s: transition strip bounds up to %.2f m, GPU against the CPU twin within %.2g (relative, or m "
	              "below 1 m)\n",
	              test_dem_name(d), strip_max, strip_diff);
	assert_true(strip_diff <= 1e-5);
	assert_true(strip_max > 0.0);
	free(cpu_strips);
	print_message("%s: %u of %u blocks have a valid sample, their bits in the layers as the masks say\n",
	              test_dem_name(d), blocks_with_data, blocks_seen);
	assert_true(blocks_with_data > 0);
	if (d != DEM_PUGET) /* no-data outside Luxembourg, padding beside Mont Blanc: some blocks have none */
		assert_true(blocks_with_data < blocks_seen);
	struct relief_patch_cache_stats s;
	relief_patch_cache_stats(c, &s);
	assert_int_equal(s.decoded, checked);
	assert_true(s.bytes <= o.budget_bytes);
	if (vk->timestamp_valid_bits && o.pass_timing) { /* the three passes split the batches' GPU time */
		assert_true(s.gpu_decode_ns > 0 && s.gpu_normals_ns > 0 && s.gpu_strips_ns > 0);
		uint64_t sum = s.gpu_decode_ns + s.gpu_normals_ns + s.gpu_strips_ns;
		assert_true(sum <= s.gpu_ns + 2 * s.batches && s.gpu_ns <= sum + 2 * s.batches); /* rounding per batch */
	} else if (vk->timestamp_valid_bits) { /* the batches' time without the split */
		assert_true(s.gpu_ns > 0);
		assert_true(s.gpu_decode_ns == 0 && s.gpu_normals_ns == 0 && s.gpu_strips_ns == 0);
	}
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	free(gpu_h);
	free(gpu_n);
	free(gpu_e);
	free(cpu_e);
	gpu_test_assert_clean(vk);
}

static void test_bit_exact_puget(void **state) { check_bit_exact(DEM_PUGET, 129, 1.0, 1); }
/* Three entropy workers finish out of order: children wait for their parents' batches. */
static void test_bit_exact_alps(void **state) { check_bit_exact(DEM_ALPS, 129, 0.5, 3); }
static void test_bit_exact_lux(void **state) { check_bit_exact(DEM_LUX, 65, 0.25, 1); }
/* The largest patch size: 9 workgroup runs per patch in each pass, the last normals block
 * of each column one row high (257 = 64 x 4 + 1). */
static void test_bit_exact_lux_257(void **state) { check_bit_exact(DEM_LUX, 257, 0.5, 2); }

/* Every resident patch's parent is resident, and no two resident patches share a layer. */
static void assert_tree_consistent(struct relief_patch_cache *c, const struct relief_file *f)
{
	struct relief_patch_cache_stats s;
	relief_patch_cache_stats(c, &s);
	int32_t *owner = malloc(sizeof(int32_t) * s.layers);
	for (uint32_t i = 0; i < s.layers; i++)
		owner[i] = -1;
	for (uint32_t id = 0; id < f->hdr.patch_count; id++) {
		if (relief_patch_cache_state(c, id) != RELIEF_PATCH_RESIDENT)
			continue;
		int layer = relief_patch_cache_layer(c, id);
		assert_true(layer >= 0 && (uint32_t)layer < s.layers);
		if (owner[layer] >= 0)
			fail_msg("patches %d and %u both resident in layer %d", owner[layer], id, layer);
		owner[layer] = (int32_t)id;
		if (id == 0)
			continue;
		uint32_t l, px, py;
		relief_patch_coords(&f->layout, id, &l, &px, &py);
		assert_int_equal(relief_patch_cache_state(c, relief_patch_id(l - 1, px / 2, py / 2)), RELIEF_PATCH_RESIDENT);
	}
	free(owner);
}

/* Patch id's layer holds exactly what the CPU reference decodes. */
static void assert_patch_exact(struct relief_patch_cache *c, const struct relief_file *f, uint32_t id)
{
	uint32_t l, px, py;
	relief_patch_coords(&f->layout, id, &l, &px, &py);
	const size_t EE = (size_t)f->layout.geom.E * f->layout.geom.E;
	int32_t *blocks, *gpu = malloc(sizeof(int32_t) * EE);
	assert_int_equal(relief_decode_level_blocks(f, l, 1, &blocks), 0);
	int layer = relief_patch_cache_layer(c, id);
	assert_true(layer >= 0);
	assert_int_equal(relief_patch_cache_read_layer(c, (uint32_t)layer, gpu, NULL, NULL), 0);
	assert_memory_equal(gpu, blocks + (relief_index_entry(&f->hdr, id) - f->hdr.index_first[l]) * EE,
	                    sizeof(int32_t) * EE);
	free(blocks);
	free(gpu);
}

static void test_budget_and_eviction(void **state)
{
	struct terrain t;
	terrain_open(&t, DEM_PUGET, 129, 2.0);
	struct relief_file *f = t.f;
	/* A budget below one patch is refused. */
	struct relief_patch_cache_options tiny = { .budget_bytes = 4096 };
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, f, &tiny, NULL, &c), -ENOSPC);
	/* Budgets are honoured exactly, whatever they are. */
	for (uint64_t mib = 1; mib <= 9; mib += 4) {
		struct relief_patch_cache_options o = { .budget_bytes = mib << 20 };
		assert_int_equal(relief_patch_cache_create(vk, f, &o, NULL, &c), 0);
		struct relief_patch_cache_stats s;
		relief_patch_cache_stats(c, &s);
		assert_true(s.bytes <= o.budget_bytes);
		assert_true(s.bytes + s.bytes_per_layer > o.budget_bytes || s.layers == 85);
		assert_int_equal(s.used + s.free, s.layers);
		relief_patch_cache_destroy(c);
	}
	/* Every cache on this device, here and in the tests before (other patch sizes too),
	 * took the one set of pipelines the device keeps (relief_vk_shared()). */
	assert_int_equal(vk->n_shared, 1);
	/* Seven layers: root, level 1, and two of level 2 at a time. */
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20, .max_layers = 7, .keep_frames = 1 };
	assert_int_equal(relief_patch_cache_create(vk, f, &o, NULL, &c), 0);
	uint64_t frame = 1;
	for (uint32_t id = 0; id < 5; id++)
		relief_patch_cache_request(c, id, 0);
	assert_int_equal(relief_patch_cache_flush(c, frame), 0);
	for (uint32_t id = 0; id < 5; id++)
		relief_patch_cache_request(c, id, 0);
	assert_int_equal(relief_patch_cache_flush(c, frame), 0);
	for (uint32_t id = 0; id < 5; id++)
		assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_RESIDENT);
	/* Walk over level 2 (ids 5..20), touching only the level-0/1 patches and the current
	 * pair: old level-2 patches are evicted, their parents never. */
	for (uint32_t id = 5; id < 21; id += 2) {
		frame += 2;
		for (uint32_t p = 0; p < 5; p++)
			relief_patch_cache_touch(c, p, frame);
		for (uint32_t k = id; k < id + 2; k++) {
			assert_int_equal(relief_patch_cache_request(c, k, 0), 0);
			relief_patch_cache_touch(c, k, frame);
		}
		assert_int_equal(relief_patch_cache_flush(c, frame), 0);
		assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_RESIDENT);
		assert_int_equal(relief_patch_cache_state(c, id + 1), RELIEF_PATCH_RESIDENT);
		assert_tree_consistent(c, f);
		struct relief_patch_cache_stats s;
		relief_patch_cache_stats(c, &s);
		assert_int_equal(s.layers, 7);
		assert_true(s.used <= 7);
	}
	struct relief_patch_cache_stats s;
	relief_patch_cache_stats(c, &s);
	assert_int_equal(s.evicted, 16 - 2);
	for (uint32_t id = 0; id < 5; id++)
		assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_RESIDENT);
	/* Nothing can be evicted while everything is in use this frame: flush reports it. */
	frame++;
	for (uint32_t id = 0; id < 21; id++)
		relief_patch_cache_touch(c, id, frame);
	uint32_t blocked = relief_level_first_id(2) + 2;
	relief_patch_cache_request(c, blocked, 0);
	assert_int_equal(relief_patch_cache_flush(c, frame), -ENOSPC);
	assert_tree_consistent(c, f);
	relief_patch_cache_destroy(c);

	/* Children go before their parents: three layers hold the root, patch 1 and its child
	 * 5. Patch 1 is the least recently used but has a resident child, so it stays. */
	struct relief_patch_cache_options three = { .budget_bytes = 64ull << 20, .max_layers = 3, .keep_frames = 1 };
	assert_int_equal(relief_patch_cache_create(vk, f, &three, NULL, &c), 0);
	relief_patch_cache_request(c, 0, 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	relief_patch_cache_request(c, 1, 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	assert_int_equal(relief_patch_cache_request(c, 5, 0), 0); /* (2, 0, 0), child of 1 */
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	relief_patch_cache_touch(c, 5, 10);
	assert_int_equal(relief_patch_cache_request(c, 2, 0), 0);
	assert_int_equal(relief_patch_cache_flush(c, 10), -ENOSPC); /* 1 has a child, 5 is in use */
	assert_int_equal(relief_patch_cache_state(c, 1), RELIEF_PATCH_RESIDENT);
	assert_int_equal(relief_patch_cache_flush(c, 20), 0);      /* 5 is old now: it goes, 1 stays */
	assert_int_equal(relief_patch_cache_state(c, 5), RELIEF_PATCH_ABSENT);
	assert_int_equal(relief_patch_cache_state(c, 1), RELIEF_PATCH_RESIDENT);
	assert_int_equal(relief_patch_cache_state(c, 2), RELIEF_PATCH_RESIDENT);
	assert_tree_consistent(c, f);
	relief_patch_cache_destroy(c);

	/* More requests than staging slots while no layer can be had: the slots fill with
	 * decoded patches waiting for a layer and the other requests wait behind them. Flush
	 * says so (-ENOSPC) instead of waiting for workers that cannot go on (it did wait
	 * forever: a 4097 x 4097 terrain's full-resolution view in a 64 MiB cache). */
	struct relief_patch_cache_options jam = { .budget_bytes = 64ull << 20, .max_layers = 1, .staging_slots = 2 };
	assert_int_equal(relief_patch_cache_create(vk, f, &jam, NULL, &c), 0);
	relief_patch_cache_request(c, 0, 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	relief_patch_cache_touch(c, 0, 1);
	for (uint32_t id = 1; id < 5; id++)
		assert_int_equal(relief_patch_cache_request(c, id, 0), 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), -ENOSPC);
	relief_patch_cache_stats(c, &s);
	assert_int_equal(s.used, 1);
	assert_int_equal(s.queue_entries, 2); /* two requests behind the two slots */
	assert_int_equal(relief_patch_cache_state(c, 0), RELIEF_PATCH_RESIDENT);
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

/* Waits (up to 10 s) until the workers have entropy-decoded n patches that no update has
 * taken yet, so that the next update sees them all. */
static void wait_for_symbols(struct relief_patch_cache *c, uint32_t n)
{
	struct relief_patch_cache_stats s;
	for (int ms = 0; ms < 10000; ms++) {
		relief_patch_cache_stats(c, &s);
		if (s.waiting == n)
			break;
		usleep(1000);
	}
	assert_int_equal(s.waiting, n);
}

/* A layer is never taken from a patch whose decode is in flight. With one patch per batch,
 * one update fills two batches; the pool is full, so both take a layer from an old
 * resident patch, and the second must not take the first one's: that patch has never been
 * drawn, so it looks the least recently used of all. */
static void test_eviction_spares_in_flight(void **state)
{
	struct terrain t;
	terrain_open(&t, DEM_PUGET, 129, 2.0);
	struct relief_file *f = t.f;
	struct relief_patch_cache_options o = {
		.budget_bytes = 64ull << 20, .max_layers = 3, .keep_frames = 1, .batch = 1,
	};
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, f, &o, &gpu_test_log, &c), 0);
	relief_patch_cache_request(c, 0, 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	assert_int_equal(relief_patch_cache_request(c, 1, 0), 0);
	assert_int_equal(relief_patch_cache_request(c, 2, 1), 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), 0); /* the pool is full: 0, 1, 2 */
	assert_int_equal(relief_patch_cache_request(c, 3, 0), 0);
	assert_int_equal(relief_patch_cache_request(c, 4, 1), 0);
	wait_for_symbols(c, 2); /* both decoded by the worker before one update */
	assert_int_equal(relief_patch_cache_update(c, 10), 0); /* two batches submitted */
	assert_int_equal(relief_patch_cache_flush(c, 10), 0);
	for (uint32_t id = 1; id <= 4; id++)
		assert_int_equal(relief_patch_cache_state(c, id), id <= 2 ? RELIEF_PATCH_ABSENT : RELIEF_PATCH_RESIDENT);
	assert_tree_consistent(c, f);
	assert_patch_exact(c, f, 3);
	assert_patch_exact(c, f, 4);
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

/* Closest first, each patch once: with one staging slot, patches are decoded one at a time
 * in the worker's order. The first request may be taken before the others arrive; the
 * rest must follow their priorities. Repeated requests decode nothing twice. */
/* Puget Sound in 129-sample patches, and a cache with options o holding the root. */
static struct relief_patch_cache *cache_with_root(struct terrain *t, const struct relief_patch_cache_options *o)
{
	terrain_open(t, DEM_PUGET, 129, 1.0);
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, t->f, o, NULL, &c), 0);
	relief_patch_cache_request(c, 0, 0);
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	return c;
}

static void test_priority_and_dedup(void **state)
{
	struct terrain t;
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20, .staging_slots = 1, .batch = 1 };
	struct relief_patch_cache *c = cache_with_root(&t, &o);
	float prio[5] = { 0, 40, 10, 30, 20 }; /* for ids 1..4 */
	for (int rep = 0; rep < 3; rep++)
		for (uint32_t id = 1; id <= 4; id++)
			assert_int_equal(relief_patch_cache_request(c, id, prio[id]), 0);
	/* A second view, nearer to patch 3, asks for it again: it now comes before 2 and 4.
	 * (With one staging slot the worker holds at most one patch until the first update.) */
	assert_int_equal(relief_patch_cache_request(c, 3, 1), 0);
	assert_int_equal(relief_patch_cache_request(c, 2, 50), 0); /* a farther view changes nothing */
	prio[3] = 1;
	uint32_t order[4], n = 0;
	/* Bounded: a patch that never becomes resident fails the test instead of hanging it. */
	for (int spins = 0; n < 4; spins++) {
		assert_true(spins < 50000); /* 10 s of 200 us naps */
		assert_true(relief_patch_cache_update(c, 1) >= 0);
		for (uint32_t id = 1; id <= 4; id++) {
			bool seen = false;
			for (uint32_t k = 0; k < n; k++)
				seen |= order[k] == id;
			if (!seen && relief_patch_cache_state(c, id) == RELIEF_PATCH_RESIDENT)
				order[n++] = id;
		}
		usleep(200);
	}
	for (uint32_t k = 2; k < 4; k++)
		assert_true(prio[order[k - 1]] < prio[order[k]]);
	struct relief_patch_cache_stats s;
	relief_patch_cache_stats(c, &s);
	assert_int_equal(s.decoded, 5); /* 12 requests, 4 patches (and the root) */
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

/* A patch whose symbols wait for a layer is served by its most urgent request: with one
 * layer besides the root's, patches 1, 2 and 3 (priorities 10, 20, 30) are decoded and 1
 * takes the layer; a nearer view then asks for 3 again (priority 1); once 1 is no longer
 * used, its layer goes to 3, not to 2. (Negative control, run by hand: with the priority
 * of a decoded patch left as it was queued, 2 takes it.) */
static void test_waiting_patch_moves_up(void **state)
{
	struct terrain t;
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20, .max_layers = 2, .keep_frames = 1 };
	struct relief_patch_cache *c = cache_with_root(&t, &o);
	for (uint32_t id = 1; id <= 3; id++)
		assert_int_equal(relief_patch_cache_request(c, id, 10.0f * (float)id), 0);
	struct relief_patch_cache_stats s = { 0 };
	for (int spins = 0; relief_patch_cache_state(c, 1) != RELIEF_PATCH_RESIDENT || s.waiting < 2; spins++) {
		assert_true(spins < 50000); /* 10 s of 200 us naps */
		assert_true(relief_patch_cache_update(c, 1) >= 0);
		relief_patch_cache_stats(c, &s);
		usleep(200);
	}
	assert_int_equal(relief_patch_cache_state(c, 3), RELIEF_PATCH_DECODING);
	assert_int_equal(relief_patch_cache_request(c, 3, 1.0f), 0);
	for (int spins = 0; relief_patch_cache_state(c, 3) != RELIEF_PATCH_RESIDENT; spins++) {
		assert_true(spins < 50000);
		assert_true(relief_patch_cache_update(c, 10) >= 0);
		usleep(200);
	}
	assert_int_equal(relief_patch_cache_state(c, 1), RELIEF_PATCH_ABSENT);
	assert_int_equal(relief_patch_cache_state(c, 2), RELIEF_PATCH_DECODING);
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

/* The request queue stays bounded while the worker cannot take from it: one staging slot,
 * held by a patch that no layer will ever be free for (the only layer holds the root), and
 * three queued patches asked for again 30,000 times each, more urgently every time (a
 * camera closing in). Negative control, run by hand: without dropping stale entries the
 * queue holds 90,003. */
static void test_queue_stays_bounded(void **state)
{
	struct terrain t;
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20, .max_layers = 1, .staging_slots = 1 };
	struct relief_patch_cache *c = cache_with_root(&t, &o);
	for (uint32_t id = 1; id <= 4; id++)
		assert_int_equal(relief_patch_cache_request(c, id, 100.0f), 0);
	struct relief_patch_cache_stats s = { 0 };
	for (int spins = 0; s.waiting < 1; spins++) { /* the worker has taken one and stalls */
		assert_true(spins < 50000);
		assert_true(relief_patch_cache_update(c, 1) >= 0);
		relief_patch_cache_stats(c, &s);
		usleep(200);
	}
	for (int k = 1; k <= 30000; k++)
		for (uint32_t id = 1; id <= 4; id++)
			assert_int_equal(relief_patch_cache_request(c, id, 100.0f - 0.001f * (float)k), 0);
	assert_true(relief_patch_cache_update(c, 2) >= 0);
	relief_patch_cache_stats(c, &s);
	print_message("%u queue entries for 3 queued patches after 90,000 more urgent requests; %u waiting for a layer\n",
	              s.queue_entries, s.waiting);
	assert_int_equal(s.waiting, 1);
	assert_true(s.queue_entries >= 3 && s.queue_entries <= 2 * 3 + 256 + 1);
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

static unsigned logged_errors;
static char last_error[512];
static void count_log(void *data, enum relief_log_level level, const char *fmt, va_list ap)
{
	if (level == RELIEF_LOG_ERROR) {
		logged_errors++;
		vsnprintf(last_error, sizeof(last_error), fmt, ap);
	}
}

/* The one message names the file and the patch. */
static void expect_bad_message(const char *file, uint32_t id)
{
	char want[64];
	snprintf(want, sizeof(want), ": patch %u (level ", id);
	if (!strstr(last_error, file) || !strstr(last_error, want))
		fail_msg("message '%s' does not name '%s' and patch %u", last_error, file, id);
}

/* A corrupt patch at level vl, position (vx, vy) of Puget Sound: it is marked bad once,
 * and every patch below it, requested (by load_all) while it was still queued, is dropped
 * when its parent turns out bad or was dropped in turn, and is refused with -EIO later. */
static void check_corrupt_patch(uint32_t vl, uint32_t vx, uint32_t vy)
{
	struct terrain t;
	terrain_open(&t, DEM_PUGET, 129, 1.0);
	struct relief_file *f = t.f;
	uint32_t victim = relief_patch_id(vl, vx, vy);
	struct relief_patch_record r;
	relief_file_record(f, victim, &r);
	t.img[f->hdr.data_offset + r.offset + r.size / 2] ^= 0x40; /* the stream's CRC no longer matches */
	struct relief_logger counter = { count_log, NULL };
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20 };
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, f, &o, &counter, &c), 0);
	logged_errors = 0;
	load_all(c, f, 1); /* nothing has run when the victim's descendants are requested */
	assert_int_equal(relief_patch_cache_state(c, victim), RELIEF_PATCH_BAD);
	assert_int_equal(logged_errors, 1);
	expect_bad_message("(memory image)", victim);
	/* Asking again neither retries nor logs again; its parent and neighbours are fine. */
	assert_int_equal(relief_patch_cache_request(c, victim, 0), -EIO);
	assert_int_equal(relief_patch_cache_flush(c, 2), 0);
	assert_int_equal(logged_errors, 1);
	uint32_t below = 0;
	for (uint32_t id = 0; id < f->hdr.patch_count; id++) {
		uint32_t l, px, py;
		assert_true(relief_patch_coords(&f->layout, id, &l, &px, &py));
		if (l > vl && px >> (l - vl) == vx && py >> (l - vl) == vy) {
			below++;
			assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_ABSENT);
			assert_int_equal(relief_patch_cache_request(c, id, 0), -EIO);
		} else if (id != victim) {
			assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_RESIDENT);
		}
	}
	assert_int_equal(below, vl == 2 ? 4 : 4 + 16);
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

static void test_corrupt_patch(void **state) { check_corrupt_patch(2, 1, 2); }
/* two levels below: the children are dropped for the bad victim, the grandchildren for them */
static void test_corrupt_patch_subtree(void **state) { check_corrupt_patch(1, 0, 1); }

/* Rewrites patch id's stream so that it decodes (its symbols are valid) to a value beyond
 * the codec's range: its labels, its residuals all 0 but one of 2^27. Signed again (the
 * stream's, the index's and the header's CRCs), so that only reconstruction can tell;
 * reopens t->f. */
static void poison_stream(struct terrain *t, uint32_t id)
{
	const struct relief_patch_geom *g = &t->f->layout.geom;
	struct relief_window win;
	relief_file_window(t->f, id, &win);
	uint8_t *stream = malloc(t->f->max_stream), *out;
	int8_t *labels = malloc(g->n_labels);
	int32_t *residuals = calloc(g->n_residuals, sizeof(int32_t));
	size_t size, out_size;
	assert_int_equal(relief_file_read_stream(t->f, id, stream, &size), 0);
	assert_int_equal(relief_patch_decode_symbols(g, id == 0, &win, stream, size, labels, residuals), 0);
	memset(residuals, 0, sizeof(int32_t) * g->n_residuals);
	residuals[g->n_residuals / 2] = 1 << 27; /* a centre sample inside the patch */
	assert_int_equal(relief_patch_encode(g, id == 0, &win, labels, residuals, &out, &out_size), 0);

	struct relief_header h;
	struct relief_layout lay;
	char err[256];
	assert_int_equal(relief_header_parse(t->img, t->size, &h, &lay, err, sizeof(err)), 0);
	assert_int_not_equal(relief_index_entry(&h, id), UINT32_MAX);
	uint8_t *rec = t->img + h.index_offset + (uint64_t)relief_index_entry(&h, id) * RELIEF_INDEX_RECORD_SIZE;
	struct relief_patch_record r;
	relief_record_read(rec, h.version, &r);
	assert_true(out_size <= r.size); /* fits where the old stream was */
	memcpy(t->img + h.data_offset + r.offset, out, out_size);
	r.size = (uint32_t)out_size;
	r.crc = relief_crc32c(0, out, out_size);
	relief_record_write(&r, rec);
	h.index_crc = relief_crc32c(0, t->img + h.index_offset, (uint64_t)h.index_records * RELIEF_INDEX_RECORD_SIZE);
	relief_header_write(&h, t->img);
	relief_file_close(t->f);
	assert_int_equal(relief_file_open_memory(t->img, t->size, &t->f, err, sizeof(err)), 0);
	free(stream);
	free(out);
	free(labels);
	free(residuals);
}

/* Levels decode in a chain within one update (a child's batch follows its parent's, in
 * flight), and a parent that the GPU finds corrupt takes its children, decoded from it in
 * the meantime, with it. The victim, a level-1 patch of Puget Sound, has a valid stream
 * whose values leave the codec's range (poison_stream()), so the worker passes it and only
 * the decode pass's range checks catch it. */
static void test_corrupt_parent_in_flight(void **state)
{
	struct terrain t;
	terrain_open(&t, DEM_PUGET, 129, 1.0);
	const uint32_t victim = relief_patch_id(1, 0, 1);
	poison_stream(&t, victim);
	struct relief_decoder dec; /* the worker's stage passes, the CPU reference does not */
	assert_int_equal(relief_decoder_init(&dec, t.f), 0);
	assert_int_equal(relief_decoder_symbols(&dec, victim), 0);
	relief_decoder_finish(&dec);
	int32_t *blocks = NULL;
	assert_int_equal(relief_decode_level_blocks(t.f, 1, 1, &blocks), -EBADMSG);
	free(blocks);
	struct relief_file *f = t.f;
	struct relief_logger counter = { count_log, NULL };
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20, .staging_slots = 128 };
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, f, &o, &counter, &c), 0);
	logged_errors = 0;
	for (uint32_t id = 0; id < f->hdr.patch_count; id++)
		assert_int_equal(relief_patch_cache_request(c, id, (float)id), 0);
	wait_for_symbols(c, f->hdr.patch_count); /* every stream decoded before the first update */
	assert_int_equal(relief_patch_cache_update(c, 1), 0);
	struct relief_patch_cache_stats s;
	relief_patch_cache_stats(c, &s);
	assert_int_equal(s.batches, 3); /* root, level 1, level 2: one per free batch */
	assert_int_equal(relief_patch_cache_flush(c, 1), 0);
	assert_int_equal(relief_patch_cache_state(c, victim), RELIEF_PATCH_BAD);
	assert_int_equal(logged_errors, 1); /* the victim only: its children are not corrupt */
	expect_bad_message("(memory image)", victim);
	uint32_t below = 0;
	for (uint32_t id = 1; id < f->hdr.patch_count; id++) {
		uint32_t l, px, py;
		relief_patch_coords(&f->layout, id, &l, &px, &py);
		if (l > 1 && px >> (l - 1) == 0 && py >> (l - 1) == 1) {
			below++;
			assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_ABSENT);
			assert_int_equal(relief_patch_cache_request(c, id, 0), -EIO);
		} else if (id != victim) {
			assert_int_equal(relief_patch_cache_state(c, id), RELIEF_PATCH_RESIDENT);
		}
	}
	assert_int_equal(below, 4 + 16);
	assert_tree_consistent(c, f);
	relief_patch_cache_stats(c, &s);
	assert_int_equal(s.bad, 1);
	assert_int_equal(s.decoded, f->hdr.patch_count - 1 - below);
	relief_patch_cache_destroy(c);
	terrain_close(&t);
	gpu_test_assert_clean(vk);
}

/* The file shrinks under a running cache: the lost patches go bad, nothing crashes. */
static void test_truncated_at_run_time(void **state)
{
	uint8_t *img;
	size_t size;
	pack_dem(DEM_ALPS, 129, 1.0, &img, &size);
	char path[] = "/tmp/relief-cache-XXXXXX";
	int fd = mkstemp(path);
	assert_true(fd >= 0);
	assert_int_equal(write(fd, img, size), (ssize_t)size);
	close(fd);
	struct relief_file *f;
	char err[256];
	assert_int_equal(relief_file_open(path, &f, err, sizeof(err)), 0);
	struct relief_logger counter = { count_log, NULL };
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20 };
	struct relief_patch_cache *c;
	assert_int_equal(relief_patch_cache_create(vk, f, &o, &counter, &c), 0);
	assert_int_equal(truncate(path, (off_t)(f->hdr.data_offset + f->hdr.data_size / 2)), 0);
	unlink(path);
	logged_errors = 0;
	load_all(c, f, 1);
	uint32_t bad = 0, resident = 0;
	for (uint32_t id = 0; id < f->hdr.patch_count; id++) {
		bad += relief_patch_cache_state(c, id) == RELIEF_PATCH_BAD;
		resident += relief_patch_cache_state(c, id) == RELIEF_PATCH_RESIDENT;
	}
	print_message("truncated file: %u patches resident, %u refused\n", resident, bad);
	assert_true(bad > 0 && resident > 0);
	assert_int_equal(logged_errors, bad);
	if (!strstr(last_error, path) || !strstr(last_error, "missing from the file"))
		fail_msg("message '%s' does not name %s and the cause", last_error, path);
	relief_patch_cache_destroy(c);
	relief_file_close(f);
	free(img);
	gpu_test_assert_clean(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bit_exact_puget),
		cmocka_unit_test(test_bit_exact_alps),
		cmocka_unit_test(test_bit_exact_lux),
		cmocka_unit_test(test_bit_exact_lux_257),
		cmocka_unit_test(test_budget_and_eviction),
		cmocka_unit_test(test_eviction_spares_in_flight),
		cmocka_unit_test(test_priority_and_dedup),
		cmocka_unit_test(test_waiting_patch_moves_up),
		cmocka_unit_test(test_queue_stays_bounded),
		cmocka_unit_test(test_corrupt_patch),
		cmocka_unit_test(test_corrupt_patch_subtree),
		cmocka_unit_test(test_corrupt_parent_in_flight),
		cmocka_unit_test(test_truncated_at_run_time),
	};
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
