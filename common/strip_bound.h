/* Transition strip bounds: how far the tessellator's transition triangles along a block
 * edge can lie from the block's own triangulation of the square they lie in, from a
 * patch's samples alone (docs/lod.md, "Transition triangles: what bounds them").
 * The decode computes them on the GPU (shaders/patch_strips.comp); this is its CPU twin,
 * the same arithmetic in the same order, for tests. Written by hand: the bound is this
 * project's own (the tessellator's strips are not something a library models). */
#pragma once

#include <stdint.h>

/* Floats per block and edge: [0..3] an edge at level e = 1..4 (segments of 2^e samples)
 * against any finer interior, [4..6] an edge at level e = 0..2 against an interior one
 * level coarser, [7] 0; metres. */
#define RELIEF_STRIP_FLOATS 8

/* The bounds of every block of a P-sample patch: `q` its quantised heights with the ring,
 * (P + 2)^2 in raster order (sample (x, y) at (y + 1) (P + 2) + x + 1), q2 metres per
 * quantum, `valid` P^2 bytes (0: no-data) or NULL (all valid). Writes blocks^2 x 4 x
 * RELIEF_STRIP_FLOATS floats to out: blocks in raster order, edges west, north, east,
 * south. A point whose samples include a no-data one is left out. */
void relief_strip_bounds(const int32_t *q, uint32_t P, float q2, const uint8_t *valid, float *out);
