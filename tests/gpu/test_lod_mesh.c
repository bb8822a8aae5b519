/* The LOD bound measured triangle by triangle: every triangle a frame draws, captured with
 * relief_terrain_view_mesh(), against the finest decoded surface everywhere on it
 * (relief_mesh_error()), not only where pixel centres fall. Every triangle must be within
 * tau: regular ones (those of a block level's triangulation) against either diagonal of
 * the finest surface, which is what the block errors bound, and the tessellator's
 * transition triangles, which the strip bounds computed at decode bound (docs/lod.md,
 * "Transition triangles: what bounds them"). A view with loose_transitions set
 * breaks it (the negative control). Every captured frame's mesh is also checked
 * watertight (assert_seamless(), lod_scene.c; its negative controls are recorded there).
 * Validation layer on, zero messages. */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "gpu_test.h"
#include "lod_scene.h"

#define vk gpu_test_vk

enum { MESH_CAP = 1u << 20 };

/* Renders v (converged) with the capture on, checks that every triangle the clipper saw was
 * captured, and measures them with their quads (so by kind). */
static uint64_t mesh_measure(struct bound_scene *b, struct relief_view *v, const struct relief_draw_options *opts,
                             struct relief_mesh_vertex *tri, struct relief_mesh_error *e)
{
	struct relief_terrain_stats st;
	struct relief_draw_options o = opts ? *opts : (struct relief_draw_options){ .fine = RELIEF_FINE_ERRORS };
	o.mesh = true;
	render_with(&b->s, v, &o, b->lod, &st);
	struct relief_mesh_quad *quads = malloc(sizeof(*quads) * (size_t)MESH_CAP);
	assert_non_null(quads);
	int64_t n = relief_terrain_view_mesh(b->s.view, tri, quads, MESH_CAP);
	assert_true(n > 0 && n <= MESH_CAP);
	if (gpu_test_has_statistics(vk)) /* clipping invocations: the geometry shader's triangles */
		assert_int_equal((uint64_t)n, st.triangles);
	relief_mesh_error(b->s.f, v, b->drawn, b->valid, b->fw, b->fh, tri, quads, (uint64_t)n, e);
	free(quads);
	assert_seamless(tri, (uint64_t)n);
	return (uint64_t)n;
}

/* Orders captured triangles (3 vertices each) by their bytes. */
static int cmp_triangle(const void *a, const void *b)
{
	return memcmp(a, b, 3 * sizeof(struct relief_mesh_vertex));
}

static void print_mesh_error(const char *what, size_t pose, double tau, bool morph, uint64_t n,
                             const struct relief_mesh_error *e)
{
	print_message("%s pose %zu tau %g%s: %llu triangles (%llu vertical, %llu transition), %llu points: max %.3f px "
	              "(%.2f m), regular %.3f px against either diagonal, transition %.3f px (coarse edge %llu %.3f, "
	              "fine edge %llu %.3f, fan %llu %.3f)\n",
	              what, pose, tau, morph ? " morphed" : "", (unsigned long long)n, (unsigned long long)e->vertical,
	              (unsigned long long)e->transition, (unsigned long long)e->points, e->max_px, e->max_m,
	              e->max_px_regular_worse, e->max_px_transition,
	              (unsigned long long)e->kind_triangles[RELIEF_MESH_COARSE_EDGE],
	              e->kind_max_px[RELIEF_MESH_COARSE_EDGE], (unsigned long long)e->kind_triangles[RELIEF_MESH_FINE_EDGE],
	              e->kind_max_px[RELIEF_MESH_FINE_EDGE], (unsigned long long)e->kind_triangles[RELIEF_MESH_FAN],
	              e->kind_max_px[RELIEF_MESH_FAN]);
}

/* Each pose at each of `taus`, without and with morphing: every triangle within tau,
 * regular ones against either diagonal too. `znear`, `fovy`: the
 * views' near plane (metres) and vertical field of view (degrees); 0: pose_view()'s. The
 * scene is closed. */
static void mesh_within_tau_view(struct bound_scene *b, const char *what, const struct pose *poses, size_t n_poses,
                                 const double *taus, size_t n_taus, double znear, double fovy)
{
	assert_int_equal(relief_terrain_view_mesh_enable(b->s.view, MESH_CAP), 0);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)MESH_CAP);
	for (size_t p = 0; p < n_poses; p++) {
		struct relief_view v = pose_view(&poses[p]);
		if (znear > 0)
			v.znear = znear;
		if (fovy > 0)
			v.fovy = fovy * M_PI / 180;
		for (size_t k = 0; k < 2 * n_taus; k++) {
			v.tau = taus[k / 2];
			v.morph = k % 2;
			struct relief_mesh_error e;
			uint64_t n = mesh_measure(b, &v, NULL, tri, &e);
			print_mesh_error(what, p, v.tau, v.morph, n, &e);
			assert_true(e.triangles > 0 && e.points > e.triangles);
			/* Every triangle within tau: the regular ones by the block errors (morphed,
			 * with the blend weights' bound: morph_byte(), docs/lod.md "Morphing"; until
			 * December 2026 weights that ignored a triangle's other corners' weights put
			 * Puget Sound pose 1 at 1.016 tau (tau = 0.5) and Mont Blanc pose 0 at 1.039
			 * tau (tau = 1) here), the transition strips by their bounds
			 * (patch_strips.comp; morphed, as measured). */
			assert_true(e.max_px_regular_worse <= v.tau);
			assert_true(e.max_px <= v.tau);
			assert_true(e.max_px_transition <= v.tau);
			/* The tessellator's structure that docs/lod.md ("Transition triangles")
			 * relies on: every triangle of a quad is regular or lies in one column of
			 * one edge's strip, its corners on the edge's samples and the inner ring. */
			assert_int_equal(e.kind_triangles[RELIEF_MESH_OTHER], 0);
			assert_int_equal(e.kind_triangles[RELIEF_MESH_UNKNOWN], 0);
			assert_int_equal(e.kind_triangles[RELIEF_MESH_COARSE_EDGE] + e.kind_triangles[RELIEF_MESH_FINE_EDGE] +
			                         e.kind_triangles[RELIEF_MESH_FAN],
			                 e.transition);
		}
	}
	free(tri);
	bound_close(b);
}

static void mesh_within_tau(struct bound_scene *b, const char *what, const struct pose *poses, size_t n_poses,
                            const double *taus, size_t n_taus)
{
	mesh_within_tau_view(b, what, poses, n_poses, taus, n_taus, 0, 0);
}

static const double all_taus[] = { 0.5, 1.0, 2.0, 4.0, 8.0 };

static void test_mesh_within_tau_puget(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	mesh_within_tau(&b, "Puget Sound", puget_bound_poses, PUGET_BOUND_POSES, all_taus, 5);
}

static void test_mesh_within_tau_alps(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_ALPS);
	mesh_within_tau(&b, "Mont Blanc", alps_bound_poses, ALPS_BOUND_POSES, all_taus, 5);
}

/* test_lod_bound's cliffs (a 1,000 m step between two samples, a 300 m diagonal step). */
static void test_mesh_within_tau_cliffs(void **state)
{
	struct relief_dem dem = cliffs_dem();
	struct bound_scene b;
	bound_open_dem(&b, vk, &dem);
	relief_dem_finish(&dem);
	const double taus[] = { 1.0, 4.0 };
	mesh_within_tau(&b, "cliffs", cliffs_poses, CLIFFS_POSES, taus, 2);
}

/* A driving simulator's camera: 2 m above a finest sample of the decoded surface, near
 * plane at 0.5 m, looking 3 km ahead and 100 m down. The bound has to hold for the terrain
 * right under the eye and out to the horizon. Heights come from the scene's finest level,
 * so the poses follow the packed data. */
static void driving_poses(const struct bound_scene *b, const double xy[][4], size_t n, struct pose *out)
{
	for (size_t i = 0; i < n; i++) {
		long c, r;
		assert_true(bound_sample_at(b, xy[i][0], xy[i][1], &c, &r)); /* over valid data */
		double ground = b->drawn[(size_t)r * b->fw + (size_t)c];
		out[i] = (struct pose){ { xy[i][0], xy[i][1], ground + 2.0 }, { xy[i][2], xy[i][3], ground - 98.0 } };
	}
}

static void test_mesh_driving_cameras(void **state)
{
	/* Eye x, y (on a sample) and the point looked at, x, y; found by a sweep of random
	 * cameras 2 m up with `relief snap --exact`, the largest errors of it (0.93-0.95 tau). */
	static const double puget[][4] = { { 95840, 36480, 95371, 39443 }, { 81920, 58240, 84436, 56606 } };
	static const double alps[][4] = { { 48945.6, 39026.7, 48219.6, 36115.7 }, { 46071.9, 39304.8, 43987.9, 37146.8 } };
	const double taus[] = { 1.0, 4.0 };
	struct pose poses[2];
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	driving_poses(&b, puget, 2, poses);
	mesh_within_tau_view(&b, "Puget Sound, 2 m up", poses, 2, taus, 2, 0.5, 0);
	bound_open(&b, vk, DEM_ALPS);
	driving_poses(&b, alps, 2, poses);
	mesh_within_tau_view(&b, "Mont Blanc, 2 m up", poses, 2, taus, 2, 0.5, 0);
}

/* A 120-degree field of view: off the view axis a vertical error projects longer than on
 * it, up to 1 / cos^2 of the angle, 13.5 times at this frustum's corners, and a patch
 * whose blocks are drawn at full detail has nothing but the coarse selection to hold it.
 * Until the selection measured with relief_view_error_kappa() (December 2026), this view
 * of Puget Sound drew a level-2 patch's full-detail triangle 2.02 px off at tau = 1 (136
 * m); the sweep it comes from, 40 random cameras at 120 degrees on both files, up to 3.03
 * px. Every triangle is within tau now. */
static void test_mesh_wide_field_of_view(void **state)
{
	static const struct pose poses[] = { { { 160475, 55844, 2107.83 }, { 159226.5, 57921.8, -2265.26 } } };
	const double taus[] = { 1.0, 4.0 };
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	mesh_within_tau_view(&b, "Puget Sound, 120 degrees", poses, 1, taus, 2, 0, 120);
}

/* Borders between levels, triangle by triangle: the coast (lod_scene.h, coast_dem()), whose
 * flat sea's coarse patches border land drawn up to 4 levels finer, so that finer patches
 * put their border vertices on the sea's drawn edges (seals) and the sea's border edges take
 * extra segments for them. The views of test_deep_level_jumps (test_lod_bound.c) at tau =
 * 2, 4 and 16: every triangle within tau, the sealed ones too (at most 0.63 tau, December
 * 2026). */
static void test_mesh_level_jumps(void **state)
{
	enum { N = 1025 };
	struct bound_scene b;
	bound_open_coast(&b, vk, N);
	const struct pose poses[] = { coast_sweep_pose(N, 57), coast_sweep_pose(N, 72), coast_sweep_pose(N, 93) };
	const double taus[] = { 2.0, 4.0, 16.0 };
	mesh_within_tau_view(&b, "coast", poses, sizeof(poses) / sizeof(poses[0]), taus, 3, 0, 0);
}

/* A finer patch's border beside a coarser one: drawn with the coarser patch's vertices, in
 * segments of at least 2^j of its own samples across a jump of j levels, whatever its
 * blocks need; the strips from there to its interior are within its border charge at
 * level j (relief_lod_border_charges()), and the selection splits the coarser patch where
 * that projects beyond tau (lod_force.comp). The coast rough at the shore (coast_dem(N,
 * 0)), view 206 of the thirty-ninth December 2026 session's 300-view sweep
 * (test_lod_sweep.c), where a level-1 sea patch beside level-4 land put a strip triangle
 * 10 m off, 1.093 px at tau = 0.5 (2.19 tau; the same mesh at tau 1 and 2): now the rule
 * fires there (more patches than a selection without border charges), the GPU's
 * selection equals the CPU reference's, and every triangle is within tau. Negative
 * control, run when the test was written: without the rule (lod_force.comp and the CPU
 * twin) the view draws 4 patches and a triangle 10 m, 1.093 px off at tau = 0.5. */
static void test_mesh_finer_border(void **state)
{
	enum { N = 1025 };
	struct relief_dem dem = coast_dem(N, 0);
	struct bound_scene b;
	bound_open_dem_patch(&b, vk, &dem, 65);
	relief_dem_finish(&dem);
	load_everything(&b.s);
	const double e[3] = { 17276.5, 11044.1, 214.2 }, yaw = 2.9374, pitch = -0.2250;
	const struct pose poses[] = { { { e[0], e[1], e[2] },
		                        { e[0] + cos(yaw) * cos(pitch) * 1000, e[1] + sin(yaw) * cos(pitch) * 1000,
		                          e[2] + sin(pitch) * 1000 } } };
	struct relief_view v = pose_view(&poses[0]);
	v.tau = 0.5;
	const struct relief_draw_options bare = { .fine = RELIEF_FINE_ERRORS };
	uint32_t drawn = fresh_view_matches_cpu(&b.s, &v, 1, &bare);
	/* The CPU reference without border charges: the selection before the rule. */
	const uint32_t n = b.s.f->hdr.patch_count;
	uint8_t *resident = malloc(n), *prev = calloc(n, 1), *next = malloc(n), *draw = malloc(n);
	uint32_t *want = malloc(4 * (size_t)n), n_want;
	assert_true(resident && prev && next && draw && want);
	scene_residency(&b.s, resident);
	uint32_t without = relief_lod_select(b.s.f, &v, resident, NULL, prev, next, draw, want, n, &n_want);
	print_message("rough coast, view 206 of the sweep: %u patches, %u without border charges\n", drawn, without);
	assert_true(drawn > without);
	free(resident); free(prev); free(next); free(draw); free(want);
	const double taus[] = { 0.5, 1.0 };
	mesh_within_tau_view(&b, "rough coast", poses, 1, taus, 2, 0, 0);
}

/* The rough coast again (65-sample patches), view 61 of test_lod_sweep's seed 54 (1,000
 * views a scene; forty-eighth December 2026 session): a driver's eye (1.5-3 m above the
 * land) looking 3.8 degrees down across 23 km, tau 2. A block edge's factor was measured at the
 * edge alone, but its coarse-edge strip's triangles reach half a block into the block, here
 * towards the camera: one was 2.0027 px off (1.0014 tau). The edge is now measured across
 * the band its strips can reach too (band_allowed(), terrain_factors.glsl; since the
 * forty-ninth session the room over that band as a box, allowed_box()). Negative control,
 * run when this was added: the previous terrain_factors.glsl fails here. */
static void test_mesh_strip_band(void **state)
{
	struct relief_dem dem = coast_dem(1025, 0);
	struct bound_scene b;
	bound_open_dem_patch(&b, vk, &dem, 65);
	relief_dem_finish(&dem);
	load_everything(&b.s);
	const struct pose pose = { { 26273.015266656872, 26499.60079908371, 2012.3325962126255 },
		                   { 26438.943872515232, 25515.707406797133, 1945.8383079412499 } };
	const double taus[] = { 2.0 };
	mesh_within_tau_view(&b, "rough coast, sweep seed 54 view 61", &pose, 1, taus, 1, 0.5,
	                     0.70852798973700903 * 180 / M_PI);
}

/* Mont Blanc at UTM-like coordinates (500 km east, 5,000 km north) measures as at the
 * origin, to a millionth: the capture's vertices are grid samples and the measure works
 * in double precision. */
static void test_mesh_huge_coordinates(void **state)
{
	const double dx = 500000.0, dy = 5000000.0;
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)MESH_CAP);
	struct relief_mesh_error e[2];
	uint64_t n[2];
	for (int k = 0; k < 2; k++) {
		struct bound_scene b;
		scene_open_at(&b.s, vk, DEM_ALPS, 1.0, BW, BH, k ? dx : 0, k ? dy : 0, 0);
		bound_buffers(&b);
		assert_int_equal(relief_terrain_view_mesh_enable(b.s.view, MESH_CAP), 0);
		const struct pose *q = &alps_bound_poses[0];
		const struct pose at = { { q->eye[0] + (k ? dx : 0), q->eye[1] + (k ? dy : 0), q->eye[2] },
			                 { q->at[0] + (k ? dx : 0), q->at[1] + (k ? dy : 0), q->at[2] } };
		struct relief_view v = pose_view(&at);
		v.tau = 1.0;
		n[k] = mesh_measure(&b, &v, NULL, tri, &e[k]);
		print_mesh_error(k ? "Mont Blanc at (500 km, 5000 km)" : "Mont Blanc", 0, v.tau, false, n[k], &e[k]);
		bound_close(&b);
	}
	assert_int_equal(n[0], n[1]);
	assert_int_equal(e[0].points, e[1].points);
	assert_int_equal(e[0].transition, e[1].transition);
	assert_true(fabs(e[0].max_px - e[1].max_px) <= 1e-6 * e[0].max_px);
	assert_true(fabs(e[0].max_px_regular_worse - e[1].max_px_regular_worse) <= 1e-6 * e[0].max_px_regular_worse);
	free(tri);
}

/* The capture changes nothing drawn: colour and depth bit for bit those of the same frame
 * without it; refusals. And the measure can fail: the frame drawn for tau = 8 is over 1 px,
 * and raising every vertex by 50 m raises the maximum. */
static void test_mesh_capture_and_measure(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	assert_int_equal(relief_terrain_view_mesh_enable(b.s.view, MESH_CAP), 0);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)MESH_CAP);
	const size_t px = (size_t)BW * BH;
	uint8_t *rgba = malloc(4 * px);
	struct relief_view v = pose_view(&puget_bound_poses[0]);
	v.tau = 2.0;
	struct relief_terrain_stats st;
	const struct relief_draw_options plain = { .fine = RELIEF_FINE_ERRORS };
	render_with(&b.s, &v, &plain, b.ref, &st);
	memcpy(rgba, b.s.target.color_readback.map, 4 * px);
	struct relief_mesh_error e;
	uint64_t n = mesh_measure(&b, &v, NULL, tri, &e);
	assert_memory_equal(b.ref, b.lod, sizeof(float) * px);
	assert_memory_equal(rgba, b.s.target.color_readback.map, 4 * px);
	/* The same frame captured in 3 parts (relief_draw_options.mesh_parts): each part holds
	 * the triangles of the patches whose id % 3 is the part, the parts together the whole
	 * frame's triangles, and the picture does not change. */
	struct relief_mesh_vertex *parts = malloc(sizeof(*parts) * 3 * (size_t)n);
	uint64_t at = 0;
	for (uint32_t part = 0; part < 3; part++) {
		const struct relief_draw_options op = { .fine = RELIEF_FINE_ERRORS, .mesh = true, .mesh_parts = 3,
			                                .mesh_part = part };
		assert_int_equal(relief_terrain_draw(b.s.terrain, b.s.view, &v, &b.s.target, 300 + part, &op, &st), 0);
		assert_memory_equal(b.ref, b.s.target.depth_readback.map, sizeof(float) * px);
		const int64_t k = relief_terrain_view_mesh(b.s.view, parts + 3 * at, NULL, (uint32_t)(n - at));
		assert_true(k > 0 && at + (uint64_t)k <= n);
		for (uint64_t j = 3 * at; j < 3 * (at + (uint64_t)k); j++)
			assert_int_equal(parts[j].patch % 3, part);
		at += (uint64_t)k;
	}
	assert_int_equal(at, n);
	qsort(tri, n, 3 * sizeof(*tri), cmp_triangle);
	qsort(parts, n, 3 * sizeof(*parts), cmp_triangle);
	assert_memory_equal(tri, parts, 3 * sizeof(*tri) * n);
	free(parts);
	const struct relief_draw_options no_part = { .fine = RELIEF_FINE_ERRORS, .mesh = true, .mesh_parts = 3,
		                                     .mesh_part = 3 };
	assert_int_equal(relief_terrain_draw(b.s.terrain, b.s.view, &v, &b.s.target, 303, &no_part, &st), -EINVAL);
	/* A wireframe frame cannot be captured, nor can a view that did not enable it. */
	const struct relief_draw_options wire = { .fine = RELIEF_FINE_ERRORS, .wire = true, .mesh = true };
	assert_int_equal(relief_terrain_draw(b.s.terrain, b.s.view, &v, &b.s.target, 200, &wire, &st), -EINVAL);
	struct relief_terrain_view *other;
	assert_int_equal(relief_terrain_view_create(b.s.terrain, &other), 0);
	const struct relief_draw_options mesh = { .fine = RELIEF_FINE_ERRORS, .mesh = true };
	assert_int_equal(relief_terrain_draw(b.s.terrain, other, &v, &b.s.target, 200, &mesh, &st), -EINVAL);
	assert_int_equal(relief_terrain_view_mesh(other, tri, NULL, MESH_CAP), -ENODATA);
	relief_terrain_view_destroy(other);

	/* The same frame measured against tau = 1 after being drawn for tau = 8. */
	struct relief_view coarse = v;
	coarse.tau = 8.0;
	n = mesh_measure(&b, &coarse, NULL, tri, &e);
	print_mesh_error("drawn for tau 8", 0, coarse.tau, false, n, &e);
	assert_true(e.max_px_regular_worse > 1.0);
	/* Every vertex 50 m up: every point's error moves by 50 m, which near the camera is
	 * far over tau. */
	struct relief_mesh_error base;
	n = mesh_measure(&b, &v, NULL, tri, &base);
	for (uint64_t k = 0; k < 3 * n; k++)
		tri[k].height += 50.0f;
	relief_mesh_error(b.s.f, &v, b.drawn, b.valid, b.fw, b.fh, tri, NULL, n, &e);
	print_message("every vertex raised by 50 m: max %.3f px (%.2f m), before %.3f px (%.2f m)\n", e.max_px, e.max_m,
	              base.max_px, base.max_m);
	assert_true(e.max_px > base.max_px + 0.1);
	free(rgba);
	free(tri);
	bound_close(&b);
}

/* View v drawn and measured with the strips bounded (n[0], e[0]) and loose (n[1], e[1]). */
static void measure_bounded_and_loose(struct bound_scene *b, struct relief_view v, const char *what, size_t pose,
                                      uint64_t n[2], struct relief_mesh_error e[2])
{
	assert_int_equal(relief_terrain_view_mesh_enable(b->s.view, MESH_CAP), 0);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)MESH_CAP);
	for (int k = 0; k < 2; k++) {
		v.loose_transitions = k;
		n[k] = mesh_measure(b, &v, NULL, tri, &e[k]);
		print_message("%s:\n", k ? "loose" : "bounded");
		print_mesh_error(what, pose, v.tau, false, n[k], &e[k]);
	}
	free(tri);
}

/* The strip bounds are what keeps the transitions within tau: with loose_transitions the
 * same view (Puget Sound pose 0, tau = 1) draws fewer triangles and a transition triangle
 * is over tau (1.008 px in December 2026), bounded it is within (0.955 px). Until the
 * packer filled the no-data rim (common/fill.h) this was Mont Blanc's pose 0, where a
 * fan reached 1.19 px loose: a strip towards the wild padding values past the raster's
 * east edge; with the rim at the data's height that view is within tau either way. */
static void test_mesh_loose_transitions(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	struct relief_view v = pose_view(&puget_bound_poses[0]);
	v.tau = 1.0;
	struct relief_mesh_error e[2];
	uint64_t n[2];
	measure_bounded_and_loose(&b, v, "Puget Sound", 0, n, e);
	assert_true(e[0].max_px_transition <= v.tau);
	assert_true(e[1].max_px_transition > v.tau);
	assert_true(n[1] < n[0]);
	bound_close(&b);
}

/* A 48-pair flight frame (`relief bench lod --frames 48` on Puget Sound, key pose 31, 480 x
 * 270, tau = 2) where an interior raised next to an edge of one segment made long strip
 * triangles from that segment to the inner ring. Measured by pixels (test_lod_bound until
 * December 2026) it was 2.652 px with the fan rule applied there, 1.617 px without; with
 * the strips bounded the rule applies there again and one pixel measures 2.843 px (275 m),
 * but no triangle of the frame is over tau: that pixel's depth is 5 % nearer than the
 * first captured triangle along its ray (a ray cast through the capture), the rasteriser's
 * depth at a sliver, which the pixels cannot tell from the surface. Loose, the frame draws
 * half the triangles (1.93 px at most in December 2026). */
static void test_mesh_single_segment_frame(void **state)
{
	struct bound_scene b;
	scene_open(&b.s, vk, DEM_PUGET, 1.0, 480, 270);
	bound_buffers(&b);
	const struct relief_view v = {
		.eye = { 59792.533, 59830.933, 3603.84 }, .target = { 92560.533, 92598.933, -10298.445 },
		.fovy = 55 * M_PI / 180, .width = 480, .height = 270, .znear = 1, .zfar = 551005.5, .tau = 2.0,
	};
	struct relief_mesh_error e[2];
	uint64_t n[2];
	measure_bounded_and_loose(&b, v, "single-segment frame", 31, n, e);
	assert_true(e[0].max_px <= v.tau);
	assert_true(n[1] < n[0]);
	bound_close(&b);
}

/* Renders v (converged) with the fine LOD `fine` and the capture on, depth into `depth`;
 * captures its triangles with their quads (at most MESH_CAP) and checks the mesh has no
 * seam. Returns their number. */
static int64_t mesh_capture(struct scene *s, struct relief_view *v, enum relief_fine_lod fine, float *depth,
                            struct relief_mesh_vertex *tri, struct relief_mesh_quad *quads,
                            struct relief_terrain_stats *st)
{
	const struct relief_draw_options o = { .fine = fine, .mesh = true };
	render_with(s, v, &o, depth, st);
	const int64_t n = relief_terrain_view_mesh(s->view, tri, quads, MESH_CAP);
	assert_true(n > 0 && n <= MESH_CAP);
	assert_seamless(tri, (uint64_t)n);
	return n;
}

/* The factors each method's frames draw with, from the capture: each kind of frame has
 * factor and border passes of its own (terrain_lod_pipelines_create(), the fine LOD a
 * specialization constant), so a frame that took another kind's would draw other factors.
 * Chunked LOD draws every block's interior at full resolution (16 segments; its edges may
 * have fewer where a coarser patch is drawn across, and a curtain quad, 1 segment on its
 * sides, is left out); relief and the distance baseline draw coarser interiors too, and
 * not the same frame. Returns the triangles drawn with `fine` and counts in *coarse those
 * of block quads with an inner factor under 16. */
static uint64_t mesh_factors(struct bound_scene *b, struct relief_view *v, enum relief_fine_lod fine,
                             struct relief_mesh_vertex *tri, struct relief_mesh_quad *quads, uint64_t *coarse)
{
	struct relief_terrain_stats st;
	const int64_t n = mesh_capture(&b->s, v, fine, b->lod, tri, quads, &st); /* the baselines' frames too */
	*coarse = 0;
	for (int64_t k = 0; k < n; k++) {
		const struct relief_mesh_quad *q = &quads[k];
		bool curtain = q->outer[0] == 1 && q->outer[2] == 1 && q->inner == q->outer[1];
		*coarse += q->inner < RELIEF_BLOCK_CELLS && !curtain;
	}
	return (uint64_t)n;
}

static void test_mesh_factors_per_method(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	assert_int_equal(relief_terrain_view_mesh_enable(b.s.view, MESH_CAP), 0);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)MESH_CAP);
	struct relief_mesh_quad *quads = malloc(sizeof(*quads) * (size_t)MESH_CAP);
	assert_true(tri && quads);
	struct relief_view v = pose_view(&puget_bound_poses[0]);
	v.tau = 4.0; /* at 1 px this view needs full resolution nearly everywhere */
	uint64_t coarse[3], n[3];
	const enum relief_fine_lod methods[3] = { RELIEF_FINE_FULL, RELIEF_FINE_ERRORS, RELIEF_FINE_DISTANCE };
	for (int m = 0; m < 3; m++) {
		n[m] = mesh_factors(&b, &v, methods[m], tri, quads, &coarse[m]);
		print_message("fine LOD %d: %llu triangles, %llu in quads under full resolution\n", (int)methods[m],
		              (unsigned long long)n[m], (unsigned long long)coarse[m]);
	}
	assert_int_equal(coarse[0], 0);
	assert_true(coarse[1] > 0 && coarse[2] > 0 && n[1] != n[2]);
	free(quads);
	free(tri);
	bound_close(&b);
}

/* A terrain seen from 1,000 km draws its root patch alone and every quad at factor 1: a
 * block's error, under 3 km on these terrains, projects to under a pixel there.
 * Until format version 8 a block error beyond the largest finite code (about 900
 * tolerances) was stored as +infinity, and such a block was drawn at full detail at any
 * distance: from 1,000 km this frame of Puget Sound at 1 m drew 3,911 triangles instead of
 * 192 (17 of the root's 64 blocks), at 0.1 m, where the codes stopped at 90 m, more. The
 * views: straight down from 1,000 km and obliquely from 1,000 km away, 300 km up, tau 1,
 * Puget Sound at 1 and 0.1 m, Mont Blanc at 1 m (its root partly outside the raster). */
static void test_mesh_far_overview(void **state)
{
	const struct {
		enum test_dem dem;
		double tol;
	} files[] = { { DEM_PUGET, 1.0 }, { DEM_PUGET, 0.1 }, { DEM_ALPS, 1.0 } };
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)MESH_CAP);
	struct relief_mesh_quad *quads = malloc(sizeof(*quads) * (size_t)MESH_CAP);
	assert_true(tri && quads);
	for (size_t i = 0; i < sizeof(files) / sizeof(files[0]); i++) {
		struct scene s;
		scene_open(&s, vk, files[i].dem, files[i].tol, BW, BH);
		assert_int_equal(relief_terrain_view_mesh_enable(s.view, MESH_CAP), 0);
		float *depth = malloc(sizeof(float) * BW * BH);
		assert_non_null(depth);
		const struct relief_header *h = &s.f->hdr;
		const double cx = h->origin_x + 0.5 * h->spacing_x * h->width, cy = h->origin_y - 0.5 * h->spacing_y * h->height;
		const struct pose poses[] = { { { cx, cy, 1e6 }, { cx, cy, 0 } }, { { cx - 8e5, cy - 6e5, 3e5 }, { cx, cy, 0 } } };
		for (size_t k = 0; k < 2; k++) {
			struct relief_view v = pose_view(&poses[k]);
			v.tau = 1.0;
			v.znear = 100;
			v.zfar = 2e6;
			struct relief_terrain_stats st;
			const int64_t n = mesh_capture(&s, &v, RELIEF_FINE_ERRORS, depth, tri, quads, &st);
			uint64_t fine = 0;
			for (int64_t t = 0; t < n; t++) {
				const struct relief_mesh_quad *q = &quads[t];
				fine += q->inner > 1 || q->outer[0] > 1 || q->outer[1] > 1 || q->outer[2] > 1 || q->outer[3] > 1;
			}
			print_message("%s at %g m, view %zu: %u patches, %lld triangles, %llu in quads over factor 1\n",
			              test_dem_name(files[i].dem), files[i].tol, k, st.patches, (long long)n,
			              (unsigned long long)fine);
			/* the root alone: at most two triangles per block and curtain quad */
			const uint32_t B = s.f->layout.blocks;
			assert_int_equal(st.patches, 1);
			assert_int_equal(fine, 0);
			assert_true((uint64_t)n <= 2ull * (B * B + 4 * B));
		}
		free(depth);
		scene_close(&s);
	}
	free(quads);
	free(tri);
	gpu_test_assert_clean(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_mesh_within_tau_puget),
		cmocka_unit_test(test_mesh_within_tau_alps),
		cmocka_unit_test(test_mesh_within_tau_cliffs),
		cmocka_unit_test(test_mesh_driving_cameras),
		cmocka_unit_test(test_mesh_wide_field_of_view),
		cmocka_unit_test(test_mesh_level_jumps),
		cmocka_unit_test(test_mesh_finer_border),
		cmocka_unit_test(test_mesh_strip_band),
		cmocka_unit_test(test_mesh_huge_coordinates),
		cmocka_unit_test(test_mesh_capture_and_measure),
		cmocka_unit_test(test_mesh_loose_transitions),
		cmocka_unit_test(test_mesh_single_segment_frame),
		cmocka_unit_test(test_mesh_factors_per_method),
		cmocka_unit_test(test_mesh_far_overview),
	};
	gpu_test_mesh_capture = true;
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
