/* Coarse level of detail: views, screen-space error and the patch selection rule
 * (docs/lod.md; design notes §3). The CPU functions here are the reference that the
 * selection compute shader (shaders/lod_select.comp) must match bit for bit in its result.
 *
 * A view is a camera and a threshold; nothing here is global, so any number of views may
 * select from one cache at once. */
#pragma once

#include <stdbool.h>
#include <stdint.h>

#include "format.h"
#include "mat4.h"

struct relief_view {
	struct relief_vec3 eye;    /* world metres, double precision */
	struct relief_vec3 target; /* a point the camera looks at */
	double roll;               /* radians about the viewing direction; see relief_view_axes() */
	double fovy;               /* vertical field of view, radians, in (0, pi) */
	uint32_t width, height;    /* viewport, pixels */
	double znear, zfar;        /* metres */
	double tau;                /* screen-space error threshold, pixels */
	bool morph;                /* geomorph changes of a block's level, within tau at finer levels
	                            * (docs/lod.md, "Morphing") */
	/* The tessellator's transition strips left unbounded: fewer triangles (28-51 % fewer
	 * at tau = 1 on the bundled DEMs), but a transition triangle may then exceed tau (by
	 * up to 19 % where measured). Off (the default): every strip is bounded (docs/lod.md,
	 * "Transition triangles: what bounds them"). */
	bool loose_transitions;
};

/* Camera and look point coordinates beyond this (metres) are refused: nothing that far
 * sees a terrain (whose coordinates are within RELIEF_MAX_COORD), and the squares of such
 * distances stay well inside float range (the GPU's camera height is a float). */
#define RELIEF_VIEW_MAX_COORD 1e12
/* 0, or -EINVAL with a reason for NaN/infinite values, a camera or look point coordinate
 * beyond RELIEF_VIEW_MAX_COORD, a zero-size viewport, eye equal to target, fov outside
 * (0, pi), near/far not 0 < near < far, or tau not in (0, FLT_MAX]. */
int relief_view_check(const struct relief_view *v, const char **why);

/* The camera's orthonormal axes (world): fwd towards the target, right and up as the
 * picture shows them. With roll 0, up is in the vertical plane through fwd (world +z
 * upwards on screen); within RELIEF_VIEW_NADIR of straight down or up, where that plane
 * is undefined, north (+y) is at the top of the picture instead, so nadir views of an
 * image generator's sensor are well defined. Roll then turns the camera about fwd:
 * positive is an aircraft's right bank (right wing down; the horizon turns anticlockwise
 * in the picture). False only when eye equals target or a value is not finite. */
#define RELIEF_VIEW_NADIR 1e-9 /* radians */
bool relief_view_axes(const struct relief_view *v, struct relief_vec3 *fwd, struct relief_vec3 *right,
                      struct relief_vec3 *up);

/* kappa = height / (2 tan(fovy / 2)): pixels per unit of error / distance, on the view axis. */
double relief_view_kappa(const struct relief_view *v);
/* The same anywhere in the view's frustum: a short segment of length e at distance r, at
 * angle t from the view axis, projects to at most kappa e / (r cos^2 t) pixels (the
 * perspective divide by the depth r cos t, and the depth's own change along the segment),
 * and cos^2 t is least at the frustum's corners: kappa (1 + tan^2(fovy / 2) (1 + aspect^2)).
 * 1.9 kappa at 50 degrees and 16:9, 13.5 kappa at 120 degrees. */
double relief_view_error_kappa(const struct relief_view *v);

/* Where the camera is in the file's finest sample grid: integer cell plus fraction, so that
 * camera-relative positions can be formed exactly for terrains at any coordinates. */
struct relief_view_origin {
	int64_t cell_x, cell_y; /* finest-level sample indices (column, row) */
	double frac_x, frac_y;  /* in [0, 1) samples */
	double z;               /* metres */
};
void relief_view_origin(const struct relief_file *f, const struct relief_view *v, struct relief_view_origin *o);

/* Bounding box of patch id relative to the camera (metres; x east, y north, z up). */
struct relief_box {
	float min[3], max[3];
};
void relief_patch_box(const struct relief_file *f, const struct relief_view_origin *o, uint32_t id,
                      struct relief_box *box);
/* Distance from the camera (at the origin) to the box; 0 inside. */
float relief_box_distance(const struct relief_box *b);

/* Camera-relative view-projection (the camera at the origin; Vulkan clip conventions,
 * reversed Z: depth 1 at the near plane, 0 at the far plane). */
void relief_view_matrix(const struct relief_view *v, float out[16]);
/* The same for positions relative to `origin` (world metres) instead of v's eye:
 * relief_view_matrix_from(v, v->eye, m) equals relief_view_matrix(v, m) bit for bit. */
void relief_view_matrix_from(const struct relief_view *v, struct relief_vec3 origin, float out[16]);
/* True when the box lies entirely outside one plane of the frustum of `vp`. */
bool relief_box_culled(const float vp[16], const struct relief_box *b);

/* Measuring what a frame shows (tests, benchmarks). */
/* Distance along the view axis of reversed-Z depth d; +infinity for the background (d <= 0). */
double relief_view_depth_distance(const struct relief_view *v, double d);
/* World point seen at pixel (x, y) whose reversed-Z depth is d (d > 0). */
struct relief_vec3 relief_view_unproject(const struct relief_view *v, int x, int y, double d);
/* Length in pixels of the vertical segment from p to p + e z (inf if it crosses the eye plane). */
double relief_view_segment_px(const struct relief_view *v, struct relief_vec3 p, double e);
/* v's view-projection in double precision for positions relative to `origin` (world). */
struct relief_mat4 relief_view_projection(const struct relief_view *v, struct relief_vec3 origin);
/* relief_view_segment_px() with the view-projection (for p relative to its origin) and the
 * viewport given: for measuring many points of one view. */
double relief_segment_px(const struct relief_mat4 *vp, uint32_t width, uint32_t height, struct relief_vec3 p, double e);
/* The fine LOD's room over a box (docs/lod.md, "The room over a box"; the shaders'
 * allowed_box() in terrain_factors.glsl, of which this is the reference): the largest
 * vertical error e such that a vertical segment of length e, up or down, from any point of
 * the box (the convex hull of the points c[0..3] and of the same points dh >= 0 higher;
 * positions relative to vp's origin) projects to at most tau pixels on a width x height
 * viewport. 0 where the box reaches the camera's plane (w <= 1e-6). */
double relief_box_allowed_error(const struct relief_mat4 *vp, uint32_t width, uint32_t height, double tau,
                                const struct relief_vec3 c[4], double dh);
/* Signed vertical distance from p to a level's decoded surface, the nearer of the two cell
 * diagonals: heights w x h in metres, every sample's decoded height, no-data ones too
 * (relief_decode_level_drawn()), samples at the file's spacing times `step`; `valid` says
 * which are data (NULL: all). A cell with a valid corner is measured whole, at its no-data
 * corners' decoded heights: a renderer keeps the fragments nearest to a valid sample, and
 * those lean towards the no-data corners (relief_mesh_error() measures the same cells). A
 * point within one cell outside the raster's extent is measured at the nearest point of
 * its edge: a drawn point there lies on a terrain-edge curtain (relief_terrain_draw()) off
 * the edge by rounding, whose depth below the edge it then reads on whichever side
 * rounding put it, or in the half cell a renderer keeps past the last sample. 0 farther
 * out and in a cell without a valid corner (nothing of it is drawn there).
 * `mid`, if not NULL, receives the signed distance to the mean of the two diagonals'
 * surfaces: one fixed reference, for differences of errors (popping). The nearer diagonal
 * is the reference the bound is stated against (either could be drawn), but it changes
 * sides when p crosses the middle between the two, so a point moving by a hair flips the
 * sign of its error there. */
double relief_surface_vertical_error(const struct relief_file *f, const float *heights, const uint8_t *valid,
                                     uint32_t w, uint32_t h, uint32_t step, struct relief_vec3 p, double *mid);

/* An upper bound (metres) on the height of the surface that any level of detail draws at
 * world (x, y): the largest block height range (relief_file_block_ranges()) over every
 * level's patch around the point, within half a finest cell of it, since the triangle
 * covering a point is part of one block of one patch and its vertices are that block's
 * samples, blends of them (morphing) or a coarser patch's samples along a shared border
 * (seals), which lie in the coarser ancestor's block there. Outside the sample grid: the
 * file's highest height plus the largest quantisation tolerance (delta_0), a bound on
 * every reconstructed sample of every level (a no-data sample takes the packer's fill,
 * a mean of valid heights, quantised within delta_l, or its parent's value, a mean of its
 * neighbours' or, at the root, one of its neighbours' or a value between them:
 * docs/codec.md, "No-data"), so that a ray from there meets the edge curtains'
 * outer faces or the upper side first. A camera above the bound sees the upper side of
 * the surface first along every ray, so back faces can be culled (relief_terrain_draw()). */
double relief_surface_height_bound(const struct relief_file *f, double x, double y);

/* The same bound from what a frame draws (the CPU twin of lod_commands.comp, for tests):
 * the largest block height range over the drawn patches `ids` (n of them) whose blocks lie
 * within their own side of world (x, y) (the larger of the block's two sides, measured as
 * the larger of the x and y distances to the block), which takes in the drawn block holding
 * the point and every coarser block across its borders whose samples can seal it; NaN if no
 * drawn block holds the point within half a finest cell. */
double relief_drawn_height_bound(const struct relief_file *f, const uint32_t *ids, uint32_t n, double x, double y);

/* A patch's screen error is its drawn error E0(P) (relief_patch_record) *
 * relief_view_error_kappa() / (distance from the camera to its box), infinite inside the
 * box: anywhere in the frustum, the projection of the patch at full detail's distance from
 * the finest decoded surface. A block drawn at full detail has only that test (the
 * tessellator's levels never test level 0), and it holds at any share up to 1. The coarse
 * selection takes patches whose screen error is within this share of tau (tau_c); the rest
 * is left to the tessellator. A patch's own samples lie up to E0(P) from the finest
 * surface, so with the whole of tau (the paper) its blocks can rarely simplify: measured on
 * Puget Sound, a half share draws fewer triangles at the same measured error (a third
 * fewer when block errors added Err(P); 9 % fewer at tau = 1 since they are measured
 * against the finest surface); with the error kappa and E0(P), shares 0.35 to 1 draw
 * nearly the same on both benchmark flights (docs/lod.md, known issues). */
#define RELIEF_LOD_COARSE_SHARE 0.5

/* Hysteresis: a patch splits when its screen error exceeds tau_c, and stays split until it
 * falls below RELIEF_LOD_MERGE * tau_c, so a still camera does not flicker. */
#define RELIEF_LOD_MERGE 0.8f

/* Coverage. A level draws a fragment where its sample nearest to it is valid (docs/lod.md,
 * "No-data"), and a coarse sample is valid where data lies within half its level's spacing
 * (docs/format.md, "Masks"). So above the finest level a patch with gaps under it
 * (relief_file_patch_gaps()) draws everything the finest level draws there and up to s
 * finest samples past it (s = 2^(levels - 1 - l), the level's spacing in finest samples;
 * masks of packers before the forty-fourth December 2026 session: up to s / 2 short of it
 * or past it): an edge of the data moves by at most s finest cells' diagonals when the
 * level changes. relief_patch_coverage_error() is that distance in metres; 0 at the finest
 * level and where the patch has no gaps. The selection projects it like a vertical error
 * (a segment of any direction projects to at most kappa e / r, relief_view_error_kappa()).
 * The fine LOD does not move coverage, so relief's selection holds it to the whole of tau:
 * the error it projects, relief_patch_select_error() (on the GPU and in
 * relief_lod_select()), is the larger of E0(P) and RELIEF_LOD_COARSE_SHARE times the
 * coverage error (the baselines' selections, which take the whole of tau, to half of it);
 * an EMPTY patch keeps its 0.
 * Without it a flat plain's root patch drew a lake's shore up to 8 cells out at any tau
 * (test_coverage_within_tau: 20.5 px at tau 1 from 3 km; docs/lod.md, "No-data"). */
double relief_patch_coverage_error(const struct relief_file *f, uint32_t id);
float relief_patch_select_error(const struct relief_file *f, uint32_t id, const struct relief_patch_record *r);

/* A patch's border charges: for each side s (0 north, 1 south, 2 west, 3 east) and level
 * k = 1..4, at [4 s + k - 1], the largest over the patch's blocks along that side of what
 * their edge there must keep within tau when drawn in segments of 2^k samples: eps_k, or
 * the charge of a transition strip from it to any finer interior if larger, both made
 * non-decreasing in k (shaders/terrain_texels.glsl, edge_charges_in()). A patch k levels
 * finer than the patch across its border draws the border in such segments (or coarser:
 * the seal takes the coarser patch's vertices), so the selection forces the coarser one
 * to split where this projects beyond tau (shaders/lod_force.comp). `eps`: the patch's
 * block errors (blocks^2 x 4, raster order, as the file stores them); `strips`: its
 * transition strip bounds (relief_strip_bounds(), RELIEF_STRIP_FLOATS per block and edge
 * west, north, east, south). */
#define RELIEF_LOD_BORDER_FLOATS 16
void relief_lod_border_charges(const float *eps, const float *strips, uint32_t blocks,
                               float out[RELIEF_LOD_BORDER_FLOATS]);

/* Where relief_lod_select() finds a resident patch's border charges: charges(data, id)
 * returns its RELIEF_LOD_BORDER_FLOATS floats, or NULL if it has none (the rule then
 * passes over that patch). Asked only for resident patches along a border, so a caller
 * can keep them per cache layer rather than per patch of the tree. */
struct relief_lod_borders {
	const float *(*charges)(void *data, uint32_t id);
	void *data;
};

/* The selection of one frame, CPU reference. `resident[id]` says whether patch id can be
 * drawn (resident in the cache), and `border` gives resident patches' border charges
 * (relief_lod_borders; not asked when the view leaves its transition strips unbounded,
 * loose_transitions, whose selection has no border rule on the GPU either; NULL leaves the
 * rule out for any view, which the GPU's selection then does not match); `split_prev` /
 * `split_next` are the view's hysteresis bits (one byte per patch; next is written for
 * every patch: 0 for a patch the selection does not visit, one with an ancestor outside
 * the frustum or not wanting to split, as the GPU's selection only visits the others).
 * Fills `draw[id]` (1 = draw) and returns the number drawn. Patches outside the frustum
 * are neither drawn nor split. `want` receives up to want_cap missing patches (not the
 * root) of the tree the view draws once everything has arrived: every ancestor in the
 * frustum and wanting to split, resident or not, so a cold cache learns the whole chain
 * down to the finest patch in one frame. In id order (coarse first); `*n_want` is their
 * count. */
uint32_t relief_lod_select(const struct relief_file *f, const struct relief_view *v, const uint8_t *resident,
                           const struct relief_lod_borders *border, const uint8_t *split_prev,
                           uint8_t *split_next, uint8_t *draw, uint32_t *want, uint32_t want_cap,
                           uint32_t *n_want);
