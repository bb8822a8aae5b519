#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "codec.h"
#include "crc32c.h"
#include "format.h"
#include "le.h"
#include "patch_error.h"

/* Header field offsets (docs/format.md). */
enum {
	H_MAGIC = 0, H_VERSION = 8, H_HEADER_SIZE = 12, H_PATCH = 16, H_LEVELS = 20, H_RATIO = 24,
	H_BLOCK = 28, H_WIDTH = 32, H_HEIGHT = 36, H_SIZE = 40, H_UNITS = 44, H_PATCHES = 48, H_MASKS = 52,
	H_TOL = 56, H_OX = 64, H_OY = 72, H_SX = 80, H_SY = 88, H_HMIN = 96, H_HMAX = 104, H_VALID = 112,
	H_INDEX = 120, H_BLOCKERR = 128, H_MASKOFF = 136, H_CRSOFF = 144, H_DATAOFF = 152, H_DATASIZE = 160,
	H_FILESIZE = 168, H_CRSSIZE = 176, H_INDEXCRC = 180, H_BLOCKCRC = 184, H_MASKCRC = 188, H_CRSCRC = 192,
	H_FLAGS = 196, H_DELTA = 200, H_MASKSIZE = 328, H_BLOCKPATCHES = 336, H_ERRUNIT = 344, H_CRC = 508,
};

static size_t blocks_per_patch(uint32_t patch_size)
{
	size_t b = (patch_size - 1) / RELIEF_BLOCK_CELLS;
	return b * b;
}

size_t relief_block_ranges_per_patch(uint32_t patch_size)
{
	return blocks_per_patch(patch_size) * 2;
}

size_t relief_block_bytes_per_patch(uint32_t version, uint32_t patch_size)
{
	/* the errors, then from version 4 a range byte per block */
	return relief_block_errors_per_patch(patch_size) + (version >= 4 ? blocks_per_patch(patch_size) : 0);
}

double relief_block_error_unit(double tolerance, double largest)
{
	const double unit = tolerance / 64.0;
	/* the largest finite code, 254, stands for unit 2^(253/16); a hair more, so that the
	 * rounding of that product cannot leave `largest` just above it */
	const double needed = largest / exp2((RELIEF_BLOCK_CODE_INF - 2) / 16.0) * (1.0 + 1e-9);
	return isfinite(needed) && needed > unit ? needed : unit;
}

/* Patch id's bytes in the block section: its errors, then (version 4) its range bytes. An
 * EMPTY patch of version 5 has none: it reads as zero bytes, what earlier packers wrote. */
static const uint8_t *patch_block_bytes(const struct relief_file *f, uint32_t id)
{
	static const uint8_t none[RELIEF_MAX_BLOCKS * 5]; /* errors and range bytes at the largest patch */
	uint32_t rec = relief_index_entry(&f->hdr, id);
	uint32_t slot = rec == UINT32_MAX ? UINT32_MAX : f->block_slot[rec];
	if (slot == UINT32_MAX)
		return none;
	return f->meta + f->hdr.block_errors_offset +
	       (uint64_t)slot * relief_block_bytes_per_patch(f->hdr.version, f->hdr.patch_size);
}

size_t relief_block_errors_per_patch(uint32_t patch_size)
{
	return blocks_per_patch(patch_size) * RELIEF_BLOCK_LEVELS;
}

void relief_header_write(const struct relief_header *h, uint8_t *o)
{
	memset(o, 0, RELIEF_HEADER_SIZE);
	memcpy(o + H_MAGIC, RELIEF_MAGIC, 8);
	le_put_u32(o + H_VERSION, h->version);
	le_put_u32(o + H_HEADER_SIZE, RELIEF_HEADER_SIZE);
	le_put_u32(o + H_PATCH, h->patch_size);
	le_put_u32(o + H_LEVELS, h->levels);
	le_put_u32(o + H_RATIO, h->ratio);
	le_put_u32(o + H_BLOCK, h->block_cells);
	le_put_u32(o + H_WIDTH, h->width);
	le_put_u32(o + H_HEIGHT, h->height);
	le_put_u32(o + H_SIZE, h->size);
	le_put_u32(o + H_UNITS, h->source_units);
	le_put_u32(o + H_PATCHES, h->patch_count);
	le_put_u32(o + H_MASKS, h->mask_count);
	le_put_f64(o + H_TOL, h->tolerance);
	le_put_f64(o + H_OX, h->origin_x);
	le_put_f64(o + H_OY, h->origin_y);
	le_put_f64(o + H_SX, h->spacing_x);
	le_put_f64(o + H_SY, h->spacing_y);
	le_put_f64(o + H_HMIN, h->height_min);
	le_put_f64(o + H_HMAX, h->height_max);
	le_put_u64(o + H_VALID, h->valid_samples);
	le_put_u64(o + H_INDEX, h->index_offset);
	le_put_u64(o + H_BLOCKERR, h->block_errors_offset);
	le_put_u64(o + H_MASKOFF, h->masks_offset);
	le_put_u64(o + H_MASKSIZE, h->masks_size);
	le_put_u64(o + H_CRSOFF, h->crs_offset);
	le_put_u64(o + H_DATAOFF, h->data_offset);
	le_put_u64(o + H_DATASIZE, h->data_size);
	le_put_u64(o + H_FILESIZE, h->file_size);
	le_put_u32(o + H_CRSSIZE, h->crs_size);
	le_put_u32(o + H_INDEXCRC, h->index_crc);
	le_put_u32(o + H_BLOCKCRC, h->block_errors_crc);
	le_put_u32(o + H_MASKCRC, h->masks_crc);
	le_put_u32(o + H_CRSCRC, h->crs_crc);
	le_put_u32(o + H_FLAGS, h->flags);
	if (h->version >= 5)
		le_put_u32(o + H_BLOCKPATCHES, h->block_patches);
	if (h->version >= 8)
		le_put_f64(o + H_ERRUNIT, h->block_error_unit);
	for (uint32_t l = 0; l < RELIEF_MAX_LEVELS; l++)
		le_put_f64(o + H_DELTA + 8 * l, l < h->levels ? h->delta[l] : 0.0);
	le_put_u32(o + H_CRC, relief_crc32c(0, o, H_CRC));
}

/* Fuzzing builds (RELIEF_FUZZ=ON) skip checksum comparisons so that mutated inputs reach
 * the field checks and the decoder; every other check stays. Never defined otherwise. */
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
#define crc_differs(a, b) ((void)(a), (void)(b), false)
#else
#define crc_differs(a, b) ((a) != (b))
#endif

__attribute__((format(printf, 3, 4)))
static int bad(char *err, size_t err_size, const char *fmt, ...)
{
	if (err && err_size) {
		va_list ap;
		va_start(ap, fmt);
		vsnprintf(err, err_size, fmt, ap);
		va_end(ap);
	}
	return -EBADMSG;
}

static bool finite_in(double v, double lo, double hi)
{
	return isfinite(v) && v >= lo && v <= hi;
}

/* A section [off, off + len) inside the file, 8-byte aligned, not overlapping the header. */
static bool section_ok(uint64_t off, uint64_t len, uint64_t file_size)
{
	return off >= RELIEF_HEADER_SIZE && off % 8 == 0 && off <= file_size && len <= file_size - off;
}

int relief_header_parse(const uint8_t *b, size_t size, struct relief_header *h, struct relief_layout *lay,
                        char *err, size_t err_size)
{
	if (size < RELIEF_HEADER_SIZE)
		return bad(err, err_size, "file too short for a header (%zu bytes, need %u)", size, RELIEF_HEADER_SIZE);
	if (memcmp(b, RELIEF_MAGIC, 8) != 0)
		return bad(err, err_size, "not a .relief file (bad magic; `relief pack` makes one from an elevation raster)");
	struct relief_header r = { 0 };
	r.version = le_get_u32(b + H_VERSION);
	if (r.version < RELIEF_FORMAT_VERSION_MIN || r.version > RELIEF_FORMAT_VERSION)
		return bad(err, err_size, "format version %u is not supported (this build reads %u to %u)", r.version,
		           RELIEF_FORMAT_VERSION_MIN, RELIEF_FORMAT_VERSION);
	if (le_get_u32(b + H_HEADER_SIZE) != RELIEF_HEADER_SIZE)
		return bad(err, err_size, "header size %u, expected %u", le_get_u32(b + H_HEADER_SIZE), RELIEF_HEADER_SIZE);
	uint32_t crc = relief_crc32c(0, b, H_CRC);
	if (crc_differs(crc, le_get_u32(b + H_CRC)))
		return bad(err, err_size, "header checksum mismatch (stored %08x, computed %08x)", le_get_u32(b + H_CRC), crc);
	/* Version 5 uses the first reserved word for the block section's record count, version
	 * 8 the double after it for the block error unit. */
	for (size_t i = r.version >= 5 ? H_BLOCKPATCHES + 4 : H_BLOCKPATCHES; i < H_CRC; i++)
		if (b[i] && !(r.version >= 8 && i >= H_ERRUNIT && i < H_ERRUNIT + 8))
			return bad(err, err_size, "reserved header byte %zu is not zero", i);
	r.patch_size = le_get_u32(b + H_PATCH);
	r.levels = le_get_u32(b + H_LEVELS);
	r.ratio = le_get_u32(b + H_RATIO);
	r.block_cells = le_get_u32(b + H_BLOCK);
	r.width = le_get_u32(b + H_WIDTH);
	r.height = le_get_u32(b + H_HEIGHT);
	r.size = le_get_u32(b + H_SIZE);
	r.source_units = le_get_u32(b + H_UNITS);
	r.patch_count = le_get_u32(b + H_PATCHES);
	r.mask_count = le_get_u32(b + H_MASKS);
	r.block_patches = r.version >= 5 ? le_get_u32(b + H_BLOCKPATCHES) : r.patch_count;
	r.tolerance = le_get_f64(b + H_TOL);
	const double least_unit = relief_block_error_unit(r.tolerance, 0.0); /* tolerance / 64 */
	r.block_error_unit = r.version >= 8 ? le_get_f64(b + H_ERRUNIT) : least_unit;
	r.origin_x = le_get_f64(b + H_OX);
	r.origin_y = le_get_f64(b + H_OY);
	r.spacing_x = le_get_f64(b + H_SX);
	r.spacing_y = le_get_f64(b + H_SY);
	r.height_min = le_get_f64(b + H_HMIN);
	r.height_max = le_get_f64(b + H_HMAX);
	r.valid_samples = le_get_u64(b + H_VALID);
	r.index_offset = le_get_u64(b + H_INDEX);
	r.block_errors_offset = le_get_u64(b + H_BLOCKERR);
	r.masks_offset = le_get_u64(b + H_MASKOFF);
	r.masks_size = le_get_u64(b + H_MASKSIZE);
	r.crs_offset = le_get_u64(b + H_CRSOFF);
	r.data_offset = le_get_u64(b + H_DATAOFF);
	r.data_size = le_get_u64(b + H_DATASIZE);
	r.file_size = le_get_u64(b + H_FILESIZE);
	r.crs_size = le_get_u32(b + H_CRSSIZE);
	r.index_crc = le_get_u32(b + H_INDEXCRC);
	r.block_errors_crc = le_get_u32(b + H_BLOCKCRC);
	r.masks_crc = le_get_u32(b + H_MASKCRC);
	r.crs_crc = le_get_u32(b + H_CRSCRC);
	r.flags = le_get_u32(b + H_FLAGS);

	if (r.patch_size != 65 && r.patch_size != 129 && r.patch_size != 257)
		return bad(err, err_size, "patch size %u is not 65, 129 or 257", r.patch_size);
	if (r.levels < 1 || r.levels > RELIEF_MAX_LEVELS)
		return bad(err, err_size, "level count %u outside 1..%u", r.levels, RELIEF_MAX_LEVELS);
	if (r.ratio != 2 && r.ratio != 3)
		return bad(err, err_size, "tolerance ratio %u is not 2 or 3", r.ratio);
	if (r.block_cells != RELIEF_BLOCK_CELLS)
		return bad(err, err_size, "block size %u cells, expected %u", r.block_cells, RELIEF_BLOCK_CELLS);
	if (!finite_in(r.tolerance, 1e-4, 1e4))
		return bad(err, err_size, "tolerance %g m outside [1e-4, 1e4]", r.tolerance);
	if (!finite_in(r.block_error_unit, least_unit, RELIEF_MAX_HEIGHT))
		return bad(err, err_size, "block error unit %g m outside [%g, %g] (the tolerance / 64 at least)",
		           r.block_error_unit, least_unit, RELIEF_MAX_HEIGHT);
	struct relief_layout L;
	if (relief_layout_init(&L, r.patch_size, r.levels, r.ratio, r.tolerance) < 0)
		return bad(err, err_size, "inconsistent layout");
	if (r.size != L.size)
		return bad(err, err_size, "grid size %u does not match %u levels of %u-sample patches (%u)", r.size,
		           r.levels, r.patch_size, L.size);
	if (r.width < 1 || r.height < 1 || r.width > r.size || r.height > r.size)
		return bad(err, err_size, "valid extent %ux%u outside the %u-sample grid", r.width, r.height, r.size);
	if (r.patch_count != L.patch_count)
		return bad(err, err_size, "patch count %u, expected %u", r.patch_count, L.patch_count);
	if (r.mask_count > r.patch_count)
		return bad(err, err_size, "mask count %u exceeds the patch count", r.mask_count);
	if (r.source_units > RELIEF_UNITS_FEET)
		return bad(err, err_size, "unknown vertical units code %u", r.source_units);
	if (r.flags != 0)
		return bad(err, err_size, "unknown header flags 0x%x", r.flags);
	if (!finite_in(r.origin_x, -RELIEF_MAX_COORD, RELIEF_MAX_COORD) ||
	    !finite_in(r.origin_y, -RELIEF_MAX_COORD, RELIEF_MAX_COORD))
		return bad(err, err_size, "origin (%g, %g) is not a finite position within %g m", r.origin_x, r.origin_y,
		           RELIEF_MAX_COORD);
	if (!finite_in(r.spacing_x, RELIEF_SPACING_MIN, RELIEF_SPACING_MAX) ||
	    !finite_in(r.spacing_y, RELIEF_SPACING_MIN, RELIEF_SPACING_MAX))
		return bad(err, err_size, "sample spacing (%g, %g) m outside [%g, %g]", r.spacing_x, r.spacing_y,
		           RELIEF_SPACING_MIN, RELIEF_SPACING_MAX);
	if (!finite_in(r.height_min, -RELIEF_MAX_HEIGHT, RELIEF_MAX_HEIGHT) ||
	    !finite_in(r.height_max, r.height_min, RELIEF_MAX_HEIGHT))
		return bad(err, err_size, "height range [%g, %g] m is not valid", r.height_min, r.height_max);
	if (r.valid_samples < 1 || r.valid_samples > (uint64_t)r.width * r.height)
		return bad(err, err_size, "valid sample count %llu outside 1..%llu", (unsigned long long)r.valid_samples,
		           (unsigned long long)r.width * r.height);
	for (uint32_t l = 0; l < RELIEF_MAX_LEVELS; l++) {
		double d = le_get_f64(b + H_DELTA + 8 * l);
		if (l < r.levels) {
			if (d != L.delta[l])
				return bad(err, err_size, "level %u tolerance %g m, expected %g m", l, d, L.delta[l]);
			r.delta[l] = d;
		} else if (d != 0.0) {
			return bad(err, err_size, "tolerance given for nonexistent level %u", l);
		}
	}
	if (r.file_size != size)
		return bad(err, err_size, "file is %zu bytes but its header says %llu (truncated or extended)", size,
		           (unsigned long long)r.file_size);
	relief_index_windows(&r);
	uint64_t idx_len = (uint64_t)r.index_records * relief_index_record_size(r.version);
	if (r.block_patches < 1 || r.block_patches > r.index_records)
		return bad(err, err_size, "%u block records for %u patches with index records", r.block_patches,
		           r.index_records);
	uint64_t be_len = (uint64_t)r.block_patches * relief_block_bytes_per_patch(r.version, r.patch_size);
	uint64_t mask_len = r.masks_size;
	if ((r.mask_count == 0) != (mask_len == 0))
		return bad(err, err_size, "mask section of %llu bytes for %u masks", (unsigned long long)mask_len,
		           r.mask_count);
	if (!section_ok(r.index_offset, idx_len, size))
		return bad(err, err_size, "index section out of bounds");
	if (!section_ok(r.block_errors_offset, be_len, size) || r.block_errors_offset < r.index_offset + idx_len)
		return bad(err, err_size, "block error section out of bounds or overlapping");
	if (!section_ok(r.masks_offset, mask_len, size) || r.masks_offset < r.block_errors_offset + be_len)
		return bad(err, err_size, "mask section out of bounds or overlapping");
	if (!section_ok(r.crs_offset, r.crs_size, size) || r.crs_offset < r.masks_offset + mask_len)
		return bad(err, err_size, "CRS section out of bounds or overlapping");
	if (!section_ok(r.data_offset, r.data_size, size) || r.data_offset < r.crs_offset + r.crs_size)
		return bad(err, err_size, "data section out of bounds or overlapping");
	*h = r;
	*lay = L;
	return 0;
}

void relief_index_windows(struct relief_header *h)
{
	uint32_t first = 0;
	for (uint32_t l = 0; l < RELIEF_MAX_LEVELS; l++) {
		uint32_t cols = 0, rows = 0;
		if (l < h->levels) {
			cols = rows = 1u << l;
			if (h->version >= 6) {
				/* Patch px's footprint starts at finest column px * span: inside the raster
				 * while that is below width (what the packer makes EMPTY otherwise). */
				const uint64_t span = (uint64_t)(h->patch_size - 1) << (h->levels - 1 - l);
				uint64_t c = (h->width + span - 1) / span, r = (h->height + span - 1) / span;
				cols = c < cols ? (uint32_t)c : cols;
				rows = r < rows ? (uint32_t)r : rows;
			}
		}
		h->index_cols[l] = cols;
		h->index_rows[l] = rows;
		h->index_first[l] = first;
		first += cols * rows; /* at most the patch count, below 2^32 */
	}
	h->index_records = first;
}

uint32_t relief_index_entry(const struct relief_header *h, uint32_t id)
{
	uint32_t l = 0;
	while (l + 1 < h->levels && relief_level_first_id(l + 1) <= id)
		l++;
	uint32_t local = id - relief_level_first_id(l), px = local & ((1u << l) - 1), py = local >> l;
	if (px >= h->index_cols[l] || py >= h->index_rows[l])
		return UINT32_MAX;
	return h->index_first[l] + py * h->index_cols[l] + px;
}

uint32_t relief_index_patch(const struct relief_header *h, uint32_t e)
{
	uint32_t l = 0;
	while (l + 1 < h->levels && h->index_first[l + 1] <= e)
		l++;
	uint32_t local = e - h->index_first[l];
	return relief_patch_id(l, local % h->index_cols[l], local / h->index_cols[l]);
}

size_t relief_index_record_size(uint32_t version)
{
	return version >= 7 ? 48 : 40;
}

void relief_record_write(const struct relief_patch_record *r, uint8_t *o)
{
	memset(o, 0, RELIEF_INDEX_RECORD_SIZE);
	le_put_u64(o, r->offset);
	le_put_u32(o + 8, r->size);
	le_put_u32(o + 12, r->crc);
	le_put_f32(o + 16, r->height_min);
	le_put_f32(o + 20, r->height_max);
	le_put_f32(o + 24, r->error);
	le_put_u32(o + 28, r->flags);
	le_put_u32(o + 32, r->mask_offset);
	le_put_u32(o + 36, r->mask_size);
	le_put_f32(o + 40, r->draw_error); /* bytes 44..47 reserved, zero */
}

void relief_record_read(const uint8_t *in, uint32_t version, struct relief_patch_record *r)
{
	r->offset = le_get_u64(in);
	r->size = le_get_u32(in + 8);
	r->crc = le_get_u32(in + 12);
	r->height_min = le_get_f32(in + 16);
	r->height_max = le_get_f32(in + 20);
	r->error = le_get_f32(in + 24);
	r->flags = le_get_u32(in + 28);
	r->mask_offset = le_get_u32(in + 32);
	r->mask_size = le_get_u32(in + 36);
	r->draw_error = version >= 7 ? le_get_f32(in + 40) : r->error;
}

/* A record's bytes, rec < index_records. */
static const uint8_t *record_bytes(const struct relief_file *f, uint32_t rec)
{
	return f->meta + f->hdr.index_offset + (uint64_t)rec * relief_index_record_size(f->hdr.version);
}

/* Checks one index record, patch id (level l, px, py) at record `rec`, and assigns its block
 * record. */
static int validate_record(struct relief_file *f, uint32_t id, uint32_t l, uint32_t px, uint32_t py, uint32_t rec,
                           uint32_t *slots, uint32_t *masks_seen, char *err, size_t err_size)
{
	const struct relief_header *h = &f->hdr;
	struct relief_patch_record r;
	relief_record_read(record_bytes(f, rec), h->version, &r);
	/* From version 5 block records are for non-EMPTY patches only, in index order. */
	if (h->version >= 5 && (r.flags & RELIEF_PATCH_EMPTY))
		f->block_slot[rec] = UINT32_MAX;
	else if (*slots == h->block_patches)
		return bad(err, err_size, "patch %u has no block record (the header counts %u)", id, h->block_patches);
	else
		f->block_slot[rec] = (*slots)++;
	if (r.flags & ~RELIEF_PATCH_FLAGS_KNOWN)
		return bad(err, err_size, "patch %u (level %u, %u,%u): unknown flags 0x%x", id, l, px, py, r.flags);
	if (r.flags & RELIEF_PATCH_EMPTY) {
		if (id == 0)
			return bad(err, err_size, "the root patch is empty");
		if (r.size || r.offset || (r.flags & RELIEF_PATCH_MASKED))
			return bad(err, err_size, "patch %u (level %u, %u,%u): empty patch with data", id, l, px, py);
	} else if (r.offset > h->data_size || r.size > h->data_size - r.offset || r.size == 0 || r.size > (64u << 20)) {
		return bad(err, err_size, "patch %u (level %u, %u,%u): stream [%llu, +%u) outside the data section", id, l,
		           px, py, (unsigned long long)r.offset, r.size);
	} else if (!isfinite(r.height_min) || !isfinite(r.height_max) || r.height_min > r.height_max ||
	           fabs(r.height_min) > RELIEF_MAX_HEIGHT || fabs(r.height_max) > RELIEF_MAX_HEIGHT) {
		return bad(err, err_size, "patch %u (level %u, %u,%u): bad height range", id, l, px, py);
	} else if (!isfinite(r.error) || r.error < 0 || r.error > 1e6) {
		return bad(err, err_size, "patch %u (level %u, %u,%u): bad error bound %g", id, l, px, py, r.error);
	} else if (!isfinite(r.draw_error) || r.draw_error < 0 || r.draw_error > 2 * RELIEF_MAX_HEIGHT) {
		/* a distance between two surfaces whose heights are within +-RELIEF_MAX_HEIGHT */
		return bad(err, err_size, "patch %u (level %u, %u,%u): bad drawn error %g", id, l, px, py, r.draw_error);
	}
	if ((r.flags & RELIEF_PATCH_EMPTY) && r.draw_error != 0.0f)
		return bad(err, err_size, "patch %u (level %u, %u,%u): empty patch with a drawn error", id, l, px, py);
	if (h->version >= 7 && le_get_u32(record_bytes(f, rec) + 44) != 0)
		return bad(err, err_size, "patch %u (level %u, %u,%u): reserved record bytes not zero", id, l, px, py);
	if (r.flags & RELIEF_PATCH_MASKED) {
		if (r.mask_size == 0 || r.mask_offset > h->masks_size || r.mask_size > h->masks_size - r.mask_offset)
			return bad(err, err_size, "patch %u (level %u, %u,%u): mask [%u, +%u) outside the mask section", id, l,
			           px, py, r.mask_offset, r.mask_size);
		(*masks_seen)++;
	} else if (r.mask_offset || r.mask_size) {
		return bad(err, err_size, "patch %u (level %u, %u,%u): mask data on an unmasked patch", id, l, px, py);
	}
	if (h->version >= 4) {
		const size_t nr = blocks_per_patch(h->patch_size);
		const uint8_t *rg = patch_block_bytes(f, id) + relief_block_errors_per_patch(h->patch_size);
		for (size_t i = 0; i < nr; i++)
			if ((rg[i] & 15) > (rg[i] >> 4))
				return bad(err, err_size, "patch %u (level %u, %u,%u): block %zu's height range is inverted", id,
				           l, px, py, i);
	}
	if (r.flags & RELIEF_PATCH_EMPTY)
		return 0;
	if (r.size > f->max_stream)
		f->max_stream = r.size;
	if (id > 0) {
		/* A patch with data needs a parent with data: decoding walks down from the root. The
		 * parent lies in its level's window (relief_index_windows()). */
		struct relief_patch_record pr;
		relief_file_record(f, relief_patch_id(l - 1, px / 2, py / 2), &pr);
		if (pr.flags & RELIEF_PATCH_EMPTY)
			return bad(err, err_size, "patch %u (level %u, %u,%u) has data but its parent is empty", id, l, px, py);
	}
	return 0;
}

static int validate_body(struct relief_file *f, char *err, size_t err_size)
{
	const struct relief_header *h = &f->hdr;
	const uint8_t *b = f->meta;
	uint64_t idx_len = (uint64_t)h->index_records * relief_index_record_size(h->version);
	size_t be_per = relief_block_bytes_per_patch(h->version, h->patch_size);
	uint64_t be_len = (uint64_t)h->block_patches * be_per;
	uint64_t mask_len = h->masks_size;
	if (crc_differs(relief_crc32c(0, b + h->index_offset, idx_len), h->index_crc))
		return bad(err, err_size, "index checksum mismatch");
	if (crc_differs(relief_crc32c(0, b + h->block_errors_offset, be_len), h->block_errors_crc))
		return bad(err, err_size, "block error checksum mismatch");
	if (crc_differs(relief_crc32c(0, b + h->masks_offset, mask_len), h->masks_crc))
		return bad(err, err_size, "mask checksum mismatch");
	if (crc_differs(relief_crc32c(0, b + h->crs_offset, h->crs_size), h->crs_crc))
		return bad(err, err_size, "CRS checksum mismatch");
	if (memchr(b + h->crs_offset, 0, h->crs_size))
		return bad(err, err_size, "CRS text contains a NUL byte");

	if (!(f->block_slot = malloc(sizeof(uint32_t) * h->index_records)))
		return -ENOMEM;
	uint32_t masks_seen = 0, slots = 0;
	int ret = 0;
	/* Window by window, row by row: record order, so block records are assigned in it. */
	for (uint32_t l = 0; l < h->levels && ret == 0; l++)
		for (uint32_t py = 0; py < h->index_rows[l] && ret == 0; py++)
			for (uint32_t px = 0; px < h->index_cols[l] && ret == 0; px++)
				ret = validate_record(f, relief_patch_id(l, px, py), l, px, py,
				                      h->index_first[l] + py * h->index_cols[l] + px, &slots, &masks_seen, err,
				                      err_size);
	if (ret == 0 && masks_seen != h->mask_count)
		ret = bad(err, err_size, "%u masked patches but the header counts %u", masks_seen, h->mask_count);
	if (ret == 0 && slots != h->block_patches)
		ret = bad(err, err_size, "%u patches with block records but the header counts %u", slots, h->block_patches);
	return ret;
}

/* Fills f->gaps from the finest level up: a finest patch has gaps where it is MASKED or
 * EMPTY, a coarser one where any of its four children has (a child without a record lies
 * past the raster: all no-data). The children's footprints tile the parent's, so this is
 * exactly "some finest sample under the footprint is no-data". Records are level-major,
 * so children come after their parent. */
static int derive_gaps(struct relief_file *f)
{
	const struct relief_header *h = &f->hdr;
	if (!(f->gaps = malloc(h->index_records ? h->index_records : 1)))
		return -ENOMEM;
	for (uint32_t rec = h->index_records; rec-- > 0;) {
		uint32_t id = relief_index_patch(h, rec), l, px, py;
		relief_patch_coords(&f->layout, id, &l, &px, &py);
		uint8_t g = 0;
		if (l + 1 == h->levels) {
			struct relief_patch_record r;
			relief_record_read(record_bytes(f, rec), h->version, &r);
			g = (r.flags & (RELIEF_PATCH_EMPTY | RELIEF_PATCH_MASKED)) != 0;
		} else {
			for (uint32_t k = 0; k < 4 && !g; k++) {
				uint32_t c = relief_index_entry(h, relief_patch_id(l + 1, 2 * px + (k & 1), 2 * py + (k >> 1)));
				g = c == UINT32_MAX || f->gaps[c];
			}
		}
		f->gaps[rec] = g;
	}
	return 0;
}

/* Validates the metadata in f->meta (header already parsed), derives the gaps and copies
 * the CRS text. */
static int open_meta(struct relief_file *f, char *err, size_t err_size)
{
	int ret = validate_body(f, err, err_size);
	if (ret == 0)
		ret = derive_gaps(f);
	if (ret < 0)
		return ret;
	f->crs = strndup((const char *)f->meta + f->hdr.crs_offset, f->hdr.crs_size);
	return f->crs ? 0 : -ENOMEM;
}

int relief_file_open_memory(const void *buf, size_t size, struct relief_file **out, char *err, size_t err_size)
{
	struct relief_file *f = calloc(1, sizeof(*f));
	if (!f)
		return -ENOMEM;
	f->fd = -1;
	f->image = buf;
	f->meta = buf;
	int ret = relief_header_parse(buf, size, &f->hdr, &f->layout, err, err_size);
	if (ret == 0)
		ret = open_meta(f, err, err_size);
	if (ret < 0) {
		relief_file_close(f);
		return ret;
	}
	*out = f;
	return 0;
}

/* pread() until `n` bytes or end of file; -EIO on a short read. */
static int read_at(int fd, void *buf, size_t n, uint64_t off)
{
	size_t done = 0;
	while (done < n) {
		ssize_t r = pread(fd, (uint8_t *)buf + done, n - done, (off_t)(off + done));
		if (r < 0 && errno == EINTR)
			continue;
		if (r < 0)
			return -errno;
		if (r == 0)
			return -EIO;
		done += (size_t)r;
	}
	return 0;
}

int relief_file_open(const char *path, struct relief_file **out, char *err, size_t err_size)
{
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0) {
		int e = errno;
		snprintf(err, err_size, "%s", strerror(e));
		return -e;
	}
	struct stat st;
	if (fstat(fd, &st) < 0 || !S_ISREG(st.st_mode)) {
		int e = S_ISREG(st.st_mode) ? errno : EINVAL;
		close(fd);
		snprintf(err, err_size, "%s", e == EINVAL ? "not a regular file" : strerror(e));
		return -e;
	}
	struct relief_file *f = calloc(1, sizeof(*f));
	if (!f) {
		close(fd);
		return -ENOMEM;
	}
	f->fd = fd;
	if (!(f->path = strdup(path))) {
		relief_file_close(f);
		return -ENOMEM;
	}
	uint8_t head[RELIEF_HEADER_SIZE];
	size_t size = (size_t)st.st_size;
	int ret;
	if (size < RELIEF_HEADER_SIZE) {
		ret = bad(err, err_size, "file too short for a header (%zu bytes, need %u)", size, RELIEF_HEADER_SIZE);
		goto fail;
	}
	if ((ret = read_at(fd, head, sizeof(head), 0)) < 0) {
		snprintf(err, err_size, "reading the header: %s", strerror(-ret));
		goto fail;
	}
	if ((ret = relief_header_parse(head, size, &f->hdr, &f->layout, err, err_size)) < 0)
		goto fail;
	/* data_offset <= file size was checked: the copy is bounded by the real file. */
	f->meta_owned = malloc(f->hdr.data_offset);
	if (!f->meta_owned) {
		ret = -ENOMEM;
		goto fail;
	}
	if ((ret = read_at(fd, f->meta_owned, f->hdr.data_offset, 0)) < 0) {
		snprintf(err, err_size, "reading the index: %s", strerror(-ret));
		goto fail;
	}
	f->meta = f->meta_owned;
	if ((ret = open_meta(f, err, err_size)) < 0)
		goto fail;
	*out = f;
	return 0;
fail:
	relief_file_close(f);
	return ret;
}

const char *relief_file_name(const struct relief_file *f)
{
	return f->path ? f->path : "(memory image)";
}

void relief_file_close(struct relief_file *f)
{
	if (!f)
		return;
	if (f->fd >= 0)
		close(f->fd);
	free(f->meta_owned);
	free(f->block_slot);
	free(f->gaps);
	free(f->crs);
	free(f->path);
	free(f);
}

void relief_file_record(const struct relief_file *f, uint32_t id, struct relief_patch_record *r)
{
	uint32_t rec = relief_index_entry(&f->hdr, id);
	if (rec == UINT32_MAX) { /* outside its level's window: EMPTY, as packers before version 6 wrote it */
		*r = (struct relief_patch_record){ .flags = RELIEF_PATCH_EMPTY };
		return;
	}
	relief_record_read(record_bytes(f, rec), f->hdr.version, r);
	uint32_t l, px, py;
	if (f->hdr.version < 7 && !(r->flags & RELIEF_PATCH_EMPTY) && relief_patch_coords(&f->layout, id, &l, &px, &py) &&
	    l + 1 < f->hdr.levels)
		r->draw_error = relief_float_up(relief_draw_error_bound(r->error, 1u << (f->hdr.levels - 1 - l),
		                                                        f->layout.delta[f->hdr.levels - 1]));
}

bool relief_file_patch_gaps(const struct relief_file *f, uint32_t id)
{
	uint32_t rec = relief_index_entry(&f->hdr, id);
	return rec == UINT32_MAX || f->gaps[rec];
}

float relief_file_measured_draw_error(const struct relief_file *f, const struct relief_patch_record *r)
{
	return f->hdr.version >= 7 ? r->draw_error : INFINITY;
}

int relief_file_read_stream(const struct relief_file *f, uint32_t id, uint8_t *buf, size_t *size)
{
	struct relief_patch_record r;
	relief_file_record(f, id, &r);
	if (r.flags & RELIEF_PATCH_EMPTY)
		return -ENOENT;
	uint64_t off = f->hdr.data_offset + r.offset;
	if (f->image) {
		memcpy(buf, f->image + off, r.size);
	} else {
		int ret = read_at(f->fd, buf, r.size, off);
		if (ret < 0)
			return ret == -EIO ? -EIO : ret;
	}
	if (crc_differs(relief_crc32c(0, buf, r.size), r.crc))
		return -EBADMSG;
	*size = r.size;
	return 0;
}

void relief_file_block_errors(const struct relief_file *f, uint32_t id, float *eps)
{
	size_t n = relief_block_errors_per_patch(f->hdr.patch_size);
	const uint8_t *p = patch_block_bytes(f, id);
	const double unit = f->hdr.block_error_unit;
	/* Before version 4 a block's error was measured against its patch's own surface, so the
	 * bound for the block is that plus Err(P) (the paper's sum), rounded up. */
	double err = 0.0;
	if (f->hdr.version < 4) {
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		err = r.error;
	}
	for (size_t i = 0; i < n; i++) {
		float e = relief_block_error_decode(p[i], unit);
		eps[i] = err > 0.0 && isfinite(e) ? relief_float_up((double)e + err) : e;
	}
}

void relief_file_block_ranges(const struct relief_file *f, uint32_t id, float *range)
{
	size_t n = relief_block_ranges_per_patch(f->hdr.patch_size);
	struct relief_patch_record r;
	relief_file_record(f, id, &r);
	if (f->hdr.version < 4) {
		for (size_t i = 0; i < n; i += 2) {
			range[i] = r.height_min;
			range[i + 1] = r.height_max;
		}
		return;
	}
	const uint8_t *p = patch_block_bytes(f, id) + relief_block_errors_per_patch(f->hdr.patch_size);
	for (size_t i = 0; i < n; i += 2) {
		range[i] = relief_block_range_decode(p[i / 2] & 15, r.height_min, r.height_max, false);
		range[i + 1] = relief_block_range_decode(p[i / 2] >> 4, r.height_min, r.height_max, true);
	}
}

void relief_file_window(const struct relief_file *f, uint32_t id, struct relief_window *win)
{
	uint32_t l, px, py;
	if (f->hdr.version < 3 || !relief_patch_coords(&f->layout, id, &l, &px, &py)) {
		relief_window_full(&f->layout.geom, win);
		return;
	}
	relief_patch_window(&f->layout, f->hdr.width, f->hdr.height, l, px, py, relief_format_has_rim(f->hdr.version), win);
}

void relief_mask_blocks(const uint8_t *mask, uint32_t patch_size, uint8_t *has_data)
{
	const uint32_t blocks = (patch_size - 1) / RELIEF_BLOCK_CELLS;
	for (uint32_t by = 0; by < blocks; by++)
		for (uint32_t bx = 0; bx < blocks; bx++) {
			uint8_t any = 0;
			for (uint32_t y = by * RELIEF_BLOCK_CELLS; y <= (by + 1) * RELIEF_BLOCK_CELLS && !any; y++)
				for (uint32_t x = bx * RELIEF_BLOCK_CELLS; x <= (bx + 1) * RELIEF_BLOCK_CELLS; x++)
					any |= mask[(size_t)y * patch_size + x];
			has_data[by * blocks + bx] = any != 0;
		}
}

int relief_file_mask(const struct relief_file *f, uint32_t id, uint8_t *mask)
{
	struct relief_patch_record r;
	relief_file_record(f, id, &r);
	size_t n = (size_t)f->hdr.patch_size * f->hdr.patch_size;
	if (r.flags & RELIEF_PATCH_EMPTY) {
		memset(mask, 0, n);
		return 0;
	}
	if (!(r.flags & RELIEF_PATCH_MASKED)) {
		memset(mask, 1, n);
		return 0;
	}
	return relief_mask_decode(f->hdr.patch_size, f->meta + f->hdr.masks_offset + r.mask_offset, r.mask_size, mask);
}
