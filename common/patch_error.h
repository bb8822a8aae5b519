/* Error bounds of a reconstructed patch (docs/codec.md §Errors).
 *
 * The surface drawn for a patch is a triangulation of its samples in which the diagonal
 * of each cell is the tessellator's choice. Both bounds below hold for either diagonal in
 * every cell:
 *
 * Err(P): the largest |surface(s) - h(s)| over the valid full-resolution samples s in the
 *   patch's footprint, measured directly against the original (not through the paper's
 *   recursion Err_Int + max Err_Appr(child) + delta_l, which it never exceeds). It already
 *   contains the patch's quantisation error.
 *
 * Block error eps_d (d = 1..4), format version 4: the largest vertical distance, over the
 *   block's footprint, between the block triangulated on every 2^d-th patch sample and the
 *   finest decoded surface (the finest level's reconstruction, which is what a frame at full
 *   detail draws). The difference of two piecewise-linear surfaces peaks at a vertex of
 *   their overlay; for grid-aligned triangulations those are the finest samples and the
 *   finest cells' centres, where both diagonal choices of both surfaces are evaluated. Only
 *   finest cells with a valid corner count (a fragment is drawn only where its nearest
 *   sample is valid), with all four corners and the centre. The bound is measured directly,
 *   so it needs no Err(P) added: for a patch above the finest level it is often far below
 *   the paper's eps_d + Err(P) (which adds the patch's worst error anywhere to every block),
 *   and at the finest level it leaves out the codec's error, which is the tolerance's to
 *   state, not the level of detail's (docs/lod.md).
 *   Versions 2 and 3 stored eps_d against the patch's own full triangulation;
 *   relief_file_block_errors() adds Err(P) to those, so readers see one meaning.
 */
#pragma once

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "layout.h"

/* Smallest float >= v: a bound stored as float never rounds below what was measured. */
static inline float relief_float_up(double v)
{
	float f = (float)v;
	if ((double)f < v)
		f = nextafterf(f, INFINITY);
	return f;
}

/* Patch heights in metres over its P x P interior samples (row-major), built by the caller
 * from the quantised block: h = 2 delta_l q. */

/* The full-resolution original: size_L-grid coordinates, only [0, w) x [0, h) exists. */
struct relief_original {
	const float *heights;   /* w x h, row-major */
	const uint8_t *valid;   /* w x h, non-zero = valid */
	uint32_t w, h;
};

/* Err(P) for patch (l, px, py); 0 when no valid sample lies in its footprint.
 * *valid_count receives the number of valid original samples in the footprint. */
double relief_patch_error(const struct relief_layout *lay, uint32_t l, uint32_t px, uint32_t py,
                          const double *patch_heights, const struct relief_original *orig,
                          uint64_t *valid_count);

/* Stored block errors are one byte each, a logarithmic code that rounds up, so a stored
 * bound is never below the measured one (and at most 2^(1/16) - 1 = 4.4% above it, or one
 * unit where it is smaller than that):
 *   0: 0;  c in 1..254: unit * 2^((c - 1) / 16);  255: +infinity (never simplify).
 * The codes span 1 to 2^(253/16), about 57,500, units. The unit is the file's
 * (relief_block_error_unit(): tolerance / 64, larger where the file's largest block error
 * needs it, from format version 8), so no measured error is stored as +infinity. */
#define RELIEF_BLOCK_CODE_INF 255
uint8_t relief_block_error_encode(double e, double unit);
float relief_block_error_decode(uint8_t code, double unit);

/* A block's height range is one byte, two 4-bit codes within its patch's [lo, hi] (the
 * index record's heights): code c stands for lo + c (hi - lo) / 15, rounded down for the low
 * end (`high` false, bits 0-3) and up for the high end (bits 4-7), and the encoder picks
 * the codes so that the decoded range contains [bmin, bmax]. The fine LOD projects error
 * segments at the top (or bottom) of it (docs/lod.md); a sixteenth of the patch's range is
 * precise enough for that, and a byte per block keeps small files small. */
#define RELIEF_BLOCK_RANGE_STEPS 15
uint8_t relief_block_range_encode(double v, float lo, float hi, bool high);
float relief_block_range_decode(uint8_t code, float lo, float hi, bool high);

/* range[(by * blocks + bx) * 2 + {0, 1}]: the lowest and highest of the block's (16 + 1)^2
 * samples among the patch's P x P heights. */
void relief_block_heights(const struct relief_layout *lay, const double *patch_heights, double *range);

/* The finest decoded surface: the finest level's quantised grid times its quantum (2
 * delta_L), and the original's validity. */
struct relief_finest {
	const struct relief_qgrid *grid;
	double q2;
	const struct relief_original *orig; /* valid, w, h */
};

/* eps[(by * blocks + bx) * 4 + (d - 1)] for every block of patch (l, px, py), whose P x P
 * heights are patch_heights. 0 for a block without a valid sample. *drawn receives the
 * patch's drawn error E0(P) (format.h), the same measure at d = 0 (the patch's own cells)
 * taken over all its blocks. -ENOMEM or 0. */
int relief_block_errors(const struct relief_layout *lay, uint32_t l, uint32_t px, uint32_t py,
                        const double *patch_heights, const struct relief_finest *fin, double *eps, double *drawn);

/* A bound on E0(P) from Err(P) for files that do not store E0 (format versions before 7),
 * for a patch above the finest level whose cells are n = 2^(L-1-l) finest cells wide
 * (n >= 2), delta_L the finest level's tolerance: (1 + 2/n) Err(P) + delta_L.
 * Why: at a finest sample the patch is within Err(P) of the original (any diagonal) and the
 * original within delta_L of the finest decoded surface. At a finest cell's centre where the
 * patch is linear across the cell, its value is the mean of the ends of either diagonal,
 * so within Err(P) + delta_L too. Otherwise the patch's cell diagonal runs along one of the
 * finest cell's diagonals (a'b'), and the finest surface may take the other (ab). The
 * patch p at the centre is (p(a') + p(b')) / 2, the finest surface (f(a) + f(b)) / 2, so
 * the difference is the mean of p - f at a and b (each within Err(P) + delta_L) plus
 * (p(a') + p(b') - p(a) - p(b)) / 2, which is +-T / 2n for the patch cell's twist
 * T = h00 + h11 - h10 - h01 (p bends along its diagonal by T / n per finest cell); the
 * patch cell's centre is a finest sample where its two diagonals' values differ by T / 2,
 * both within Err(P) of the original, so |T| <= 4 Err(P). It needs the samples involved
 * to be valid; next to no-data it is not a bound. The selection uses it where a file does
 * not have E0. */
double relief_draw_error_bound(double err, uint32_t n, double delta_finest);

/* Value of the triangulated cell with corners h00 (u=v=0), h10, h01, h11 at (u, v) in
 * [0,1]^2, under the diagonal 00-11 (diag = 0) or 10-01 (diag = 1). */
static inline double relief_cell_value(double h00, double h10, double h01, double h11, double u, double v, int diag)
{
	if (diag == 0)
		return u >= v ? h00 + u * (h10 - h00) + v * (h11 - h10) : h00 + v * (h01 - h00) + u * (h11 - h01);
	return u + v <= 1.0 ? h00 + u * (h10 - h00) + v * (h01 - h00)
	                    : h11 + (1.0 - u) * (h01 - h11) + (1.0 - v) * (h10 - h11);
}
