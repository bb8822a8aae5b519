/* Random views, every frame's mesh checked for seams (assert_seamless()'s invariant: no
 * position drawn at two heights, no T-junction): the three bundled DEMs (Luxembourg with
 * its no-data border), the synthetic coasts whose flat sea borders land drawn up to 4
 * levels finer (1025 and 2049 samples, 65-sample patches) and the cliffs. Eyes anywhere
 * over the raster and a tenth of it beyond, from 20 m above the lowest sample up (so also
 * inside mountains) to about 8 km higher, any heading, looking 2-87 degrees down; tau 0.5
 * to 30, morphed or not, skirts on or off, each at random from a fixed seed, so a failure
 * names a view that can be drawn again. A frame of more triangles than one capture holds
 * on the device is named and left out (at least half the views must be checked).
 * RELIEF_SWEEP_VIEWS sets the views per scene (default 30, about 20 s here); the
 * thirty-ninth December 2026 session ran 300 per scene (600 on the 1025 coast): 1,783
 * frames with terrain checked, 85 million triangles, no seam (9 frames of the 2049 coast
 * drew 2.4-4.2 million triangles, more than one capture holds, and were not checked).
 * Negative controls, run when the test was written: the evaluation shader ignoring the side
 * seal records puts seams in 14 of Puget Sound's 27 frames with terrain and 7 of the 1025
 * coast's 25; border edges not raised for a finer patch across them (drawn_border_factor()
 * without its rule), 15 and 6. */
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

static int sweep_views(void)
{
	const char *e = getenv("RELIEF_SWEEP_VIEWS");
	int n = e ? atoi(e) : 30;
	return n > 0 ? n : 30;
}

/* Draws `views` random views of scene s and checks each frame's mesh. */
static void sweep(struct scene *s, const char *name, int views)
{
	const struct relief_header *h = &s->f->hdr;
	const double w = h->width * h->spacing_x, d = h->height * h->spacing_y;
	const uint32_t limit = relief_terrain_mesh_limit(s->ctx), room = limit < (1u << 21) ? limit : 1u << 21;
	assert_int_equal(relief_terrain_view_mesh_enable(s->view, room), 0);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)room);
	float *depth = malloc(sizeof(float) * BW * BH);
	assert_true(tri && depth);
	const double taus[] = { 0.5, 1, 2, 4, 8, 16, 30 };
	uint32_t frames = 0, checked = 0, bad = 0;
	uint64_t triangles = 0;
	for (int i = 0; i < views; i++) {
		const double ex = h->origin_x + (rnd() * 1.2 - 0.1) * w, ey = h->origin_y - (rnd() * 1.2 - 0.1) * d;
		const double ez = h->height_min + (h->height_max - h->height_min) * rnd() + 20 + 8000 * rnd() * rnd();
		const double yaw = rnd() * 2 * M_PI, pitch = -(2 + 85 * rnd() * rnd()) * M_PI / 180;
		const struct pose p = { { ex, ey, ez },
			                { ex + cos(yaw) * cos(pitch) * 1000, ey + sin(yaw) * cos(pitch) * 1000,
			                  ez + sin(pitch) * 1000 } };
		struct relief_view v = pose_view(&p);
		v.tau = taus[(int)(rnd() * 7)];
		v.morph = rnd() < 0.5;
		v.zfar = 1e6;
		const struct relief_draw_options o = { .fine = RELIEF_FINE_ERRORS, .mesh = true, .no_skirts = rnd() < 0.5 };
		struct relief_terrain_stats st;
		render_with(s, &v, &o, depth, &st);
		const int64_t n = relief_terrain_view_mesh(s->view, tri, NULL, room);
		assert_true(n >= 0);
		if (n == 0)
			continue; /* no terrain in view */
		frames++;
		if (n > room) {
			print_message("%s view %d: %lld triangles, more than one capture holds here: not checked\n", name, i,
			              (long long)n);
			continue;
		}
		struct relief_mesh_seams m;
		assert_int_equal(relief_mesh_seams(tri, (uint64_t)n, RELIEF_MESH_SEAM_TOL_M, &m), 0);
		checked++;
		triangles += (uint64_t)n;
		if (m.split || m.junctions) {
			bad++;
			print_message("%s view %d: eye (%.1f, %.1f, %.1f) heading %.4f pitch %.4f rad, tau %g%s%s: %llu positions "
			              "split (first at sample %lld, %lld), %llu T-junctions (%llu open, largest gap %.3g m)\n",
			              name, i, ex, ey, ez, yaw, pitch, v.tau, v.morph ? ", morphed" : "",
			              o.no_skirts ? ", no skirts" : "", (unsigned long long)m.split, (long long)m.split_at.col,
			              (long long)m.split_at.row, (unsigned long long)m.junctions, (unsigned long long)m.open,
			              m.max_gap_m);
		}
	}
	print_message("%s: %d views, %u with terrain, %u checked (%llu triangles), %u with seams\n", name, views, frames,
	              checked, (unsigned long long)triangles, bad);
	assert_int_equal(bad, 0);
	assert_true(checked >= (uint32_t)views / 2);
	free(tri);
	free(depth);
}

static void test_sweep_dems(void **state)
{
	for (int d = 0; d < DEM_COUNT; d++) {
		struct scene s;
		scene_open(&s, vk, (enum test_dem)d, 1.0, BW, BH);
		sweep(&s, test_dem_name((enum test_dem)d), sweep_views());
		scene_close(&s);
	}
	gpu_test_assert_clean(vk);
}

static void test_sweep_coasts_and_cliffs(void **state)
{
	const int sizes[] = { 1025, 2049 };
	for (int k = 0; k < 2; k++) {
		struct relief_dem dem = coast_dem(sizes[k]);
		struct scene s;
		scene_open_dem_patch(&s, vk, &dem, 65, 1.0, BW, BH, 0);
		relief_dem_finish(&dem);
		sweep(&s, k ? "coast 2049" : "coast 1025", sweep_views());
		scene_close(&s);
	}
	struct relief_dem dem = cliffs_dem();
	struct scene s;
	scene_open_dem(&s, vk, &dem, 1.0, BW, BH, 0);
	relief_dem_finish(&dem);
	sweep(&s, "cliffs", sweep_views());
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_sweep_dems),
		cmocka_unit_test(test_sweep_coasts_and_cliffs),
	};
	gpu_test_mesh_capture = true;
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
