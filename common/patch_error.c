#include <math.h>

#include "patch_error.h"

double relief_patch_error(const struct relief_layout *lay, uint32_t l, uint32_t px, uint32_t py,
                          const double *ph, const struct relief_original *orig, uint64_t *valid_count)
{
	const uint32_t P = lay->geom.P, cells = P - 1;
	const uint32_t step = 1u << (lay->levels - 1 - l); /* full-res samples per patch cell */
	const uint64_t x0 = (uint64_t)px * cells * step, y0 = (uint64_t)py * cells * step;
	const uint64_t span = (uint64_t)cells * step;
	double worst = 0.0;
	uint64_t count = 0;
	for (uint64_t Y = y0; Y <= y0 + span && Y < orig->h; Y++) {
		uint64_t cy = (Y - y0) / step;
		if (cy >= cells)
			cy = cells - 1;
		double v = (double)(Y - y0) / step - (double)cy;
		for (uint64_t X = x0; X <= x0 + span && X < orig->w; X++) {
			size_t oi = (size_t)Y * orig->w + X;
			if (!orig->valid[oi])
				continue;
			count++;
			uint64_t cx = (X - x0) / step;
			if (cx >= cells)
				cx = cells - 1;
			double u = (double)(X - x0) / step - (double)cx;
			const double *c = ph + cy * P + cx;
			double h = orig->heights[oi];
			for (int diag = 0; diag < 2; diag++) {
				double s = relief_cell_value(c[0], c[1], c[P], c[P + 1], u, v, diag);
				double e = fabs(s - h);
				if (e > worst)
					worst = e;
			}
		}
	}
	*valid_count = count;
	return worst;
}

/* Coarse (step s) triangulated value at fine sample offset (i, j) inside the block whose
 * top-left sample is b, at fractional fine offsets (fu, fv) within the fine cell. */
static double coarse_value(const double *b, uint32_t P, uint32_t s, uint32_t i, uint32_t j, double fu, double fv,
                           int diag)
{
	uint32_t ci = i / s, cj = j / s;
	if (ci * s == RELIEF_BLOCK_CELLS)
		ci--;
	if (cj * s == RELIEF_BLOCK_CELLS)
		cj--;
	double u = ((double)(i - ci * s) + fu) / s, v = ((double)(j - cj * s) + fv) / s;
	const double *c = b + (size_t)cj * s * P + ci * s;
	return relief_cell_value(c[0], c[s], c[(size_t)s * P], c[(size_t)s * P + s], u, v, diag);
}

void relief_block_errors(const struct relief_layout *lay, const double *ph, double *eps)
{
	const uint32_t P = lay->geom.P, B = RELIEF_BLOCK_CELLS;
	for (uint32_t by = 0; by < lay->blocks; by++)
		for (uint32_t bx = 0; bx < lay->blocks; bx++) {
			const double *b = ph + (size_t)by * B * P + bx * B;
			for (uint32_t d = 1; d <= RELIEF_BLOCK_LEVELS; d++) {
				uint32_t s = 1u << d;
				double worst = 0.0;
				for (uint32_t j = 0; j <= B; j++)
					for (uint32_t i = 0; i <= B; i++) {
						double h = b[(size_t)j * P + i];
						for (int dc = 0; dc < 2; dc++) {
							/* at the sample */
							worst = fmax(worst, fabs(h - coarse_value(b, P, s, i, j, 0, 0, dc)));
							if (i == B || j == B)
								continue;
							/* at the centre of fine cell (i, j), both fine diagonals */
							const double *c = b + (size_t)j * P + i;
							double f0 = 0.5 * ((double)c[0] + c[P + 1]);
							double f1 = 0.5 * ((double)c[1] + c[P]);
							double cv = coarse_value(b, P, s, i, j, 0.5, 0.5, dc);
							worst = fmax(worst, fmax(fabs(f0 - cv), fabs(f1 - cv)));
						}
					}
				eps[((size_t)by * lay->blocks + bx) * RELIEF_BLOCK_LEVELS + (d - 1)] = worst;
			}
		}
}

float relief_block_error_decode(uint8_t code, double unit)
{
	if (code == 0)
		return 0.0f;
	if (code == RELIEF_BLOCK_CODE_INF)
		return INFINITY;
	return relief_float_up(unit * exp2((code - 1) / 16.0));
}

uint8_t relief_block_error_encode(double e, double unit)
{
	if (!(e > 0))
		return 0;
	double c = 1.0 + ceil(16.0 * log2(e / unit));
	if (c < 1)
		c = 1;
	if (!(c < RELIEF_BLOCK_CODE_INF)) /* also NaN */
		return RELIEF_BLOCK_CODE_INF;
	uint8_t code = (uint8_t)c;
	while (code < RELIEF_BLOCK_CODE_INF && relief_block_error_decode(code, unit) < e)
		code++; /* guard against log2/exp2 rounding */
	return code;
}
