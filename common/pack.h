/* Building a .relief image from an elevation model: pyramid by decimation, per-level
 * quantisation over a window around the data (no-data samples beside the data filled,
 * the rest predicted: common/fill.h), patch coding,
 * error bounds, container assembly. */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dem.h"
#include "layout.h"

struct relief_pack_options {
	uint32_t patch;     /* 65, 129 or 257 */
	uint32_t ratio;     /* 2 or 3 */
	double tolerance;   /* delta_L, metres */
	unsigned threads;   /* 0 = every core */
	/* Called (from any worker thread, serialised) after each patch coded: `total` counts
	 * the patches with an index entry (over the raster); the others are EMPTY by position. */
	void (*progress)(void *data, uint32_t done, uint32_t total, uint64_t bytes);
	void *progress_data;
	/* tests: quantise every level whole instead of its window around the data (the file
	 * must come out the same byte for byte) */
	bool whole_levels;
	/* The format version to write: 0 = RELIEF_FORMAT_VERSION, or 8 for readers built
	 * before version 9 (the windows without their rim: past the raster's east and south
	 * edges some levels' first padding column then keeps the prediction). Others are
	 * refused (-EINVAL). */
	uint32_t version;
};

struct relief_pack_stats {
	uint32_t levels, patches, empty_patches, masked_patches;
	uint64_t bytes, stream_bytes;
	uint64_t quantised_samples; /* in the levels' windows, rings included */
	/* Largest |original - reconstruction| per level over valid samples, measured. */
	double max_error[RELIEF_MAX_LEVELS];
};

/* -EINVAL bad options or DEM, -ENODATA no valid sample, -ERANGE heights too large for the
 * tolerance (|h| / (2 delta_L) must stay below 2^24), -ENOMEM. */
int relief_pack_memory(const struct relief_dem *dem, const struct relief_pack_options *opts,
                       uint8_t **out, size_t *out_size, struct relief_pack_stats *stats);
/* Samples the packer quantises for a width x height raster in layout `lay`: every level's
 * window around the data, rings included (relief_pack_stats.quantised_samples). Each
 * costs 4 bytes while packing. */
uint64_t relief_pack_quantised_samples(const struct relief_layout *lay, uint32_t width, uint32_t height);
/* Writes atomically: a temporary file in the same folder, fsync, rename. An existing file
 * at `path` stays intact if anything fails. */
int relief_pack_write(const char *path, const uint8_t *data, size_t size);
