/* CPU reference decoder over an opened .relief file.
 *
 * Decoding walks the tree: a patch needs its parent's decoded E x E block (with ring).
 * An empty patch (no valid sample below it) has no stream and decodes as all-zero labels
 * and residuals, i.e. its parent interpolated; it is never drawn. */
#pragma once

#include <stdint.h>

#include "format.h"

struct relief_decoder {
	const struct relief_file *file; /* borrowed */
	uint8_t *stream;                /* max_stream bytes */
	int8_t *labels;
	int32_t *residuals;
};

int relief_decoder_init(struct relief_decoder *d, const struct relief_file *f);
void relief_decoder_finish(struct relief_decoder *d);

/* Entropy stage only (what the GPU path runs on the CPU): labels and residuals of patch id.
 * -EBADMSG for a CRC mismatch or a corrupt stream, -EIO when the file lost the stream. */
int relief_decoder_symbols(struct relief_decoder *d, uint32_t id);
/* Full decode of patch id into `block` (E x E) from its parent's block (NULL for the root). */
int relief_decoder_patch(struct relief_decoder *d, uint32_t id, const int32_t *parent, int32_t *block);

/* Decodes levels 0..level; blocks_out receives level `level`'s blocks, E*E values each,
 * for the patches with an index entry, in entry order (patch id's block is number
 * relief_index_entry(id) - index_first[level]; free() it), so that a long, narrow raster's
 * levels cost what its data does. threads: 0 = every core. Empty patches are not decoded
 * (the file guarantees that their descendants are empty too): their blocks are zero, and
 * none of their samples is valid. */
int relief_decode_level_blocks(const struct relief_file *f, uint32_t level, unsigned threads, int32_t **blocks_out);

/* Assembles level `level` as heights in metres over the raster's extent at that level
 * (width_l x height_l, see relief_level_extent) and its validity mask (1 byte per sample,
 * may be NULL). No-data samples get NAN. */
void relief_level_extent(const struct relief_header *h, uint32_t level, uint32_t *w, uint32_t *hgt);
int relief_decode_level(const struct relief_file *f, uint32_t level, unsigned threads, float *heights,
                        uint8_t *mask);
/* The same with every sample's decoded height, no-data ones too: what a renderer
 * interpolates towards in the half cell it keeps beside a valid sample (docs/codec.md,
 * "No-data"); `mask` says which samples are valid. */
int relief_decode_level_drawn(const struct relief_file *f, uint32_t level, unsigned threads, float *heights,
                              uint8_t *mask);
