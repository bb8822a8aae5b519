/* Random views, every frame's mesh checked for seams (assert_seamless()'s invariant: no
 * position drawn at two heights, no T-junction) and measured triangle by triangle against
 * the finest decoded surface (relief_mesh_error(): every triangle within tau): the three
 * bundled DEMs (Luxembourg with its no-data border), the synthetic coasts whose flat sea
 * borders land (1025 and 2049 samples, 65-sample patches) and the cliffs; then the hard
 * terrains: Mont Blanc with no-data holes inside it (holes_dem()), Puget Sound moved to
 * projected coordinates in the millions of metres, Puget Sound with samples 4 times
 * closer north-south than east-west (since the forty-fourth December 2026 session), Puget
 * Sound with its water as no-data in 65-sample patches (since the forty-fifth), and a
 * 4097-sample coast rough at the shore, a 7-level tree (65-sample patches) where both
 * forced-split rules apply (five levels, the finer border: lod_force.comp). Eyes anywhere over the raster and a tenth
 * of it beyond, from 20 m above a height in the terrain's range (so also inside
 * mountains) to about 8 km higher, any heading, looking 2-87 degrees down, or (a quarter
 * of the views, where the eye is over data) a driver's 1.5-3 m above the decoded surface
 * looking 0-10 degrees down with the near plane at 0.5 m; a vertical field of view of
 * 10-110 degrees, and in 30 % of the views a roll of up to 60 degrees either way (50
 * degrees and no roll until the forty-fourth December 2026 session, and no driver's eyes);
 * tau 0.5 to 30, morphed or not, skirts on or off, each at random from a seed
 * (RELIEF_SWEEP_SEED, default 12345), so a failure names a view that can be drawn again.
 * A frame of more triangles than one capture holds on the device is captured in parts
 * (capture_in_parts(): drawn again for each); one of more patches than the scene's cache
 * holds (render_fits()) is named and left out (at least half the views must be checked).
 * Each view's frames are numbered after the last view's, as time goes on for a cache, so
 * that it may evict what the views before used.
 * RELIEF_SWEEP_VIEWS sets the views per scene (default 8, about 30 s here; 12 for the
 * first six scenes until the forty-first December 2026 session). The
 * thirty-ninth December 2026 session ran 300 per scene: 1,556 frames with terrain
 * checked, 61 million triangles, no seam (and none in 1,783 frames of an earlier run, of
 * seams only). One frame broke tau: coast 1025 view 206 (tau 0.5, 1.093 px, 2.19 tau), a
 * transition strip of a level-4 patch along the border of a level-1 sea patch whose
 * block edge already had its 16 segments: docs/lod.md, known issues ("Strips along a
 * border between levels"), fixed in the fortieth by forced splits for a finer border
 * (lod_force.comp; test_mesh_finer_border draws that view). 300 per scene then: 1,553
 * frames checked (60 million triangles; 3 frames of the 2049 coast drew 2.2-2.8 million
 * triangles, more than one capture holds, and were not checked), no seam, none over tau,
 * the worst frame of each scene 0.945-0.988 tau. The forty-first, with the hard terrains
 * and the frames over one capture taken in parts: 300 a scene, 2,325 frames; 1,000 a
 * scene, 7,706 frames (624 million triangles); no seam, none over tau, the worst 0.998
 * tau (the 4097 coast). The forty-fourth, with drivers' eyes and fields of view (no
 * banking, nine scenes): 300 a scene (seed 2026120501), 2,215 frames; 1,000 a scene (seed
 * 44), 7,474 frames (557 million triangles); then with banking, the tenth scene and the
 * packer's new coarse masks, 300 a scene (seed 45), 2,456 frames; no seam, none over tau,
 * the worst 0.998 tau (the coasts). The forty-fifth, with the selection's coverage rule:
 * 300 a scene (seed 46), 2,487 frames; with the eleventh scene (seed 47), 2,703 frames;
 * 1,000 a scene (seed 48), 9,222 frames (512 million triangles); none with a seam or over
 * tau, the worst 0.9988 tau. The forty-sixth, 300 a scene (seed 49): 2,758 frames (208
 * million triangles); 1,000 a scene (seed 50): 9,074 frames (594 million triangles); none
 * with a seam or over tau, the worst 0.9983 tau (the 2049 and 4097 coasts). The
 * forty-seventh, 300 a scene (seed 51): 2,794 frames (204 million triangles); 1,000 a scene
 * (seed 52): 9,090 frames (559 million triangles); none with a seam or over tau, the worst
 * 0.9989 tau (the 4097 coast). The forty-eighth, 300 a scene (seed 53): 2,763 frames (163
 * million triangles), none with a seam or over tau, the worst 0.9975 tau (the 4097
 * coast). Then 1,000 a scene (seed 54) found the rough coast's view 61 2.0027 px off at
 * tau 2 (1.0014 tau): a coarse-edge strip's triangle reaching half a block from the edge
 * its factor was measured on, towards the camera; edges are now measured across that band too
 * (band_allowed(), terrain_factors.glsl; test_mesh_strip_band keeps the view), and seed 54
 * again: 9,101 frames (606 million triangles), none with a seam or over tau, the worst
 * 0.9978 tau (the 4097 coast). The forty-ninth, 1,000 a scene (seed 55), before the
 * factor pass bounded the error over boxes: 9,195 frames (585 million triangles), none
 * with a seam or over tau, the worst 0.9973 tau (the 2049 coast); after it, 1,000 a scene
 * (seed 56): 9,142 frames (619 million triangles), none with a seam or over tau, the worst
 * 0.9965 tau (the 2049 coast). The 1025
 * coast is rough at the shore, where the sea splits beside the land; the 2049 one smooth
 * for 32 samples, where the sea stays up to 4 levels coarser (coast_dem()).
 * Negative controls, run when the test was written (30 views a scene): the evaluation
 * shader ignoring the side seal records puts seams in 14 of Puget Sound's 27 frames with
 * terrain and 7 of the 1025 coast's 25; border edges not raised for a finer patch across
 * them (drawn_border_factor() without its rule), 15 and 6; the frames measured against
 * half their tau, 12 and 8 over. (Every view with loose_transitions set still passed:
 * these views do not find what test_mesh_loose_transitions' view does.) */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gpu_test.h"
#include "lod_scene.h"

#define vk gpu_test_vk

static uint32_t rng_state = 12345;

/* Uniform in [0, 1): a linear congruential generator's top 24 bits. */
static double rnd(void)
{
	rng_state = rng_state * 1664525u + 1013904223u;
	return (rng_state >> 8) / 16777216.0;
}

/* RELIEF_SWEEP_SEED starts the generator elsewhere (default 12345): a longer run with
 * another seed draws views no run before drew. */
static void sweep_seed(void)
{
	const char *e = getenv("RELIEF_SWEEP_SEED");
	rng_state = e ? (uint32_t)strtoul(e, NULL, 0) : 12345u;
	printf("views from seed %u\n", rng_state);
}

static int sweep_views(void)
{
	const char *e = getenv("RELIEF_SWEEP_VIEWS");
	int n = e ? atoi(e) : 8;
	return n > 0 ? n : 8;
}

/* The mesh of a converged frame of v (o, drawn just before, n triangles: more than one
 * capture's room) captured in parts: the frame drawn again for each part, from frame
 * `frame` on, keeping the triangles of the patches whose id % parts is the part (more parts
 * if one does not fit). Returns the n triangles and their quads (the caller frees them);
 * the parts add up to the frame's count and draw the same patches, or the test fails. */
static struct relief_mesh_vertex *capture_in_parts(struct scene *s, const struct relief_view *v,
                                                   const struct relief_draw_options *o, uint64_t frame, uint64_t n,
                                                   uint32_t room, const struct relief_terrain_stats *whole,
                                                   struct relief_mesh_quad **quads)
{
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * n);
	*quads = malloc(sizeof(**quads) * n);
	assert_true(tri && *quads);
	for (uint32_t parts = (uint32_t)(2 * n / room + 2);; parts *= 2) {
		assert_true(parts <= 64);
		uint64_t at = 0;
		bool fits = true;
		for (uint32_t part = 0; part < parts && fits; part++) {
			struct relief_draw_options op = *o;
			op.mesh_parts = parts;
			op.mesh_part = part;
			struct relief_terrain_stats st;
			assert_int_equal(relief_terrain_draw(s->terrain, s->view, v, &s->target, frame++, &op, &st), 0);
			assert_int_equal(st.requests, 0);
			assert_int_equal(st.patches, whole->patches);
			const uint32_t cap = n - at < room ? (uint32_t)(n - at) : room; /* never past the n */
			const int64_t k = relief_terrain_view_mesh(s->view, tri + 3 * at, *quads + at, cap);
			assert_true(k >= 0 && at + (uint64_t)k <= n);
			fits = (uint64_t)k <= room;
			at += (uint64_t)k;
		}
		if (fits) {
			assert_int_equal(at, n);
			return tri;
		}
	}
}

/* Sets *z to the decoded surface's height at world (x, y) plus `above` and returns true
 * where (x, y) is over valid data (the nearest finest sample's); else leaves *z. */
static bool low_eye(const struct bound_scene *b, double x, double y, double above, double *z)
{
	long c, r;
	if (!bound_sample_at(b, x, y, &c, &r))
		return false;
	/* the highest of the 3 x 3 samples around the nearest: every cell holding (x, y) has
	 * its corners among them, and the surface there is below them */
	const long c0 = c > 0 ? c - 1 : c, r0 = r > 0 ? r - 1 : r;
	double top = -INFINITY;
	for (long rr = r0; rr <= r0 + 2 && rr < (long)b->fh; rr++)
		for (long cc = c0; cc <= c0 + 2 && cc < (long)b->fw; cc++)
			top = fmax(top, b->drawn[(size_t)rr * b->fw + (size_t)cc]);
	*z = top + above;
	return true;
}

/* Draws `views` random views of scene b and checks each frame's mesh. */
static void sweep(struct bound_scene *b, const char *name, int views)
{
	struct scene *s = &b->s;
	const struct relief_header *h = &s->f->hdr;
	const double w = h->width * h->spacing_x, d = h->height * h->spacing_y;
	const uint32_t limit = relief_terrain_mesh_limit(s->ctx), room = limit < (1u << 21) ? limit : 1u << 21;
	assert_int_equal(relief_terrain_view_mesh_enable(s->view, room), 0);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)room);
	struct relief_mesh_quad *quads = malloc(sizeof(*quads) * (size_t)room);
	uint32_t over = 0;
	double worst_ratio = 0;
	float *depth = malloc(sizeof(float) * BW * BH);
	assert_true(tri && quads && depth);
	const double taus[] = { 0.5, 1, 2, 4, 8, 16, 30 };
	uint32_t frames = 0, checked = 0, bad = 0, unfit = 0, parted = 0, low_checked = 0;
	uint64_t triangles = 0;
	for (int i = 0; i < views; i++) {
		const double ex = h->origin_x + (rnd() * 1.2 - 0.1) * w, ey = h->origin_y - (rnd() * 1.2 - 0.1) * d;
		double ez = h->height_min + (h->height_max - h->height_min) * rnd() + 20 + 8000 * rnd() * rnd();
		const double yaw = rnd() * 2 * M_PI;
		double pitch = -(2 + 85 * rnd() * rnd()) * M_PI / 180;
		/* a quarter of the views a driver's: 1.5-3 m above the decoded surface (where the
		 * eye is over valid data), looking 0-10 degrees down, the near plane at 0.5 m */
		const bool low = rnd() < 0.25 && low_eye(b, ex, ey, 1.5 + 1.5 * rnd(), &ez);
		if (low)
			pitch = -10 * rnd() * M_PI / 180;
		const struct pose p = { { ex, ey, ez },
			                { ex + cos(yaw) * cos(pitch) * 1000, ey + sin(yaw) * cos(pitch) * 1000,
			                  ez + sin(pitch) * 1000 } };
		struct relief_view v = pose_view(&p);
		v.tau = taus[(int)(rnd() * 7)];
		v.morph = rnd() < 0.5;
		v.zfar = 1e6;
		v.fovy = 10 * pow(11, rnd()) * M_PI / 180; /* 10-110 degrees, as many below 33 as above */
		v.roll = rnd() < 0.3 ? (2 * rnd() - 1) * M_PI / 3 : 0; /* a banked aircraft's, up to 60 degrees */
		if (low)
			v.znear = 0.5;
		const struct relief_draw_options o = { .fine = RELIEF_FINE_ERRORS, .mesh = true, .no_skirts = rnd() < 0.5 };
		s->frame_base = 100 * (uint64_t)i; /* the views before may be evicted (coast 4097) */
		struct relief_terrain_stats st;
		if (!render_fits(s, &v, &o, depth, &st)) {
			print_message("%s view %d: more patches than the cache holds: not checked\n", name, i);
			unfit++;
			continue;
		}
		const int64_t n = relief_terrain_view_mesh(s->view, tri, quads, room);
		assert_true(n >= 0);
		if (n == 0)
			continue; /* no terrain in view */
		frames++;
		struct relief_mesh_vertex *t = tri;
		struct relief_mesh_quad *q = quads;
		if (n > room) {
			t = capture_in_parts(s, &v, &o, 140 + s->frame_base, (uint64_t)n, room, &st, &q);
			parted++;
		}
		struct relief_mesh_seams m;
		assert_int_equal(relief_mesh_seams(t, (uint64_t)n, RELIEF_MESH_SEAM_TOL_M, &m), 0);
		checked++;
		low_checked += low;
		triangles += (uint64_t)n;
		struct relief_mesh_error e;
		relief_mesh_error(s->f, &v, b->drawn, b->valid, b->fw, b->fh, t, q, (uint64_t)n, &e);
		if (t != tri) {
			free(t);
			free(q);
		}
		worst_ratio = fmax(worst_ratio, e.max_px / v.tau);
		if (e.max_px > v.tau) {
			over++;
			print_message("%s view %d: tau %g%s: max %.4f px (%.2f m), regular worse %.4f, transition %.4f, "
			              "eye (%.2f, %.2f, %.2f) heading %.4f pitch %.4f roll %.4f fov %.2f, %u patches\n",
			              name, i, v.tau, v.morph ? " morphed" : "", e.max_px, e.max_m, e.max_px_regular_worse,
			              e.max_px_transition, ex, ey, ez, yaw, pitch, v.roll, v.fovy * 180 / M_PI, st.patches);
		}
		if (m.split || m.junctions) {
			bad++;
			print_message("%s view %d: eye (%.2f, %.2f, %.2f) heading %.4f pitch %.4f roll %.4f rad, fov %.2f, tau %g%s%s: "
			              "%llu positions split (first at sample %lld, %lld), %llu T-junctions (%llu open, largest gap "
			              "%.3g m)\n",
			              name, i, ex, ey, ez, yaw, pitch, v.roll, v.fovy * 180 / M_PI, v.tau, v.morph ? ", morphed" : "",
			              o.no_skirts ? ", no skirts" : "", (unsigned long long)m.split, (long long)m.split_at.col,
			              (long long)m.split_at.row, (unsigned long long)m.junctions, (unsigned long long)m.open,
			              m.max_gap_m);
		}
	}
	print_message("%s: %d views, %u with terrain, %u more than the cache holds, %u checked (%u of them low; %llu "
	              "triangles; %u captured in parts), %u with seams, %u over tau (worst %.4f tau)\n", name, views,
	              frames, unfit, checked, low_checked, (unsigned long long)triangles, parted, bad, over, worst_ratio);
	assert_int_equal(bad, 0);
	assert_int_equal(over, 0);
	assert_true(checked >= (uint32_t)views / 2);
	free(tri);
	free(quads);
	free(depth);
}

static void test_sweep_dems(void **state)
{
	for (int d = 0; d < DEM_COUNT; d++) {
		struct bound_scene b;
		bound_open(&b, vk, (enum test_dem)d);
		sweep(&b, test_dem_name((enum test_dem)d), sweep_views());
		bound_close(&b);
	}
	gpu_test_assert_clean(vk);
}

/* Sweeps a DEM of the test's own packed with `patch`-sample patches (and finishes it);
 * returns the tree's levels. */
static uint32_t sweep_dem(struct relief_dem *dem, uint32_t patch, const char *name)
{
	struct bound_scene b;
	bound_open_dem_patch(&b, vk, dem, patch);
	relief_dem_finish(dem);
	const uint32_t levels = b.s.f->hdr.levels;
	sweep(&b, name, sweep_views());
	bound_close(&b);
	return levels;
}

static void test_sweep_coasts_and_cliffs(void **state)
{
	const int sizes[] = { 1025, 2049 }, bands[] = { 0, COAST_BAND }; /* rough at the shore, smooth there */
	for (int k = 0; k < 2; k++) {
		struct relief_dem dem = coast_dem(sizes[k], bands[k]);
		sweep_dem(&dem, 65, k ? "coast 2049" : "coast 1025");
	}
	struct relief_dem dem = cliffs_dem();
	sweep_dem(&dem, 129, "cliffs");
	gpu_test_assert_clean(vk);
}

/* Mont Blanc with no-data holes inside it: 40 round ones of 1-40 samples' radius at
 * hashed places, one of 3 x 3 samples on a patch corner (129-sample patches: corners every
 * 128 samples) and a line of single no-data samples along a patch border. */
static struct relief_dem holes_dem(void)
{
	struct relief_dem dem;
	test_dem_load(DEM_ALPS, &dem);
	const int w = (int)dem.width, h = (int)dem.height;
	for (uint32_t k = 0; k < 40; k++) {
		const int cx = (int)(hash32(7000u + k) % (uint32_t)w), cy = (int)(hash32(8000u + k) % (uint32_t)h);
		const int r = 1 + (int)(hash32(9000u + k) % 40u);
		for (int y = cy - r; y <= cy + r; y++)
			for (int x = cx - r; x <= cx + r; x++)
				if (x >= 0 && y >= 0 && x < w && y < h && (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r)
					dem.valid[(size_t)y * w + x] = 0;
	}
	for (int y = 255; y <= 257; y++)
		for (int x = 383; x <= 385; x++)
			dem.valid[(size_t)y * w + x] = 0;
	for (int x = 0; x < w; x += 7)
		dem.valid[(size_t)384 * w + x] = 0;
	return dem;
}

static void test_sweep_hard_terrains(void **state)
{
	struct relief_dem dem = holes_dem();
	sweep_dem(&dem, 129, "Mont Blanc with holes");
	struct bound_scene b;
	scene_open_at(&b.s, vk, DEM_PUGET, 1.0, BW, BH, 4.0e6, 5.5e6, 0);
	bound_buffers(&b);
	sweep(&b, "Puget Sound at (4000 km, 5500 km)", sweep_views());
	bound_close(&b);
	/* samples 4 times closer north-south than east-west: every bound the selection and the
	 * fine LOD take per axis (boxes, block edges, strips) meets unequal spacings. Negative
	 * control, run when it was added (30 views a scene): the selection's patch boxes with
	 * the two spacings swapped (lod_select_common.glsl) put this scene's view 13 66 px off
	 * at tau 8, every other scene passing; swapped in the fine LOD's nearest sample
	 * (terrain_factors.glsl) they did not fail those views. */
	test_dem_load(DEM_PUGET, &dem);
	dem.spacing_y = dem.spacing_x / 4;
	sweep_dem(&dem, 129, "Puget Sound at 160 x 40 m");
	/* its water as no-data, in 65-sample patches (5 levels): a real coast, whose shore the
	 * selection splits for where a coarse level's coverage would reach past tau
	 * (relief_patch_select_error(); since the forty-fifth December 2026 session) */
	test_dem_load(DEM_PUGET, &dem);
	for (size_t i = 0; i < (size_t)dem.width * dem.height; i++)
		dem.valid[i] = dem.heights[i] > 0.5f;
	sweep_dem(&dem, 65, "Puget Sound's water as no-data");
	dem = coast_dem(4097, 0);
	assert_int_equal(sweep_dem(&dem, 65, "coast 4097"), 7);
	gpu_test_assert_clean(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_sweep_dems),
		cmocka_unit_test(test_sweep_coasts_and_cliffs),
		cmocka_unit_test(test_sweep_hard_terrains),
	};
	gpu_test_mesh_capture = true;
	sweep_seed();
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
