/* Transition strip bounds: how far the tessellator's transition triangles along a block
 * edge can lie from the finest surface, through the block's own triangulation of the
 * square they lie in or the finer interior's, from a patch's samples and its block errors
 * (docs/lod.md, "Transition triangles: what bounds them").
 * The decode computes them on the GPU (shaders/patch_strips.comp); this is its CPU twin,
 * the same arithmetic in the same order, for tests. Written by hand: the bound is this
 * project's own (the tessellator's strips are not something a library models). */
#pragma once

#include <stdbool.h>
#include <stdint.h>

/* Floats per block and edge, metres:
 * [0..3] for an edge at level e = 1..4 (segments of 2^e samples), the charge of any
 *        coarse-edge strip along it against any finer interior: at most this far from the
 *        finest surface (the larger of it and the block's eps_e bounds the edge's level),
 *        the largest over interiors at i < e of the least of eps_e + D against the
 *        column's square, eps_i + D_i against the interior's cells
 *        (relief_strip_interior_points()) and, for i > 0, eps_0 + D_0 against full
 *        resolution with every diagonal (relief_strip_interior_full_points());
 * [4..6] for an edge at level e = 0..2 against an interior one level coarser, the charge
 *        of its fine-edge strips: the smallest of eps_(e+1) + D against the column's square,
 *        eps_e + D_e against the edge's own level (relief_strip_fine_points()) and eps_0 +
 *        D_0 against full resolution with every diagonal (relief_strip_full_points());
 * [7]    0. */
#define RELIEF_STRIP_FLOATS 8

/* The inner ring's vertices a strip in the column from along c0 to c0 + so can hold,
 * against an interior of cells of si < so samples: at depth si, every si along from
 * *first to *last, within the column and inset by si from the block's ends. */
void relief_strip_ring(int c0, int so, int si, int *first, int *last);

/* One point where a strip triangle T may deviate most from a triangulation L: its
 * deviation T - L there is the sum of w h(s) over the n terms (the weights sum to zero), h(s)
 * the height of sample s = (along the edge, depth in from it). The functions below list
 * them; shaders/strip_terms_gen.c writes the same points into the shader, so both sides
 * compute them with the same weights. */
#define RELIEF_STRIP_POINT_TERMS 4
struct relief_strip_point {
	int n;
	int8_t s[RELIEF_STRIP_POINT_TERMS][2];
	float w[RELIEF_STRIP_POINT_TERMS];
};

/* The points of the coarse-edge column from along c0 to c0 + so (a segment of so samples,
 * a power of two up to RELIEF_BLOCK_CELLS) against an interior of cells of si < so samples
 * (a ring at depth si, every si along, inset by si from the block's ends), for every
 * triangle the column can hold (the segment joined to a ring vertex, a ring segment joined
 * to an end of the segment): along the segment, the samples between its ends; along each
 * other side, where it crosses a side or either diagonal of a cell (T spans one row of the
 * interior's cells, so T - L_i is linear between those points for either diagonal of
 * every cell). Writes at most `cap` of them to out (may be NULL with cap 0); returns how
 * many there are. */
int relief_strip_interior_points(int so, int si, int c0, struct relief_strip_point *out, int cap);

/* The points of the fine-edge column from along c0 (segments of so samples, so = 1, 2, 4;
 * a ring at depth c = 2 so, every c along, inset by c from the block's ends) against the
 * edge's own level: for every triangle the column can hold (an edge segment joined to a
 * ring vertex of the column, a ring segment joined to a vertex of the edge), the cells'
 * vertices on or in it and where its sides cross a cell's side. No side of these triangles
 * crosses both diagonals of one cell, so each cell can take the diagonal that no side
 * crosses (the errors bound either), and T - L then peaks at those points. Writes at most
 * `cap` of them to out (may be NULL with cap 0); returns how many there are. */
int relief_strip_fine_points(int so, int c0, struct relief_strip_point *out, int cap);

/* The same triangles against full resolution (cells of 1 sample) with every diagonal: T -
 * L_0 is linear on each piece of T that the cells' sides and either diagonal cut, for any
 * choice of diagonals, so |T - L_0| peaks for every choice at the samples inside T, on its
 * sides, and where its sides cross a cell's side or diagonal (the diagonal's own
 * interpolation there). A side two triangles share is listed once. */
int relief_strip_full_points(int so, int c0, struct relief_strip_point *out, int cap);

/* Likewise for the coarse-edge column from along c0 (a segment of so samples) against an
 * interior of cells of si < so (relief_strip_interior_points()): its triangles (the
 * segment joined to a ring vertex, a ring segment joined to an end of the segment) against
 * full resolution with every diagonal. */
int relief_strip_interior_full_points(int so, int si, int c0, struct relief_strip_point *out, int cap);

/* The bounds of every block of a P-sample patch: `q` its quantised heights with the ring,
 * (P + 2)^2 in raster order (sample (x, y) at (y + 1) (P + 2) + x + 1), q2 metres per
 * quantum, `eps` each block's errors eps_1..eps_4 as the file stores them (blocks^2 x 4
 * floats, relief_file_block_errors()), `finest`: the patch is at the file's finest level,
 * where eps_0 is 0 for the bounds through full resolution that take every diagonal (the
 * finest surface is one of them) and half the largest twist of the two rows a fine-edge
 * strip at level 0 spans for its bound through the edge's own level (one diagonal a cell);
 * above it, eps_0 is e0_patch for every block, metres: how far the patch drawn at full
 * detail can lie from the finest surface (its drawn error E0(P) where the file stores it),
 * INFINITY if unknown.
 * Writes blocks^2 x 4 x RELIEF_STRIP_FLOATS floats to out: blocks in raster order, edges
 * west, north, east, south. No-data samples count with their decoded heights: a strip
 * triangle with a no-data corner still draws wherever its nearest sample is valid.
 * Returns 0, or -ENOMEM. */
int relief_strip_bounds(const int32_t *q, uint32_t P, float q2, const float *eps, bool finest, float e0_patch,
                        float *out);
