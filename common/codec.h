/* The patch codec of Yusov & Shevtsov 2011 (docs/codec.md; ../design notes §2).
 *
 * Values are quantised heights: q = round(h / (2 delta_l)) in units of the level's
 * quantum 2*delta_l, so |h - 2 delta_l q| <= delta_l.
 *
 * A patch has P = 2^n + 1 samples per side plus a one-sample ring for seamless normals:
 * local indices -1..P, stored row-major in an E x E array (E = P + 2) at [(y+1)E + x+1].
 * Local parity equals global parity (patch origins are multiples of P - 1), so:
 *  - refined samples (x, y both even, inside [0, P-1]) coincide with parent samples:
 *    q = k * q_parent + r with a 3-symbol label r in {-1, 0, 1} (k = the tolerance ratio);
 *  - every other sample (all ring samples included) is predicted from the refined values
 *    around it, in integers with one rounding rule (round half up):
 *      edge midpoint: (a + b + 1) >> 1, cell centre: (a + b + c + d + 2) >> 2,
 *    and stored as the residual q - prediction.
 *    Refined neighbours outside the patch (local -2 and P+1) use k * q_parent (no label).
 * The root patch has no parent: all E*E values are coded as residuals of the MED
 * (LOCO-I) predictor in raster order.
 *
 * Bounds that make decoding of hostile streams safe in int32: every decoded value must
 * satisfy |q| <= RELIEF_Q_MAX (checked), residual magnitudes are < 2^29 by construction of
 * the entropy code, so no intermediate overflows.
 */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rangecoder.h"

#define RELIEF_Q_MAX (1 << 26)

struct relief_patch_geom {
	uint32_t P;       /* samples per side: 65, 129 or 257 */
	uint32_t E;       /* P + 2, with the ring */
	uint32_t half;    /* (P - 1) / 2: a child's offset inside its parent */
	uint32_t L;       /* (P + 1) / 2: labels per side */
	uint32_t R;       /* (P + 5) / 2: refined values per side, local -2..P+1 */
	uint32_t n_labels;    /* L * L */
	uint32_t n_residuals; /* E * E - L * L */
};

#define RELIEF_PATCH_MAX 4097u

/* 0 or -EINVAL when P is not 2^n + 1 with 3 <= P <= RELIEF_PATCH_MAX. */
int relief_patch_geom_init(struct relief_patch_geom *g, uint32_t P);

/* quadrant: bit 0 = east half, bit 1 = south half of the parent (rows grow southwards). */

/* Encoder side: splits a child's E*E values into labels and residuals given its parent's
 * E*E values. -ERANGE when a label falls outside {-1, 0, 1} (the child was not quantised
 * from this parent). */
int relief_patch_analyse(const struct relief_patch_geom *g, uint32_t ratio, unsigned quadrant,
                         const int32_t *parent, const int32_t *child, int8_t *labels, int32_t *residuals);

/* CPU reference reconstruction; the GPU decoder performs the same integer arithmetic.
 * -EBADMSG when a value leaves [-RELIEF_Q_MAX, RELIEF_Q_MAX] (corrupt input); `out` is then
 * partially written. */
int relief_patch_reconstruct(const struct relief_patch_geom *g, uint32_t ratio, unsigned quadrant,
                             const int32_t *parent, const int8_t *labels, const int32_t *residuals,
                             int32_t *out);

/* Root patch: residuals of the MED predictor (E*E of them). relief_root_predict() is the
 * prediction of value (x, y) (storage indices) from the values before it in raster order. */
int32_t relief_root_predict(const int32_t *q, uint32_t E, uint32_t x, uint32_t y);
void relief_root_analyse(const struct relief_patch_geom *g, const int32_t *q, int32_t *residuals);
int relief_root_reconstruct(const struct relief_patch_geom *g, const int32_t *residuals, int32_t *out);

/* Validity masks (P x P bytes, 0 or 1), coded with adaptive binary models whose context is
 * the left and upper neighbours' validity. Decoding returns -EBADMSG on a truncated stream. */
int relief_mask_encode(uint32_t P, const uint8_t *mask, uint8_t **out, size_t *out_size);
int relief_mask_decode(uint32_t P, const uint8_t *buf, size_t size, uint8_t *mask);

/* The samples a patch stream codes: local x in [x0, x1) and y in [y0, y1), inside
 * [-1, P+1); with ring_west also the whole column x = -1, with ring_north the whole row
 * y = -1. Labels and residuals of the samples outside are 0 and take no symbol: the stream
 * of a patch at the raster's east or south edge skips the padding beyond the valid extent
 * (format version 3, docs/format.md; relief_patch_window() in layout.h). The root patch
 * codes its values in raster order, so its window is a plain rectangle (the ring flags do
 * not apply). */
struct relief_window {
	int32_t x0, y0, x1, y1;
	bool ring_west, ring_north;
};

/* The whole patch, ring included. */
void relief_window_full(const struct relief_patch_geom *g, struct relief_window *w);

/* Entropy stage. A patch stream codes its labels (none for the root) then its residual
 * planes, with adaptive models whose contexts come only from symbols of the same stream
 * (so entropy decoding needs no parent data). win NULL = the whole patch. Encoding returns
 * -EINVAL when a label or residual outside the window is not 0. */
int relief_patch_encode(const struct relief_patch_geom *g, bool root, const struct relief_window *win,
                        const int8_t *labels, const int32_t *residuals, uint8_t **out, size_t *out_size);
/* -EBADMSG on a corrupt or truncated stream; values outside the window are set to 0. */
int relief_patch_decode_symbols(const struct relief_patch_geom *g, bool root, const struct relief_window *win,
                                const uint8_t *buf, size_t size, int8_t *labels, int32_t *residuals);
