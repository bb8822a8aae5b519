/* Heights for no-data samples, chosen by the packer (docs/codec.md, "No-data").
 *
 * A no-data sample is never drawn, but its value is still part of the surface: the
 * renderer keeps a fragment wherever its nearest sample is valid, so the half cell beyond
 * the last valid sample is drawn leaning towards the no-data neighbour's value, and that
 * neighbour enters the valid sample's normal. The packer therefore codes the no-data
 * samples beside the data (within one of their level's spacings: level_target() in
 * common/pack.c) from these heights.
 *
 * The fill grows outwards from the data into the no-data ring by ring (8-neighbourhood):
 * each sample of a ring takes the mean of its neighbours filled before that ring, so
 *   - valid samples are copied bit for bit;
 *   - a no-data sample next to valid ones lies within [min, max] of those valid
 *     neighbours (the rim is drawn at the data's own heights, no wall to an arbitrary
 *     value);
 *   - every filled value lies within [min, max] of the valid heights (means of means), so
 *     the packer's range check on valid samples still holds for the filled ones.
 * O(w h) time; the rings are index lists of at most the samples of one ring each.
 */
#pragma once

#include <stdint.h>

/* heights, valid: w x h, row-major. out (w x h) receives the heights where valid and the
 * fill elsewhere; it may be `heights` itself. ring_of (w x h, may be NULL) receives each
 * sample's ring: 0 where valid, k for the k-th ring, which is the Chebyshev distance in
 * samples to the nearest valid sample (UINT16_MAX for that or more). Returns 0, -ENODATA
 * when no sample is valid, -ENOMEM. */
int relief_fill_nodata(uint32_t w, uint32_t h, const float *heights, const uint8_t *valid, float *out,
                       uint16_t *ring_of);
