/* The container under attack: truncation, bit flips, hostile but checksum-valid headers
 * and records. Every case must end in a clear error (never a crash, never an
 * out-of-bounds read: this test also runs under ASan), and a damaged patch stream must not
 * make the rest of the file unreadable. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdbool.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../data_load.h"
#include "crc32c.h"
#include "decode.h"
#include "format.h"
#include "le.h"
#include "pack.h"

static uint8_t *img;
static size_t img_size;

static int setup(void **state)
{
	struct relief_dem dem;
	test_dem_load(DEM_LUX, &dem);
	struct relief_pack_options o = { .patch = 65, .ratio = 2, .tolerance = 1.0 };
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &img_size, NULL), 0);
	relief_dem_finish(&dem);
	return 0;
}

static int teardown(void **state)
{
	free(img);
	return 0;
}

static int open_copy(const uint8_t *buf, size_t size, char *err, size_t n)
{
	uint8_t *copy = malloc(size ? size : 1); /* exact-size heap copy: ASan sees any overread */
	memcpy(copy, buf, size);
	struct relief_file *f = NULL;
	int ret = relief_file_open_memory(copy, size, &f, err, n);
	if (ret == 0) {
		/* Whatever opened must decode or fail cleanly. */
		uint32_t w, h;
		relief_level_extent(&f->hdr, f->hdr.levels - 1, &w, &h);
		float *hh = malloc(sizeof(float) * w * h);
		int r = relief_decode_level(f, f->hdr.levels - 1, 1, hh, NULL);
		assert_true(r == 0 || r == -EBADMSG);
		free(hh);
		relief_file_close(f);
	}
	free(copy);
	return ret;
}

static void test_valid_file_opens(void **state)
{
	char err[256] = "";
	assert_int_equal(open_copy(img, img_size, err, sizeof(err)), 0);
}

static void test_truncation(void **state)
{
	char err[256];
	for (size_t n = 0; n < img_size; n += n < 600 ? 1 : 97) {
		err[0] = '\0';
		assert_int_equal(open_copy(img, n, err, sizeof(err)), -EBADMSG);
		assert_true(err[0] != '\0');
	}
	assert_int_equal(open_copy(img, img_size - 1, err, sizeof(err)), -EBADMSG);
	assert_non_null(strstr(err, "truncated"));
}

/* Any single flipped bit outside the patch streams is caught at open by a checksum;
 * inside a stream, open succeeds and that patch's CRC check refuses it. */
static void test_bit_flips(void **state)
{
	struct relief_file *f;
	char err[256];
	assert_int_equal(relief_file_open_memory(img, img_size, &f, err, sizeof(err)), 0);
	uint64_t data_offset = f->hdr.data_offset;
	uint32_t patches = f->hdr.patch_count;
	/* Covered bytes: the header and every section; the rest is alignment padding. */
	const struct relief_header *h = &f->hdr;
	uint64_t sections[5][2] = {
		{ 0, RELIEF_HEADER_SIZE },
		{ h->index_offset, h->index_offset + (uint64_t)h->index_records * RELIEF_INDEX_RECORD_SIZE },
		{ h->block_errors_offset,
		  h->block_errors_offset + h->block_patches * relief_block_bytes_per_patch(h->version, h->patch_size) },
		{ h->masks_offset, h->masks_offset + h->masks_size },
		{ h->crs_offset, h->crs_offset + h->crs_size },
	};
	relief_file_close(f);
	size_t padding = 0;
	uint8_t *copy = malloc(img_size);
	for (size_t i = 0; i < img_size; i += i < data_offset ? 1 : 13) {
		memcpy(copy, img, img_size);
		copy[i] ^= (uint8_t)(1u << (i % 8));
		int ret = relief_file_open_memory(copy, img_size, &f, err, sizeof(err));
		if (i < data_offset) {
			bool covered = false;
			for (int k = 0; k < 5; k++)
				covered |= i >= sections[k][0] && i < sections[k][1];
			if (covered) {
				assert_int_equal(ret, -EBADMSG);
			} else {
				padding++;
				if (ret == 0)
					relief_file_close(f);
			}
			continue;
		}
		assert_int_equal(ret, 0);
		int bad = 0;
		uint8_t *sbuf = malloc(f->max_stream);
		for (uint32_t id = 0; id < patches; id++) {
			size_t n;
			int r = relief_file_read_stream(f, id, sbuf, &n);
			bad += r == -EBADMSG;
		}
		free(sbuf);
		assert_int_equal(bad, 1);
		relief_file_close(f);
	}
	assert_true(padding < 40); /* at most 7 bytes after each of the 5 sections */
	free(copy);
}

/* Rewrites a header field and fixes the header CRC, so that field validation is what
 * must catch it. */
static int open_with_u32(size_t off, uint32_t v, char *err, size_t n)
{
	uint8_t *copy = malloc(img_size);
	memcpy(copy, img, img_size);
	le_put_u32(copy + off, v);
	le_put_u32(copy + 508, relief_crc32c(0, copy, 508));
	int ret = open_copy(copy, img_size, err, n);
	free(copy);
	return ret;
}

static int open_with_f64(size_t off, double v, char *err, size_t n)
{
	uint8_t *copy = malloc(img_size);
	memcpy(copy, img, img_size);
	le_put_f64(copy + off, v);
	le_put_u32(copy + 508, relief_crc32c(0, copy, 508));
	int ret = open_copy(copy, img_size, err, n);
	free(copy);
	return ret;
}

static void expect(int ret, const char *err, const char *needle)
{
	assert_int_equal(ret, -EBADMSG);
	if (!strstr(err, needle))
		fail_msg("error '%s' does not mention '%s'", err, needle);
}

static void test_hostile_header_fields(void **state)
{
	char err[256];
	expect(open_with_u32(8, RELIEF_FORMAT_VERSION + 1, err, sizeof(err)), err, "version");
	expect(open_with_u32(8, 1, err, sizeof(err)), err, "version"); /* before the class contexts */
	expect(open_with_u32(16, 100, err, sizeof(err)), err, "patch size");
	expect(open_with_u32(20, 17, err, sizeof(err)), err, "level count");
	expect(open_with_u32(20, 0, err, sizeof(err)), err, "level count");
	expect(open_with_u32(24, 5, err, sizeof(err)), err, "ratio");
	expect(open_with_u32(32, 0, err, sizeof(err)), err, "extent");
	expect(open_with_u32(32, 1u << 30, err, sizeof(err)), err, "extent");
	expect(open_with_u32(40, 1025, err, sizeof(err)), err, "grid size");
	expect(open_with_u32(48, 4, err, sizeof(err)), err, "patch count");
	expect(open_with_u32(48, 0xffffffffu, err, sizeof(err)), err, "patch count");
	expect(open_with_u32(44, 9, err, sizeof(err)), err, "units");
	expect(open_with_u32(196, 1, err, sizeof(err)), err, "flags");
	expect(open_with_f64(56, 0.0, err, sizeof(err)), err, "tolerance");
	expect(open_with_f64(56, NAN, err, sizeof(err)), err, "tolerance");
	expect(open_with_f64(64, INFINITY, err, sizeof(err)), err, "origin");
	expect(open_with_f64(80, -1.0, err, sizeof(err)), err, "spacing");
	expect(open_with_f64(96, 1e300, err, sizeof(err)), err, "height range");
	expect(open_with_f64(200 + 8, 3.0, err, sizeof(err)), err, "level 1 tolerance");
	/* The block error unit (version 8): at least tolerance / 64, finite, at most 1e6 m. */
	expect(open_with_f64(344, 0.0, err, sizeof(err)), err, "block error unit");
	expect(open_with_f64(344, NAN, err, sizeof(err)), err, "block error unit");
	expect(open_with_f64(344, 1e7, err, sizeof(err)), err, "block error unit");
	expect(open_with_f64(344, -1.0, err, sizeof(err)), err, "block error unit");
	/* Sections out of bounds or overlapping. */
	expect(open_with_u32(120, 7, err, sizeof(err)), err, "index");
	expect(open_with_u32(120, 0xfffffff8u, err, sizeof(err)), err, "index");
	expect(open_with_u32(128, 512, err, sizeof(err)), err, "block error");
	expect(open_with_u32(160, 0xfffffff0u, err, sizeof(err)), err, "data section");
	expect(open_with_u32(176, 1u << 31, err, sizeof(err)), err, "CRS");
	/* A reserved byte set. */
	expect(open_with_u32(400, 1, err, sizeof(err)), err, "reserved");
	expect(open_with_u32(336, 0, err, sizeof(err)), err, "block records"); /* version 5's count */
	expect(open_with_u32(336, 1000000, err, sizeof(err)), err, "block records");
	expect(open_with_u32(352, 1, err, sizeof(err)), err, "reserved"); /* just after the unit */
}

/* Rewrites index record `id` (fixing the index CRC): with `edit`, or when edit is NULL by
 * putting `word` at byte `at` of the record. */
static int open_with_record_bytes(uint32_t id, void (*edit)(struct relief_patch_record *), size_t at, uint32_t word,
                                  char *err, size_t n)
{
	uint8_t *copy = malloc(img_size);
	memcpy(copy, img, img_size);
	struct relief_file *f;
	assert_int_equal(relief_file_open_memory(img, img_size, &f, err, n), 0);
	uint64_t idx = f->hdr.index_offset;
	uint32_t count = f->hdr.index_records, rec = relief_index_entry(&f->hdr, id);
	relief_file_close(f);
	assert_int_not_equal(rec, UINT32_MAX);
	struct relief_patch_record r;
	relief_record_read(copy + idx + (uint64_t)rec * RELIEF_INDEX_RECORD_SIZE, RELIEF_FORMAT_VERSION, &r);
	if (edit) {
		edit(&r);
		relief_record_write(&r, copy + idx + (uint64_t)rec * RELIEF_INDEX_RECORD_SIZE);
	} else {
		le_put_u32(copy + idx + (uint64_t)rec * RELIEF_INDEX_RECORD_SIZE + at, word);
	}
	le_put_u32(copy + 180, relief_crc32c(0, copy + idx, (size_t)count * RELIEF_INDEX_RECORD_SIZE));
	le_put_u32(copy + 508, relief_crc32c(0, copy, 508));
	int ret = open_copy(copy, img_size, err, n);
	free(copy);
	return ret;
}

static int open_with_record(uint32_t id, void (*edit)(struct relief_patch_record *), char *err, size_t n)
{
	return open_with_record_bytes(id, edit, 0, 0, err, n);
}

static void rec_huge_offset(struct relief_patch_record *r) { r->offset = UINT64_MAX - 3; }
static void rec_huge_size(struct relief_patch_record *r) { r->size = UINT32_MAX; }
static void rec_bad_flags(struct relief_patch_record *r) { r->flags |= 1u << 7; }
static void rec_nan_error(struct relief_patch_record *r) { r->error = NAN; }
static void rec_negative_drawn(struct relief_patch_record *r) { r->draw_error = -1.0f; }
static void rec_inf_drawn(struct relief_patch_record *r) { r->draw_error = INFINITY; }
static void rec_inverted_range(struct relief_patch_record *r) { r->height_min = r->height_max + 1; }
static void rec_empty_root(struct relief_patch_record *r) { r->flags = RELIEF_PATCH_EMPTY; r->size = 0; r->offset = 0; }
static void rec_bad_mask(struct relief_patch_record *r) { r->flags |= RELIEF_PATCH_MASKED; r->mask_offset = 1u << 30; r->mask_size = 4; }

static void test_hostile_records(void **state)
{
	char err[256];
	expect(open_with_record(1, rec_huge_offset, err, sizeof(err)), err, "outside the data section");
	expect(open_with_record(2, rec_huge_size, err, sizeof(err)), err, "outside the data section");
	expect(open_with_record(3, rec_bad_flags, err, sizeof(err)), err, "unknown flags");
	expect(open_with_record(1, rec_nan_error, err, sizeof(err)), err, "error bound");
	expect(open_with_record(1, rec_negative_drawn, err, sizeof(err)), err, "drawn error");
	expect(open_with_record(2, rec_inf_drawn, err, sizeof(err)), err, "drawn error");
	expect(open_with_record_bytes(1, NULL, 44, 1, err, sizeof(err)), err, "reserved record bytes");
	expect(open_with_record(1, rec_inverted_range, err, sizeof(err)), err, "height range");
	expect(open_with_record(0, rec_empty_root, err, sizeof(err)), err, "root");
	expect(open_with_record(1, rec_bad_mask, err, sizeof(err)), err, "mask");
}

/* A block height range whose low end is above its high end (the block section's CRC
 * fixed) is refused, naming the patch and block; the file as packed has none. */
static void test_inverted_block_range(void **state)
{
	char err[256];
	struct relief_file *f;
	assert_int_equal(relief_file_open_memory(img, img_size, &f, err, sizeof(err)), 0);
	const struct relief_header h = f->hdr;
	const size_t per = relief_block_bytes_per_patch(h.version, h.patch_size);
	const size_t errors = relief_block_errors_per_patch(h.patch_size); /* the range bytes follow */
	float *rg = malloc(sizeof(float) * relief_block_ranges_per_patch(h.patch_size));
	relief_file_block_ranges(f, 1, rg);
	for (size_t i = 0; i < relief_block_ranges_per_patch(h.patch_size); i += 2)
		assert_true(rg[i] <= rg[i + 1]);
	free(rg);
	const size_t slot1 = f->block_slot[1];
	assert_true(slot1 < h.block_patches);
	relief_file_close(f);
	uint8_t *copy = malloc(img_size);
	memcpy(copy, img, img_size);
	uint8_t *b = copy + h.block_errors_offset + slot1 * per + errors + 5; /* patch 1, block 5 */
	*b = 0x3c; /* low code 12, high code 3 */
	le_put_u32(copy + 184, relief_crc32c(0, copy + h.block_errors_offset, (size_t)h.block_patches * per));
	le_put_u32(copy + 508, relief_crc32c(0, copy, 508));
	expect(open_copy(copy, img_size, err, sizeof(err)), err, "block 5's height range is inverted");
	free(copy);
}

static void test_open_from_disk(void **state)
{
	char path[] = "/tmp/relief-test-XXXXXX";
	int fd = mkstemp(path);
	assert_true(fd >= 0);
	assert_int_equal(write(fd, img, img_size), (ssize_t)img_size);
	close(fd);
	int fds = test_count_fds();
	struct relief_file *f;
	char err[256];
	assert_int_equal(relief_file_open(path, &f, err, sizeof(err)), 0);
	assert_int_equal(f->hdr.width, 95);
	relief_file_close(f);
	assert_int_equal(test_count_fds(), fds);
	truncate(path, 700);
	assert_int_equal(relief_file_open(path, &f, err, sizeof(err)), -EBADMSG);
	unlink(path);
	assert_int_equal(relief_file_open(path, &f, err, sizeof(err)), -ENOENT);
	assert_int_equal(relief_file_open("/tmp", &f, err, sizeof(err)), -EINVAL);
	assert_int_equal(test_count_fds(), fds);
}

/* Format version 2 is still read (and version 3, which differs from it only in the
 * streams). tests/data/alps-crop-140x100-v2.relief was written by
 * the last version-2 packer (commit "codec: branch-free residual sign ...") from the
 * Mont Blanc crop next to it (`relief pack alps-crop-140x100.f32 --raw-size 140x100
 * --raw-type float32 --spacing 92.7 --tolerance 1 --patch 65`). Version 3 skips padding
 * symbols but quantises alike, so both must decode to the same heights and masks at every
 * level, and the version-3 streams must be smaller (those at the east and south edges
 * skip the padding beyond 140 x 100 in the 257 x 257 grid). The file written now is
 * version 4 (v3 below), whose streams are version 3's. */
/* The Mont Blanc crop packed now as format `version` (0: the current one; *image, *size,
 * opened as *now) and the older file `old` in tests/data packed from it with the same
 * options (opened as *then; NULL: none). */
static void open_crop_pair(const char *old, uint32_t version, uint8_t **image, size_t *size,
                           struct relief_file **then, struct relief_file **now)
{
	struct dem_import_options o = { .has_spacing = true, .spacing = 92.7, .raw_width = 140, .raw_height = 100,
	                                .raw_type = "float32" };
	struct relief_dem dem;
	char err[512] = "";
	if (dem_import(test_data("alps-crop-140x100.f32"), &o, &dem, err, sizeof(err)) < 0)
		fail_msg("import: %s", err);
	struct relief_pack_options po = { .patch = 65, .ratio = 2, .tolerance = 1.0, .version = version };
	assert_int_equal(relief_pack_memory(&dem, &po, image, size, NULL), 0);
	relief_dem_finish(&dem);
	if (old && relief_file_open(test_data(old), then, err, sizeof(err)) < 0)
		fail_msg("%s: %s", old, err);
	assert_int_equal(relief_file_open_memory(*image, *size, now, err, sizeof(err)), 0);
}

/* Every level of a and b decodes to the same heights (NaN where no-data, in both) and the
 * same validity. */
static void assert_same_levels(const struct relief_file *a, const struct relief_file *b)
{
	assert_int_equal(a->hdr.levels, b->hdr.levels);
	for (uint32_t l = 0; l < a->hdr.levels; l++) {
		uint32_t w, h;
		relief_level_extent(&b->hdr, l, &w, &h);
		size_t n = (size_t)w * h;
		float *ha = malloc(sizeof(float) * n), *hb = malloc(sizeof(float) * n);
		uint8_t *ma = malloc(n), *mb = malloc(n);
		assert_int_equal(relief_decode_level(a, l, 1, ha, ma), 0);
		assert_int_equal(relief_decode_level(b, l, 1, hb, mb), 0);
		assert_memory_equal(ha, hb, sizeof(float) * n);
		assert_memory_equal(ma, mb, n);
		free(ha);
		free(hb);
		free(ma);
		free(mb);
	}
}

static void test_version2_still_read(void **state)
{
	uint8_t *v3img;
	size_t v3size;
	struct relief_file *v2, *v3;
	/* version 8: the windows of versions 3 to 8 (version 9 codes a column more) */
	open_crop_pair("alps-crop-140x100-v2.relief", 8, &v3img, &v3size, &v2, &v3);
	assert_int_equal(v2->hdr.version, 2);
	assert_int_equal(v3->hdr.version, 8);
	assert_int_equal(v2->hdr.levels, 3);
	assert_int_equal(v3->hdr.levels, 3);
	struct stat st;
	assert_int_equal(stat(test_data("alps-crop-140x100-v2.relief"), &st), 0);
	print_message("version 2: %lld bytes (streams %llu), version %u: %zu bytes (streams %llu)\n", (long long)st.st_size,
	              (unsigned long long)v2->hdr.data_size, v3->hdr.version, v3size,
	              (unsigned long long)v3->hdr.data_size);
	assert_true(v3->hdr.data_size < v2->hdr.data_size);
	assert_same_levels(v2, v3);
	/* Block errors: version 2 stored them against the patch's own surface, and reading adds
	 * Err(P) (a bound against the original); the current version measures them against
	 * the finest decoded surface, which is within the finest tolerance of the original.
	 * So every current bound is at most the old one plus that tolerance (both rounded up
	 * by the byte code, at most 2^(1/16) above what was measured, never below one unit). */
	const size_t nb = relief_block_errors_per_patch(v2->hdr.patch_size);
	const double unit = v3->hdr.block_error_unit, fin = v2->layout.delta[v2->hdr.levels - 1];
	float *e2 = malloc(sizeof(float) * nb), *e3 = malloc(sizeof(float) * nb);
	double sum2 = 0, sum3 = 0;
	for (uint32_t id = 0; id < v2->hdr.patch_count; id++) {
		struct relief_patch_record r;
		relief_file_record(v2, id, &r);
		if (r.flags & RELIEF_PATCH_EMPTY)
			continue;
		relief_file_block_errors(v2, id, e2);
		relief_file_block_errors(v3, id, e3);
		float rg[2 * 16 * 16];
		relief_file_block_ranges(v2, id, rg);
		for (size_t i = 0; i < relief_block_ranges_per_patch(v2->hdr.patch_size); i += 2) {
			assert_true(rg[i] == r.height_min); /* before version 4: the patch's range */
			assert_true(rg[i + 1] == r.height_max);
		}
		for (size_t i = 0; i < nb; i++) {
			assert_true(e2[i] >= r.error);
			if (e3[i] > fmax(unit, exp2(1.0 / 16) * (e2[i] + fin)))
				fail_msg("patch %u error %zu: %g now, %g + %g before", id, i, e3[i], e2[i], fin);
			if (isfinite(e2[i])) {
				sum2 += e2[i];
				sum3 += e3[i];
			}
		}
	}
	print_message("block errors (finite ones): sum %.1f m against the finest decoded surface, %.1f m as eps_d + Err(P)\n",
	              sum3, sum2);
	assert_true(sum3 < sum2);
	free(e2);
	free(e3);
	relief_file_close(v2);
	relief_file_close(v3);
	free(v3img);
}

/* Records of the same patch from an older file and one packed now: equal but for the drawn
 * error, which files before version 7 do not store. What they read instead must bound the
 * measured one above the finest level (relief_draw_error_bound(): a proof, checked here on
 * real data) and is Err(P) at the finest level (where the selection never uses it). */
static void assert_same_record(const struct relief_file *old, uint32_t id, const struct relief_patch_record *a,
                               const struct relief_patch_record *b)
{
	assert_true(a->offset == b->offset && a->size == b->size && a->crc == b->crc);
	assert_true(a->height_min == b->height_min && a->height_max == b->height_max && a->error == b->error);
	assert_true(a->flags == b->flags && a->mask_offset == b->mask_offset && a->mask_size == b->mask_size);
	uint32_t l, px, py;
	assert_true(relief_patch_coords(&old->layout, id, &l, &px, &py));
	if (old->hdr.version >= 7)
		assert_true(a->draw_error == b->draw_error);
	else if (a->flags & RELIEF_PATCH_EMPTY)
		assert_true(a->draw_error == 0.0f && b->draw_error == 0.0f);
	else if (l + 1 == old->hdr.levels)
		assert_true(a->draw_error == a->error);
	else if (!(a->draw_error >= b->draw_error))
		fail_msg("patch %u (level %u): drawn error %g, above the bound %g from Err(P) %g", id, l, b->draw_error,
		         a->draw_error, a->error);
}

/* Block error bounds of one patch read from an older file (e0) and from one packed now (e1):
 * codes of the same measured errors, each the least of its file's codes at or above the
 * error (relief_block_error_encode(), at most 2^(1/16) above it or one unit), in units
 * that differ from version 8 on (relief_block_error_unit()). An error the older file could
 * not code is +infinity there and finite now. Returns how many of those. */
static uint32_t assert_same_block_bounds(const struct relief_file *old, const struct relief_file *now,
                                         const float *e0, const float *e1, size_t n)
{
	const double u0 = old->hdr.block_error_unit, u1 = now->hdr.block_error_unit;
	const double step = exp2(1.0 / 16) * (1 + 1e-6);
	if (u0 == u1) {
		assert_memory_equal(e0, e1, sizeof(float) * n);
		return 0;
	}
	uint32_t uncoded = 0;
	for (size_t i = 0; i < n; i++) {
		assert_true(isfinite(e1[i]));
		if (isinf(e0[i])) {
			uncoded++;
			continue;
		}
		assert_true((e0[i] == 0) == (e1[i] == 0));
		if (!(e1[i] <= fmax(u1 * (1 + 1e-6), step * e0[i]) && e0[i] <= fmax(u0 * (1 + 1e-6), step * e1[i])))
			fail_msg("block error %zu: %g then (unit %g), %g now (unit %g)", i, e0[i], u0, e1[i], u1);
	}
	return uncoded;
}

/* Every patch of `old` and `now` reads the same: index record, block errors (as codes of
 * the same errors: assert_same_block_bounds()) and ranges, stream. Returns the number of
 * EMPTY patches. */
static uint32_t assert_same_patches(const struct relief_file *old, const struct relief_file *now)
{
	const uint32_t n = old->hdr.patch_count;
	assert_int_equal(now->hdr.patch_count, n);
	assert_int_equal(now->hdr.data_size, old->hdr.data_size);
	const size_t ne = relief_block_errors_per_patch(old->hdr.patch_size);
	const size_t nr = relief_block_ranges_per_patch(old->hdr.patch_size);
	float *e0 = malloc(sizeof(float) * ne), *e1 = malloc(sizeof(float) * ne);
	float *r0 = malloc(sizeof(float) * nr), *r1 = malloc(sizeof(float) * nr);
	uint8_t *s0 = malloc(old->max_stream), *s1 = malloc(now->max_stream);
	uint32_t empty = 0, uncoded = 0;
	for (uint32_t id = 0; id < n; id++) {
		struct relief_patch_record a, b;
		relief_file_record(old, id, &a);
		relief_file_record(now, id, &b);
		assert_same_record(old, id, &a, &b);
		/* the drawn error as measured: only what version 7 on stores */
		assert_true(old->hdr.version >= 7 ? relief_file_measured_draw_error(old, &a) == a.draw_error
		                                  : isinf(relief_file_measured_draw_error(old, &a)));
		assert_true(relief_file_measured_draw_error(now, &b) == b.draw_error);
		empty += !!(a.flags & RELIEF_PATCH_EMPTY);
		relief_file_block_errors(old, id, e0);
		relief_file_block_errors(now, id, e1);
		uncoded += assert_same_block_bounds(old, now, e0, e1, ne);
		relief_file_block_ranges(old, id, r0);
		relief_file_block_ranges(now, id, r1);
		assert_memory_equal(r0, r1, sizeof(float) * nr);
		size_t z0, z1;
		int ra = relief_file_read_stream(old, id, s0, &z0), rb = relief_file_read_stream(now, id, s1, &z1);
		assert_int_equal(ra, rb); /* -ENOENT for both where EMPTY */
		if (ra == 0) {
			assert_int_equal(z0, z1);
			assert_memory_equal(s0, s1, z0);
		}
	}
	print_message("version %u: %u block errors stored as +infinity (none now)\n", old->hdr.version, uncoded);
	free(s0);
	free(s1);
	free(e0);
	free(e1);
	free(r0);
	free(r1);
	return empty;
}

/* Versions 4 to 8 are still read. tests/data/alps-crop-140x100-v4.relief was written by the
 * last version-4 packer (commit 8180fba), alps-crop-140x100-v5.relief by the last version-5
 * packer (commit 620b9bf), alps-crop-140x100-v6.relief by the last version-6 packer (commit
 * 01fc8e7), alps-crop-140x100-v7.relief by the last version-7 packer (commit d90d6fe),
 * alps-crop-140x100-v8.relief by the last version-8 packer (commit d3551bc), all from the
 * Mont Blanc crop with the options of the version-2 file above, and compared with the
 * crop packed now as version 8 (the windows of version 9 code a column more:
 * test_version9_rim() below).
 * Version 5 dropped the block records of EMPTY patches (12 of this file's 21), which read
 * as zero bytes, what version 4 stored for them; version 6 drops their index records too
 * (all 12 lie outside the raster's windows), which read as what earlier versions stored;
 * version 7 adds the drawn error to every index record (assert_same_record()); version 8
 * codes the block errors in a unit of its own (assert_same_block_bounds(): the older files
 * hold 9 errors as +infinity). So the same input packed now reads the same for every patch
 * but those, and the files differ by those records. */
static void test_versions4_to_8_still_read(void **state)
{
	const struct {
		const char *name;
		uint32_t version;
		bool block_records; /* it holds block records for EMPTY patches */
	} olds[] = { { "alps-crop-140x100-v4.relief", 4, true },
	             { "alps-crop-140x100-v5.relief", 5, false },
	             { "alps-crop-140x100-v6.relief", 6, false },
	             { "alps-crop-140x100-v7.relief", 7, false },
	             { "alps-crop-140x100-v8.relief", 8, false } };
	for (size_t i = 0; i < sizeof(olds) / sizeof(olds[0]); i++) {
		uint8_t *img_now;
		size_t size_now;
		struct relief_file *old, *now;
		open_crop_pair(olds[i].name, 8, &img_now, &size_now, &old, &now);
		assert_int_equal(old->hdr.version, olds[i].version);
		assert_int_equal(now->hdr.version, 8);
		assert_int_equal(old->hdr.index_records, olds[i].version < 6 ? old->hdr.patch_count : 21 - 12);
		uint32_t empty = assert_same_patches(old, now);
		assert_int_equal(empty, 12);
		assert_int_equal(old->hdr.block_patches, olds[i].block_records ? old->hdr.patch_count : 21 - empty);
		assert_int_equal(now->hdr.block_patches, 21 - empty);
		assert_int_equal(now->hdr.index_records, 21 - empty);
		struct stat st;
		assert_int_equal(stat(test_data(olds[i].name), &st), 0);
		/* The files differ by their index and block records only (and up to 8 bytes of
		 * alignment per section): EMPTY patches' records dropped (versions 5 and 6), index
		 * records of 48 bytes instead of 40 (version 7); version 8 by a header field. */
		const size_t per = relief_block_bytes_per_patch(olds[i].version, old->hdr.patch_size);
		const int64_t records_then = (int64_t)old->hdr.index_records * relief_index_record_size(olds[i].version) +
		                             (int64_t)old->hdr.block_patches * (int64_t)per;
		const int64_t records_now = (int64_t)now->hdr.index_records * RELIEF_INDEX_RECORD_SIZE +
		                            (int64_t)now->hdr.block_patches * (int64_t)per;
		const int64_t diff = (int64_t)st.st_size - (int64_t)size_now;
		print_message("version %u: %lld bytes, version %u: %zu bytes (%u empty patches; records %lld bytes then, %lld now)\n",
		              olds[i].version, (long long)st.st_size, now->hdr.version, size_now, empty,
		              (long long)records_then, (long long)records_now);
		assert_true(diff > records_then - records_now - 16 && diff < records_then - records_now + 16);
		relief_file_close(old);
		relief_file_close(now);
		free(img_now);
	}
}

/* Version 9 codes the first sample past the raster's extent at every level (the rim: its
 * windows, relief_patch_window()), where version 8 left some levels' to the prediction; the
 * packer puts it at the edge's height (docs/codec.md, "No-data"). The crop packed both ways:
 * the same tree, records' flags and masks, every valid sample of every level decoded the
 * same, and the windows of version 9 at least those of version 8, larger somewhere. A
 * packer asked for another version refuses. */
static void test_version9_rim(void **state)
{
	uint8_t *img8, *img9;
	size_t size8, size9;
	struct relief_file *f8, *f9;
	open_crop_pair(NULL, 8, &img8, &size8, NULL, &f8);
	open_crop_pair(NULL, 0, &img9, &size9, NULL, &f9);
	assert_int_equal(f8->hdr.version, 8);
	assert_int_equal(f9->hdr.version, 9);
	assert_int_equal(f8->hdr.patch_count, f9->hdr.patch_count);
	assert_int_equal(f8->hdr.index_records, f9->hdr.index_records);
	uint32_t wider = 0;
	for (uint32_t id = 0; id < f9->hdr.patch_count; id++) {
		struct relief_patch_record a, b;
		relief_file_record(f8, id, &a);
		relief_file_record(f9, id, &b);
		assert_int_equal(a.flags, b.flags);
		if (a.flags & RELIEF_PATCH_EMPTY)
			continue;
		struct relief_window w8, w9;
		relief_file_window(f8, id, &w8);
		relief_file_window(f9, id, &w9);
		assert_true(w9.x0 == w8.x0 && w9.y0 == w8.y0 && w9.x1 >= w8.x1 && w9.y1 >= w8.y1);
		wider += w9.x1 > w8.x1 || w9.y1 > w8.y1;
	}
	assert_true(wider > 0);
	assert_same_levels(f8, f9);
	print_message("crop: version 8 %zu bytes, version 9 %zu bytes; %u of %u patches with wider windows\n", size8,
	              size9, wider, f9->hdr.index_records);
	relief_file_close(f8);
	relief_file_close(f9);
	free(img8);
	free(img9);
	struct relief_dem dem;
	struct dem_import_options o = { .has_spacing = true, .spacing = 92.7, .raw_width = 140, .raw_height = 100,
	                                .raw_type = "float32" };
	char err[512] = "";
	assert_int_equal(dem_import(test_data("alps-crop-140x100.f32"), &o, &dem, err, sizeof(err)), 0);
	for (uint32_t v = 1; v <= RELIEF_FORMAT_VERSION + 1; v++) {
		struct relief_pack_options po = { .patch = 65, .ratio = 2, .tolerance = 1.0, .version = v };
		uint8_t *packed = NULL;
		size_t size = 0;
		int ret = relief_pack_memory(&dem, &po, &packed, &size, NULL);
		assert_int_equal(ret, v == 8 || v == RELIEF_FORMAT_VERSION ? 0 : -EINVAL);
		free(packed);
	}
	relief_dem_finish(&dem);
}

/* Which blocks of a patch have a valid sample: a sample on a block corner belongs to the
 * four blocks around it, one on a block edge to two, one inside to its block alone. */
static void test_mask_blocks(void **state)
{
	enum { P = 65, B = 4 }; /* 4 x 4 blocks of 16 cells */
	uint8_t mask[P * P], has[B * B];
	memset(mask, 0, sizeof(mask));
	relief_mask_blocks(mask, P, has);
	for (int i = 0; i < B * B; i++)
		assert_int_equal(has[i], 0);
	mask[32 * P + 16] = 1; /* the corner of blocks (0,1), (1,1), (0,2), (1,2) */
	mask[5 * P + 48] = 1;  /* on the edge between blocks (2,0) and (3,0) */
	mask[60 * P + 61] = 1; /* inside block (3,3) */
	relief_mask_blocks(mask, P, has);
	const uint8_t want[B * B] = {
		0, 0, 1, 1,
		1, 1, 0, 0,
		1, 1, 0, 0,
		0, 0, 0, 1,
	};
	assert_memory_equal(has, want, sizeof(want));
	memset(mask, 1, sizeof(mask));
	relief_mask_blocks(mask, P, has);
	for (int i = 0; i < B * B; i++)
		assert_int_equal(has[i], 1);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_valid_file_opens),
		cmocka_unit_test(test_truncation),
		cmocka_unit_test(test_bit_flips),
		cmocka_unit_test(test_hostile_header_fields),
		cmocka_unit_test(test_hostile_records),
		cmocka_unit_test(test_inverted_block_range),
		cmocka_unit_test(test_open_from_disk),
		cmocka_unit_test(test_version2_still_read),
		cmocka_unit_test(test_versions4_to_8_still_read),
		cmocka_unit_test(test_version9_rim),
		cmocka_unit_test(test_mask_blocks),
	};
	return cmocka_run_group_tests(tests, setup, teardown);
}
