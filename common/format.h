/* The .relief container (specified in docs/format.md). Little-endian, versioned, with every
 * section 8-byte aligned so that a memory-mapped file can be read in place.
 *
 * Opening validates every header field, the index records and the section checksums; a
 * corrupt, truncated or hostile file gets -EBADMSG (or -EINVAL for a bad path) and a
 * message naming what is wrong, never an out-of-bounds read. Patch streams carry their own
 * CRC32C, checked when a stream is fetched, so one damaged patch does not make the whole
 * file unreadable.
 *
 * Reading: everything before the patch streams (header, index, block errors, masks, CRS) is
 * read into memory at open; streams are fetched with pread() into the caller's buffer. A
 * file truncated or replaced while open therefore yields -EIO for the streams it no longer
 * has, never a SIGBUS, which a memory mapping would raise. Any number of threads may fetch
 * streams concurrently.
 */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "layout.h"

#define RELIEF_MAGIC "RELIEF\x1a\n"
/* 2: residual contexts from classes (docs/codec.md); 3: streams skip the padding beyond
 * the valid extent (relief_patch_window()); 4: block errors measured against the finest
 * decoded surface, and block height ranges (patch_error.h); 5: block records for
 * non-EMPTY patches only, counted in the header; 6: index records only for the patches
 * of each level's index window (relief_index_windows()); 7: index records of 48 bytes
 * with the patch's drawn error (relief_patch_record); 8: the block error codes' unit in
 * the header (relief_block_error_unit()); 9: the windows also code the first sample past
 * the raster's extent at every level (relief_patch_window()'s rim). Versions 2 to 8 are
 * still read, and the packer can write version 8 (relief_pack_options.version). */
#define RELIEF_FORMAT_VERSION 9u
#define RELIEF_FORMAT_VERSION_MIN 2u
/* Whether files of this version code the rim in their windows (relief_patch_window()). */
static inline bool relief_format_has_rim(uint32_t version)
{
	return version >= 9;
}
#define RELIEF_HEADER_SIZE 512u
/* Index record bytes: 48 from version 7, 40 before (relief_index_record_size()). */
#define RELIEF_INDEX_RECORD_SIZE 48u
/* Georeferencing a file may have (checked on open; the packer and the importer refuse
 * rasters outside it): |origin| <= RELIEF_MAX_COORD m, spacing in [RELIEF_SPACING_MIN,
 * RELIEF_SPACING_MAX] m. */
#define RELIEF_MAX_COORD 1e9
#define RELIEF_SPACING_MIN 1e-6
#define RELIEF_SPACING_MAX 1e7
/* Heights a file may hold, metres: |h| <= RELIEF_MAX_HEIGHT (checked on open; the importer
 * takes a sample beyond it, or one that is not a number, as no-data and counts it). */
#define RELIEF_MAX_HEIGHT 1e6

enum relief_patch_flags {
	RELIEF_PATCH_EMPTY = 1u << 0,  /* no valid sample in its footprint: no stream */
	RELIEF_PATCH_MASKED = 1u << 1, /* some of its samples are no-data: has a mask */
};
#define RELIEF_PATCH_FLAGS_KNOWN (RELIEF_PATCH_EMPTY | RELIEF_PATCH_MASKED)

enum relief_units {
	RELIEF_UNITS_METRES = 0,
	RELIEF_UNITS_FEET = 1, /* the source was in feet; stored heights are metres anyway */
};

struct relief_header {
	uint32_t version;
	uint32_t patch_size, levels, ratio, block_cells;
	uint32_t width, height; /* the raster's valid extent, finest-level samples [0,w) x [0,h) */
	uint32_t size;          /* finest level samples per side (padded) */
	uint32_t source_units;
	uint32_t patch_count, mask_count;
	uint32_t flags;
	double tolerance;
	double origin_x, origin_y;   /* world position of sample (0, 0), the north-west corner */
	double spacing_x, spacing_y; /* metres; world y = origin_y - row * spacing_y */
	double height_min, height_max; /* over valid original samples, metres */
	/* the block error codes' unit, metres (relief_block_error_unit()): stored from version
	 * 8, tolerance / 64 before */
	double block_error_unit;
	uint64_t valid_samples;
	uint64_t index_offset, block_errors_offset, masks_offset, masks_size, crs_offset, data_offset, data_size,
		file_size;
	uint32_t crs_size;
	uint32_t index_crc, block_errors_crc, masks_crc, crs_crc;
	/* Patches with a record in the block section: from version 5 the non-EMPTY ones, in id
	 * order; before, every patch (the header's field is new in version 5). */
	uint32_t block_patches;
	double delta[RELIEF_MAX_LEVELS];
	/* Not stored: derived from the fields above by relief_index_windows(). From version 6
	 * the index holds records for the patches of each level l whose footprint starts
	 * inside the raster, px < index_cols[l] and py < index_rows[l], level-major and
	 * row-major within that window starting at record index_first[l]; every other patch
	 * is EMPTY and has no record. Before version 6 the windows are whole levels. A patch's
	 * parent lies in its level's window whenever the patch lies in its own. */
	uint32_t index_cols[RELIEF_MAX_LEVELS], index_rows[RELIEF_MAX_LEVELS], index_first[RELIEF_MAX_LEVELS];
	uint32_t index_records; /* records in the index */
};

struct relief_patch_record {
	uint64_t offset; /* in the data section */
	uint32_t size;
	uint32_t crc;
	float height_min, height_max; /* reconstructed interior samples, metres */
	float error;                  /* Err(P), metres: the codec's bound against the original */
	uint32_t flags;
	uint32_t mask_offset, mask_size; /* coded mask in the mask section (MASKED only) */
	/* The drawn error E0(P), metres: the largest vertical distance from the patch drawn at
	 * full detail (its own samples, either diagonal in each cell) to the finest decoded
	 * surface (either diagonal), over the finest samples and cell centres of its live cells
	 * (computed with the block errors, relief_block_errors()). The coarse selection holds a patch's full-detail blocks
	 * with it (docs/lod.md). Stored from version 7; for older files relief_file_record()
	 * gives relief_draw_error_bound(), which bounds it from Err(P). */
	float draw_error;
};

/* Block errors per patch (one byte each on disk, see relief_block_error_encode()). */
size_t relief_block_errors_per_patch(uint32_t patch_size);
/* Block height ranges per patch, as floats: low and high of each block (from version 4 one
 * byte per block on disk, see relief_block_range_encode()). */
size_t relief_block_ranges_per_patch(uint32_t patch_size);
/* Bytes per patch in the block section: its errors, then (version 4) its height ranges. */
size_t relief_block_bytes_per_patch(uint32_t version, uint32_t patch_size);
/* The unit of block error codes (relief_block_error_encode()), metres, for a file whose
 * largest block error is `largest`: tolerance / 64, or more where the codes would not reach
 * `largest` with it (the largest finite code stands for about 57,500 units). Before version
 * 8 every file used tolerance / 64, so a block error over about 900 tolerances was stored
 * as +infinity and that block drawn at full detail at any distance (on Puget Sound at 1 m,
 * 17 of the root patch's 64 blocks). */
double relief_block_error_unit(double tolerance, double largest);

/* Serialises / parses the 512-byte header (parse checks magic, version, sizes, ranges and
 * the header CRC, and fills `lay`). */
void relief_header_write(const struct relief_header *h, uint8_t *out);
int relief_header_parse(const uint8_t *buf, size_t size, struct relief_header *h, struct relief_layout *lay,
                        char *err, size_t err_size);
/* Fills the header's index windows from its version, levels, patch size and extent. */
void relief_index_windows(struct relief_header *h);
/* Patch id's entry: its record number in the index, or UINT32_MAX for a patch outside its
 * level's window (EMPTY, no record) and for an id beyond the tree (>= patch_count: it
 * falls below the finest level's rows). Entries also number the per-patch
 * arrays of the GPU cache and the selection, so that they follow the data too. */
uint32_t relief_index_entry(const struct relief_header *h, uint32_t id);
/* The patch id of entry e < index_records (the inverse). */
uint32_t relief_index_patch(const struct relief_header *h, uint32_t e);
/* Index record bytes of a file of this version. */
size_t relief_index_record_size(uint32_t version);
/* Writes a current-version record (RELIEF_INDEX_RECORD_SIZE bytes). */
void relief_record_write(const struct relief_patch_record *r, uint8_t *out);
/* Reads a record of a file of `version`; before version 7 draw_error is Err(P) as stored
 * (relief_file_record() turns it into the bound). */
void relief_record_read(const uint8_t *in, uint32_t version, struct relief_patch_record *r);

struct relief_file {
	struct relief_header hdr;
	struct relief_layout layout;
	const uint8_t *meta;   /* bytes [0, data_offset): owned copy, or the borrowed image */
	uint8_t *meta_owned;
	const uint8_t *image;  /* memory images only: the whole file (borrowed) */
	int fd;                /* files only: CLOEXEC, for pread(); -1 for memory images */
	uint32_t max_stream;   /* largest patch stream, bytes */
	uint32_t *block_slot;  /* per index record: its patch's record in the block section; UINT32_MAX: none
	                        * (EMPTY, from version 5) */
	uint8_t *gaps;         /* per index record: 1 where some finest sample under the patch's footprint is
	                        * no-data or past the raster (relief_file_patch_gaps()) */
	char *crs;             /* NUL-terminated copy of the CRS text (may be empty) */
	char *path;            /* files only: the path it was opened with (for messages) */
};

/* Opens and validates a file. err receives a one-line reason on failure. */
int relief_file_open(const char *path, struct relief_file **out, char *err, size_t err_size);
/* Validates a file image in memory; the buffer is borrowed and must outlive the file. */
int relief_file_open_memory(const void *buf, size_t size, struct relief_file **out, char *err, size_t err_size);
void relief_file_close(struct relief_file *f);
/* What messages call the file: its path, or "(memory image)". */
const char *relief_file_name(const struct relief_file *f);

void relief_file_record(const struct relief_file *f, uint32_t id, struct relief_patch_record *r);
/* Whether some finest sample under patch id's footprint is no-data or lies past the
 * raster (a finest patch under it is MASKED or EMPTY): where a coarser level's coverage
 * differs from the finest level's (relief_patch_coverage_error(), lod.h). True for a patch
 * without a record. Derived from the index when the file is opened. */
bool relief_file_patch_gaps(const struct relief_file *f, uint32_t id);
/* The drawn error E0(P) of record r (as relief_file_record() gives it) where the file
 * measured it (version 7 on), metres; else +infinity: the bound relief_file_record() gives
 * older files holds only where the patch's samples are valid, which a bound over every
 * block (the transition strips', strip_bound.h) cannot assume. */
float relief_file_measured_draw_error(const struct relief_file *f, const struct relief_patch_record *r);
/* Reads patch id's stream into buf (at least max_stream bytes) and checks its CRC:
 * -EBADMSG on mismatch, -EIO if the file no longer holds it, -ENOENT for an empty patch. */
int relief_file_read_stream(const struct relief_file *f, uint32_t id, uint8_t *buf, size_t *size);
/* Decoded block errors: for each block and d = 1..4, an upper bound in metres on the
 * distance of the block drawn at level d from the finest decoded surface (versions 2 and 3:
 * the stored value plus Err(P), the paper's sum, a bound against the original samples);
 * +infinity means "never simplify". */
void relief_file_block_errors(const struct relief_file *f, uint32_t id, float *eps);
/* Each block's height range (low, high; metres), bounds on every sample of the block, so
 * on the block drawn at any level (versions 2 and 3: the patch's range for every block). */
void relief_file_block_ranges(const struct relief_file *f, uint32_t id, float *range);
/* The samples patch id's stream codes: relief_patch_window() from version 3 on, the whole
 * patch in version 2. */
void relief_file_window(const struct relief_file *f, uint32_t id, struct relief_window *win);
/* 1 byte per interior sample (P x P), 1 = valid. -EBADMSG for a corrupt mask. */
int relief_file_mask(const struct relief_file *f, uint32_t id, uint8_t *mask);
/* Whether each block of a patch (blocks^2 bytes, raster order) has a valid sample among
 * its (16 + 1)^2, from the patch's validity bytes (relief_file_mask()). A renderer that
 * hides no-data per fragment by the nearest sample shows nothing of a block without one:
 * every point of the block is nearest to one of its own samples. */
void relief_mask_blocks(const uint8_t *mask, uint32_t patch_size, uint8_t *has_data);
