/* Smoke test of the tessellation pipeline: a displaced, tessellated patch grid rendered
 * off-screen, read back and compared pixel by pixel with a CPU expectation.
 *
 * Orthographic, top-down: the depth of a pixel is linear in the surface height, so every
 * pixel's height is known exactly. The CPU expectation is the piecewise-linear surface over
 * the tessellated vertices (spacing 1/(patches*factor)); the split of each tessellated
 * cell into triangles is the implementation's choice, so the expected value at a pixel
 * centre is the interval spanned by the two possible diagonals (plus float rounding). */
#include <math.h>
#include <string.h>

#include "gpu_test.h"
#include "grid.h"
#include "mat4.h"
#include "pipeline.h"

#define W 256
#define H 256
#define N 8      /* patches per side */
#define F 16     /* tessellation factor */
#define SIZE 1000.0
#define AMP 100.0
#define EPS (2e-4 * AMP) /* float rounding of positions and depth */

struct fixture {
	struct relief_vk *vk;
	struct relief_vk_target target;
	struct relief_grid *grid;
};

static int setup(void **state)
{
	struct fixture *f = calloc(1, sizeof(*f));
	f->vk = gpu_test_context();
	assert_int_equal(relief_vk_target_init(f->vk, &f->target, W, H), 0);
	assert_int_equal(relief_grid_create(f->vk, &f->target, &f->grid), 0);
	*state = f;
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;
	relief_grid_destroy(f->grid);
	relief_vk_target_finish(f->vk, &f->target);
	unsigned messages = atomic_load(&f->vk->validation_messages);
	relief_vk_destroy(f->vk);
	free(f);
	gpu_test_report(messages);
	return messages ? -1 : 0; /* a validation message during teardown fails the group */
}

static void top_down(struct relief_grid_params *p, uint32_t factor)
{
	struct relief_mat4 view, proj, mvp;
	assert_true(relief_mat4_look_at((struct relief_vec3){ SIZE / 2, SIZE / 2, 10 * AMP },
	                                (struct relief_vec3){ SIZE / 2, SIZE / 2, 0 },
	                                (struct relief_vec3){ 0, 1, 0 }, &view));
	/* Heights +AMP -> depth 0, -AMP -> depth 1. */
	proj = relief_mat4_ortho(-SIZE / 2, SIZE / 2, -SIZE / 2, SIZE / 2, 9 * AMP, 11 * AMP);
	mvp = relief_mat4_mul(&proj, &view);
	*p = (struct relief_grid_params){
		.patches_per_side = N, .size = SIZE, .factor = factor, .amplitude = AMP,
		.sun = { 0, 0, 1 }, .shaded = false,
	};
	relief_mat4_to_float(&mvp, p->mvp);
}

/* Interval of the piecewise-linear surface (vertex spacing 1/cells) at g, over both
 * diagonal choices, in metres. */
static void expected_interval(double gx, double gy, int cells, double *lo, double *hi)
{
	double fx = gx * cells, fy = gy * cells;
	int i = (int)floor(fx), j = (int)floor(fy);
	if (i >= cells) i = cells - 1;
	if (j >= cells) j = cells - 1;
	double u = fx - i, v = fy - j;
	double h00 = relief_grid_height((double)i / cells, (double)j / cells);
	double h10 = relief_grid_height((double)(i + 1) / cells, (double)j / cells);
	double h01 = relief_grid_height((double)i / cells, (double)(j + 1) / cells);
	double h11 = relief_grid_height((double)(i + 1) / cells, (double)(j + 1) / cells);
	/* Diagonal 00-11 */
	double a = u >= v ? h00 + u * (h10 - h00) + v * (h11 - h10) : h00 + v * (h01 - h00) + u * (h11 - h01);
	/* Diagonal 10-01 */
	double b = u + v <= 1 ? h00 + u * (h10 - h00) + v * (h01 - h00)
	                      : h11 + (1 - u) * (h01 - h11) + (1 - v) * (h10 - h11);
	*lo = AMP * fmin(a, b);
	*hi = AMP * fmax(a, b);
}

/* Largest distance (metres) of the rendered heights from the expectation for a surface
 * tessellated into `cells` per side; also checks the grey height code against the depth. */
static double max_height_error(struct fixture *f, int cells, double *max_abs_height)
{
	const float *depth = f->target.depth_readback.map;
	const uint8_t *rgba = f->target.color_readback.map;
	double worst = 0.0, tallest = 0.0;
	for (int py = 0; py < H; py++) {
		for (int px = 0; px < W; px++) {
			double d = depth[py * W + px];
			assert_true(d >= 0.0 && d < 1.0); /* every pixel sees terrain */
			double h = AMP - 2.0 * AMP * d;
			double gx = (px + 0.5) / W, gy = 1.0 - (py + 0.5) / H;
			double lo, hi;
			expected_interval(gx, gy, cells, &lo, &hi);
			double err = h < lo ? lo - h : h > hi ? h - hi : 0.0;
			worst = fmax(worst, err);
			tallest = fmax(tallest, fabs(h));
			double code = (h / AMP + 1.0) / 2.0 * 255.0;
			if (fabs(rgba[(py * W + px) * 4] - code) > 1.5)
				fail_msg("pixel %d,%d: grey %u, depth says %.2f", px, py, rgba[(py * W + px) * 4], code);
		}
	}
	*max_abs_height = tallest;
	return worst;
}

static void test_grid_matches_cpu(void **state)
{
	struct fixture *f = *state;
	struct relief_grid_params p;
	top_down(&p, F);
	struct relief_grid_stats stats;
	assert_int_equal(relief_grid_render(f->grid, &p, &stats), 0);

	double tallest, err = max_height_error(f, N * F, &tallest);
	print_message("max height error %.5f m (bound %.5f m), tallest %.1f m, %u draws, %llu TES invocations\n",
	              err, EPS, tallest, stats.draws, (unsigned long long)stats.tes_invocations);
	assert_true(err <= EPS);
	assert_true(tallest > 0.5 * AMP); /* the displacement really happened */
	if (gpu_test_has_statistics(f->vk))
		assert_true(stats.tes_invocations >= (uint64_t)N * N * (F + 1) * (F + 1));
	gpu_test_assert_clean(f->vk);
}

/* The same check must notice a coarser tessellation: otherwise it proves nothing. */
static void test_check_detects_coarse_tessellation(void **state)
{
	struct fixture *f = *state;
	struct relief_grid_params p;
	top_down(&p, 2);
	assert_int_equal(relief_grid_render(f->grid, &p, NULL), 0);
	double tallest, err = max_height_error(f, N * F, &tallest);
	print_message("factor 2 against the factor-%d expectation: max error %.3f m\n", F, err);
	assert_true(err > 20 * EPS);
}

/* Draw splitting keeps every draw within the lavapipe bound, and a grid needing several
 * draws renders the same as the CPU expectation. */
static void test_split_draws(void **state)
{
	struct fixture *f = *state;
	assert_int_equal(relief_vk_quads_per_draw(16), 65536 / 289);
	assert_int_equal(relief_vk_quads_per_draw(64), 65536 / 4225);
	assert_true(relief_vk_quads_per_draw(64) * 4225u <= RELIEF_VK_MAX_TESS_VERTICES_PER_DRAW);
	struct relief_grid_params p;
	top_down(&p, F);
	p.patches_per_side = 32;
	p.factor = 4;
	struct relief_grid_stats stats;
	assert_int_equal(relief_grid_render(f->grid, &p, &stats), 0);
	assert_int_equal(stats.draws, 1); /* factor 4: 25 vertices, 2621 patches per draw */
	p.patches_per_side = 16;
	p.factor = 16;
	assert_int_equal(relief_grid_render(f->grid, &p, &stats), 0);
	assert_int_equal(stats.draws, (256 + 226) / 227);
	double tallest, err = max_height_error(f, 16 * 16, &tallest);
	assert_true(err <= EPS);
	gpu_test_assert_clean(f->vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_grid_matches_cpu),
		cmocka_unit_test(test_check_detects_coarse_tessellation),
		cmocka_unit_test(test_split_draws),
	};
	return cmocka_run_group_tests(tests, setup, teardown);
}
