#include <math.h>
#include <stddef.h>

#include "normals.h"

/* packSnorm4x8's rounding of one component of a unit vector, round(clamp(v, -1, 1) * 127),
 * to nearest with ties to even like the default rounding mode: adding and subtracting
 * 1.5 * 2^23 rounds a float of magnitude below 2^22 to an integer. No clamp: a component of
 * a normalised vector is at most 1 plus a few ulps, which rounds to 127 all the same.
 * Branch-free, so the row loop vectorises. */
static inline uint32_t snorm8(float v)
{
	float r = (v * 127.0f + 12582912.0f) - 12582912.0f;
	return (uint32_t)(int32_t)r & 0xffu;
}

void relief_normals_pack(const struct relief_file *f, uint32_t level, const int32_t *block, const uint8_t *mask,
                         uint32_t *out)
{
	const struct relief_layout *lay = &f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E;
	const double step = (double)(1u << (lay->levels - 1 - level));
	/* The same float factors patch_gpu.c hands the shader. */
	const float q2 = (float)(2.0 * lay->delta[level]);
	const float sx = q2 * (float)(1.0 / (2.0 * f->hdr.spacing_x * step));
	const float sy = q2 * (float)(1.0 / (2.0 * f->hdr.spacing_y * step));
	for (uint32_t y = 0; y < P; y++) {
		/* row y from its ring sample -1 (so that sample x is c[x + 1]) and, from sample 0,
		 * the rows north and south of it; rows grow southwards, world y (north) is up */
		const int32_t *restrict c = block + (size_t)(y + 1) * E;
		const int32_t *restrict n = c - E + 1, *restrict s = c + E + 1;
		uint32_t *restrict o = out + (size_t)y * P;
#pragma GCC ivdep /* out never overlaps block */
		for (uint32_t x = 0; x < P; x++) {
			float dx = (float)(c[x + 2] - c[x]) * sx, dy = (float)(n[x] - s[x]) * sy;
			float inv = 1.0f / sqrtf(dx * dx + dy * dy + 1.0f);
			o[x] = snorm8(-dx * inv) | snorm8(-dy * inv) << 8 | snorm8(inv) << 16 | 127u << 24; /* w: valid */
		}
		if (mask) {
			const uint8_t *restrict m = mask + (size_t)y * P;
			for (uint32_t x = 0; x < P; x++) /* w: snorm8 of 1 or -1 */
				o[x] = (o[x] & 0xffffffu) | (m[x] ? 127u : 0x81u) << 24;
		}
	}
}
