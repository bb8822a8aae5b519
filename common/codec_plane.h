/* The residual planes of a patch, shared by the prediction (codec.c) and the entropy
 * coding (codec_entropy.c): internal to relief-common. */
#pragma once

#include <stdint.h>

#include "codec.h"

/* Residual planes, in stream order: H (y even inside, x odd incl. ring), V (y odd incl.
 * ring, x even inside), C (x and y odd incl. ring). Dimensions w x h each. */
struct plane {
	uint32_t w, h;
	int x0, y0; /* local coordinates of the plane's first sample; step 2 */
};

static inline void planes(const struct relief_patch_geom *g, struct plane p[3])
{
	uint32_t odd = (g->P + 3) / 2; /* odd local indices in [-1, P] */
	uint32_t even = g->L;          /* even local indices in [0, P-1] */
	p[0] = (struct plane){ odd, even, -1, 0 };
	p[1] = (struct plane){ even, odd, 0, -1 };
	p[2] = (struct plane){ odd, odd, -1, -1 };
}
