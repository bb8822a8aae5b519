/* The normal map of a decoded patch on the CPU: the same central differences, float
 * arithmetic and packing as shaders/patch_normals.comp, so that `relief bench decode` can
 * say what a CPU decoder would also pay to fill the pool the renderer reads. The shader is
 * the one the renderer uses; this twin is checked against it (test_patch_cache) to within
 * one snorm8 step per component (normalisation rounds differently). */
#pragma once

#include <stdint.h>

#include "format.h"

/* Normals of the P x P samples of `block` (E x E quantised heights with the one-sample
 * ring, as relief_decoder_patch() writes it) of a patch at `level`: xyz of the unit normal
 * (x east, y north, z up) and validity in w (1 valid, -1 no-data; mask: P x P bytes,
 * NULL for all valid), packed as four snorm8 per uint32 like GLSL's packSnorm4x8(). */
void relief_normals_pack(const struct relief_file *f, uint32_t level, const int32_t *block, const uint8_t *mask,
                         uint32_t *out);
