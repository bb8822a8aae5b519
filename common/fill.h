/* Hole filling for geometry under no-data (docs/codec.md §No-data).
 *
 * Pull-push (Gortler et al. 1996): valid samples are averaged up a pyramid of halving
 * resolution (each coarse sample the weighted mean of its 2x2 children, weight = number
 * of valid samples below it, capped at 1); then, from the coarsest level down, every
 * sample with weight w < 1 becomes w * own + (1 - w) * bilinear(coarser level). Valid
 * samples are kept bit for bit; holes and the padding beyond the raster get a smooth
 * surface that meets the valid terrain without steps. Heights under no-data are never
 * taken from the no-data value itself.
 */
#pragma once

#include <stdint.h>

/* in: w x h heights (row-major, row 0 north), valid: 1 byte per sample (non-zero = valid).
 * out: size x size (size >= w, h); the raster occupies its top-left corner.
 * -ENODATA when no sample is valid, -ENOMEM. */
int relief_fill(const float *in, const uint8_t *valid, uint32_t w, uint32_t h, uint32_t size, float *out);
