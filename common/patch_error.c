#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

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

static bool finest_valid(const struct relief_original *o, uint64_t X, uint64_t Y)
{
	return X < o->w && Y < o->h && o->valid[Y * o->w + X];
}

static inline double dmax(double a, double b) { return a > b ? a : b; }

/* The largest distance between the block at level d (triangulated on every s-th patch
 * sample from its north-west sample b, row stride P, each patch cell `step` finest cells
 * wide) and the finest surface, over the block's live finest samples and cell centres
 * (`live`, rows of ls bytes, see below; none beyond column iw or row jh). Coarse cell by coarse
 * cell, so that its corners are read once; each finest sample belongs to the coarse cell
 * to its south-east (the last cell takes the block's east and south edges), each finest
 * cell centre to the one holding it. */
static double block_level_error(const double *b, uint32_t P, uint32_t s, uint32_t step, const uint8_t *live,
                                size_t ls, uint32_t iw, uint32_t jh, const struct relief_finest *fin, uint64_t X0,
                                uint64_t Y0)
{
	const uint32_t C = s * step, cells = RELIEF_BLOCK_CELLS / s;
	const size_t st = (size_t)fin->grid->w + 2;
	const double q2 = fin->q2;
	double worst = 0.0;
	for (uint32_t cj = 0; cj < cells && cj * C <= jh; cj++)
		for (uint32_t ci = 0; ci < cells && ci * C <= iw; ci++) {
			const double *c = b + (size_t)cj * s * P + ci * s;
			const double h00 = c[0], h10 = c[s], h01 = c[(size_t)s * P], h11 = c[(size_t)s * P + s];
			const uint32_t jn = cj + 1 == cells ? C : C - 1, in = ci + 1 == cells ? C : C - 1;
			for (uint32_t j = 0; j <= jn && cj * C + j <= jh; j++) {
				const uint32_t J = cj * C + j;
				const double v = (double)j / C, vc = ((double)j + 0.5) / C;
				for (uint32_t i = 0; i <= in && ci * C + i <= iw; i++) {
					const uint32_t I = ci * C + i;
					const uint8_t lv = live[(size_t)J * ls + I];
					if (!lv)
						continue;
					const int32_t *q = fin->grid->q + relief_qgrid_index(fin->grid, (int)(X0 + I), (int)(Y0 + J));
					const double h = q2 * q[0], u = (double)i / C;
					for (int dc = 0; dc < 2; dc++)
						worst = dmax(worst, fabs(h - relief_cell_value(h00, h10, h01, h11, u, v, dc)));
					if (!(lv & 2) || i == C || j == C)
						continue;
					/* the centre of finest cell (I, J), both of its diagonals */
					const double f0 = 0.5 * q2 * ((double)q[0] + q[st + 1]);
					const double f1 = 0.5 * q2 * ((double)q[1] + q[st]);
					const double uc = ((double)i + 0.5) / C;
					for (int dc = 0; dc < 2; dc++) {
						const double cv = relief_cell_value(h00, h10, h01, h11, uc, vc, dc);
						worst = dmax(worst, dmax(fabs(f0 - cv), fabs(f1 - cv)));
					}
				}
			}
		}
	return worst;
}

int relief_block_errors(const struct relief_layout *lay, uint32_t l, uint32_t px, uint32_t py, const double *ph,
                        const struct relief_finest *fin, double *eps, double *drawn)
{
	const uint32_t P = lay->geom.P, B = RELIEF_BLOCK_CELLS, step = 1u << (lay->levels - 1 - l);
	const uint32_t n = B * step; /* finest cells per block side */
	/* live[j][i] for the block's finest samples within the raster (j, i at most the
	 * raster's extent: a coarse block over a narrow raster is mostly beyond it; rows of ls
	 * bytes): bit 0 the sample is a corner of a cell with a valid corner, bit 1 cell (i, j)
	 * has a valid corner */
	const size_t ls = (size_t)(n < fin->orig->w ? n : fin->orig->w) + 1;
	const size_t rows = (size_t)(n < fin->orig->h ? n : fin->orig->h) + 1;
	uint8_t *live = malloc(ls * rows);
	if (!live)
		return -ENOMEM;
	*drawn = 0.0;
	for (uint32_t by = 0; by < lay->blocks; by++)
		for (uint32_t bx = 0; bx < lay->blocks; bx++) {
			const uint64_t X0 = ((uint64_t)px * (P - 1) + bx * B) * step, Y0 = ((uint64_t)py * (P - 1) + by * B) * step;
			double *e = eps + ((size_t)by * lay->blocks + bx) * RELIEF_BLOCK_LEVELS;
			if (X0 >= fin->orig->w || Y0 >= fin->orig->h) { /* beyond the raster: no valid sample */
				for (uint32_t d = 0; d < RELIEF_BLOCK_LEVELS; d++)
					e[d] = 0.0;
				continue;
			}
			/* A cell with a valid corner lies within the raster (i < iw, j < jh), its
			 * corners up to iw, jh: only that part of the block is looked at, so that a
			 * coarse block over a raster's padding costs what its data does. */
			const uint32_t iw = (uint32_t)(fin->orig->w - X0 < n ? fin->orig->w - X0 : n);
			const uint32_t jh = (uint32_t)(fin->orig->h - Y0 < n ? fin->orig->h - Y0 : n);
			for (uint32_t j = 0; j <= jh; j++)
				memset(live + (size_t)j * ls, 0, iw + 1);
			for (uint32_t j = 0; j < jh; j++)
				for (uint32_t i = 0; i < iw; i++) {
					bool any = false;
					for (uint32_t k = 0; k < 4 && !any; k++)
						any = finest_valid(fin->orig, X0 + i + (k & 1), Y0 + j + (k >> 1));
					if (!any)
						continue;
					uint8_t *c = live + (size_t)j * ls + i;
					c[0] |= 3;
					c[1] |= 1;
					c[ls] |= 1;
					c[ls + 1] |= 1;
				}
			const double *b = ph + (size_t)by * B * P + bx * B;
			for (uint32_t d = 1; d <= RELIEF_BLOCK_LEVELS; d++)
				e[d - 1] = block_level_error(b, P, 1u << d, step, live, ls, iw, jh, fin, X0, Y0);
			*drawn = dmax(*drawn, block_level_error(b, P, 1, step, live, ls, iw, jh, fin, X0, Y0));
		}
	free(live);
	return 0;
}

double relief_draw_error_bound(double err, uint32_t n, double delta_finest)
{
	return (1.0 + 2.0 / n) * err + delta_finest;
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

void relief_block_heights(const struct relief_layout *lay, const double *ph, double *range)
{
	const uint32_t P = lay->geom.P, B = RELIEF_BLOCK_CELLS;
	for (uint32_t by = 0; by < lay->blocks; by++)
		for (uint32_t bx = 0; bx < lay->blocks; bx++) {
			double lo = INFINITY, hi = -INFINITY;
			for (uint32_t j = 0; j <= B; j++)
				for (uint32_t i = 0; i <= B; i++) {
					double h = ph[(size_t)(by * B + j) * P + bx * B + i];
					lo = fmin(lo, h);
					hi = fmax(hi, h);
				}
			range[((size_t)by * lay->blocks + bx) * 2] = lo;
			range[((size_t)by * lay->blocks + bx) * 2 + 1] = hi;
		}
}

float relief_block_range_decode(uint8_t code, float lo, float hi, bool high)
{
	double v = (double)lo + ((double)hi - lo) * code / RELIEF_BLOCK_RANGE_STEPS;
	float f = (float)v;
	if (high ? (double)f < v : (double)f > v)
		f = nextafterf(f, high ? INFINITY : -INFINITY);
	return f;
}

uint8_t relief_block_range_encode(double v, float lo, float hi, bool high)
{
	if (!(hi > lo))
		return 0;
	const int top = RELIEF_BLOCK_RANGE_STEPS;
	double c = top * (v - lo) / ((double)hi - lo);
	int code = high ? (int)ceil(c) : (int)floor(c);
	code = code < 0 ? 0 : code > top ? top : code;
	/* guard against rounding: the decoded end must contain v */
	while (high && code < top && relief_block_range_decode((uint8_t)code, lo, hi, true) < v)
		code++;
	while (!high && code > 0 && relief_block_range_decode((uint8_t)code, lo, hi, false) > v)
		code--;
	return (uint8_t)code;
}
