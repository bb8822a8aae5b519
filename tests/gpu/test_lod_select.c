/* Compute LOD, the selection: the GPU equals the CPU reference (common/lod.c) on the same
 * camera over poses that stress it (grazing, inside the terrain, far away, looking at a
 * patch corner), hysteresis frame after frame, trees of 11 and 13 levels, forced splits;
 * requests look ahead; view checks and axes. Validation layer on, zero messages.
 * (Views sharing a cache, frames in flight, a frozen LOD: test_lod_views.c.) */
#include <assert.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpu_test.h"
#include "lod_scene.h"

#define vk gpu_test_vk

static void test_view_check(void **state)
{
	struct relief_view good = {
		.eye = { 0, 0, 100 }, .target = { 10, 0, 0 }, .fovy = 1, .width = 10, .height = 10, .znear = 1,
		.zfar = 100, .tau = 1,
	};
	const char *why;
	assert_int_equal(relief_view_check(&good, &why), 0);
	struct relief_view v = good;
	v.eye.x = NAN;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	v = good;
	v.width = 0;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	v = good;
	v.target = v.eye;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	assert_non_null(strstr(why, "look point"));
	v = good;
	v.target = (struct relief_vec3){ 0, 0, 0 }; /* straight down: north at the top */
	assert_int_equal(relief_view_check(&v, &why), 0);
	v.roll = NAN;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	v = good;
	v.tau = 0;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	/* beyond the float the GPU takes: infinite there (relief_view_check()) */
	v.tau = 3.5e38;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	assert_non_null(strstr(why, "tau"));
	v.tau = FLT_MAX;
	assert_int_equal(relief_view_check(&v, &why), 0);
	/* a camera beyond 1e12 m (1e39 was infinite as the GPU's float camera height) */
	v = good;
	v.eye.z = 1e39;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	assert_non_null(strstr(why, "1e12"));
	v.eye.z = RELIEF_VIEW_MAX_COORD;
	assert_int_equal(relief_view_check(&v, &why), 0);
	v.target.x = -1.5e12;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
	v = good;
	v.fovy = M_PI;
	assert_int_equal(relief_view_check(&v, &why), -EINVAL);
}

static double vec_dot(struct relief_vec3 a, struct relief_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

static void assert_vec_near(struct relief_vec3 a, double x, double y, double z)
{
	assert_true(fabs(a.x - x) < 1e-12 && fabs(a.y - y) < 1e-12 && fabs(a.z - z) < 1e-12);
}

/* relief_view_axes(): orthonormal and right-handed (right x up = -fwd, the camera looking
 * down its -z) for oblique, near-vertical and vertical views and any roll; the documented
 * conventions for roll and for straight down / up. */
static void test_view_axes(void **state)
{
	const double dirs[][3] = { { 1, 2, -0.5 }, { 0, 0, -1 }, { 0, 0, 1 }, { 1e-12, 0, -1 }, { 0, 1e-7, -1 },
	                           { -3, 0.1, 2 }, { 0, 1, 0 } };
	const double rolls[] = { 0, 0.3, -2, M_PI, 7.5 };
	for (size_t i = 0; i < sizeof(dirs) / sizeof(dirs[0]); i++)
		for (size_t k = 0; k < sizeof(rolls) / sizeof(rolls[0]); k++) {
			struct relief_view v = { .eye = { 500000, 5000000, 100 }, .roll = rolls[k] };
			v.target = (struct relief_vec3){ v.eye.x + dirs[i][0], v.eye.y + dirs[i][1], v.eye.z + dirs[i][2] };
			struct relief_vec3 f, r, u;
			assert_true(relief_view_axes(&v, &f, &r, &u));
			assert_true(fabs(vec_dot(f, f) - 1) < 1e-12 && fabs(vec_dot(r, r) - 1) < 1e-12 &&
			            fabs(vec_dot(u, u) - 1) < 1e-12);
			assert_true(fabs(vec_dot(f, r)) < 1e-12 && fabs(vec_dot(f, u)) < 1e-12 && fabs(vec_dot(r, u)) < 1e-12);
			struct relief_vec3 ru = relief_vec3_cross(r, u);
			assert_vec_near(ru, -f.x, -f.y, -f.z);
		}
	struct relief_vec3 f, r, u;
	/* Looking north, level: east on the right, up is up; banked right by 30 degrees, the
	 * right axis dips and the up axis leans east. */
	struct relief_view v = { .eye = { 0, 0, 0 }, .target = { 0, 10, 0 } };
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_vec_near(r, 1, 0, 0);
	assert_vec_near(u, 0, 0, 1);
	v.roll = M_PI / 6;
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_vec_near(r, cos(M_PI / 6), 0, -0.5);
	assert_vec_near(u, 0.5, 0, cos(M_PI / 6));
	/* Straight down: a map, north up and east right; straight up: north up, east left. */
	v = (struct relief_view){ .eye = { 0, 0, 100 }, .target = { 0, 0, 0 } };
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_vec_near(r, 1, 0, 0);
	assert_vec_near(u, 0, 1, 0);
	v.target.z = 200;
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_vec_near(r, -1, 0, 0);
	assert_vec_near(u, 0, 1, 0);
	/* Tilted a little towards north (beyond the nadir cone): the same picture as nadir. */
	v.target = (struct relief_vec3){ 0, 1e-6, 0 };
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_true(r.x > 1 - 1e-9 && u.y > 1 - 1e-9);
	v.target = v.eye;
	assert_false(relief_view_axes(&v, &f, &r, &u));
	v.target.x = 1;
	v.roll = INFINITY;
	assert_false(relief_view_axes(&v, &f, &r, &u));
}

static void test_gpu_matches_cpu(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, 320, 180);
	load_everything(&s);
	/* Puget Sound spans x, y in [0, 163840] m, heights 0..4380 m. */
	const struct { double eye[3], at[3], tau; } poses[] = {
		{ { 100000, 50000, 5500 }, { 128480, 79200, 3000 }, 1.0 },   /* towards Mt Rainier */
		{ { 81920, 81920, 30000 }, { 81921, 81930, 0 }, 2.0 },       /* nearly straight down on a corner */
		{ { 5000, 5000, 120 }, { 160000, 150000, 100 }, 0.5 },       /* grazing, low */
		{ { 128480, 79200, 3000 }, { 130000, 80000, 3000 }, 1.0 },   /* inside the mountain */
		{ { -900000, 80000, 9000 }, { 80000, 80000, 0 }, 4.0 },      /* far outside */
		{ { 40960, 40960, 2000 }, { 40960 + 100, 40960 - 100, 1500 }, 8.0 },
		{ { 100000, 50000, 5500 }, { 128480, 79200, 3000 }, 1.0 },  /* banked right (rolls_deg) */
		{ { 81920, 81920, 30000 }, { 81920, 81920, 0 }, 1.0 },      /* straight down, rolled */
	};
	const double rolls_deg[] = { 0, 0, 0, 0, 0, 0, 35, -120 };
	static_assert(sizeof(rolls_deg) / sizeof(rolls_deg[0]) == sizeof(poses) / sizeof(poses[0]), "a roll per pose");
	for (size_t p = 0; p < sizeof(poses) / sizeof(poses[0]); p++) {
		struct relief_view v = {
			.eye = { poses[p].eye[0], poses[p].eye[1], poses[p].eye[2] },
			.target = { poses[p].at[0], poses[p].at[1], poses[p].at[2] },
			.roll = rolls_deg[p] * M_PI / 180,
			.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = poses[p].tau,
		};
		struct relief_terrain_stats st;
		/* The GPU view starts with nothing split, like prev[] here. */
		assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, 2 + p, NULL, &st), 0);
		print_message("pose %zu:\n", p);
		gpu_matches_cpu(&s, &v, &st);
		/* A new view for the next pose: hysteresis state starts empty again. */
		relief_terrain_view_destroy(s.view);
		assert_int_equal(relief_terrain_view_create(s.terrain, &s.view), 0);
	}
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* The view of pose (eye = at + dist dir, looking at `at`, or away from it), tau 1. */
static struct relief_view hysteresis_view(const double at[3], const double dir[3], double dist, bool away)
{
	struct relief_view v = {
		.eye = { at[0] + dir[0] * dist, at[1] + dir[1] * dist, at[2] + dir[2] * dist },
		.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = 1.0,
	};
	double sign = away ? -1.0 : 1.0;
	v.target = (struct relief_vec3){ v.eye.x - sign * dir[0], v.eye.y - sign * dir[1], v.eye.z - sign * dir[2] };
	return v;
}

/* Hysteresis, frame after frame, GPU against the CPU reference fed its own last split
 * state. The CPU finds, backing away from Mt Rainier in steps of 2 % from 2 km, the first
 * distance d from which backing 10 % further keeps a patch split that a selection without
 * history merges (its error between 0.8 tau and tau). Frame A at d, then B 10 % further:
 * B must differ from a fresh selection. Then C looks away
 * (the patch's ancestors leave the frustum, the selection does not visit it, its state
 * becomes "not split"), and D is B's pose again: it must equal a fresh selection. At
 * every frame the GPU's drawn patches equal the CPU's. A and C draw nothing
 * (relief_draw_options.lod_only, no target, which they leave as it was): the hysteresis B
 * and D start from is theirs. */
static void test_hysteresis_matches_cpu(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, 320, 180);
	load_everything(&s);
	const uint32_t n = s.f->hdr.patch_count;
	uint8_t *resident = malloc(n), *prev = calloc(n, 1), *next = malloc(n), *draw = malloc(n);
	uint8_t *fresh_next = malloc(n), *fresh_draw = malloc(n), *zero = calloc(n, 1), *last = malloc(n);
	uint32_t *want = malloc(4 * n), *gpu = malloc(4 * n), n_want;
	const struct relief_lod_borders border = scene_residency(&s, resident);
	const double at[3] = { 128480, 79200, 3000 }, dir[3] = { -0.55, -0.6, 0.58 };
	double d = 2000;
	struct relief_view v;
	for (;; d *= 1.02) {
		assert_true(d < 100000);
		v = hysteresis_view(at, dir, d, false);
		relief_lod_select(s.f, &v, resident, &border, zero, last, draw, want, n, &n_want);
		v = hysteresis_view(at, dir, d * 1.1, false);
		relief_lod_select(s.f, &v, resident, &border, last, next, draw, want, n, &n_want);
		relief_lod_select(s.f, &v, resident, &border, zero, fresh_next, fresh_draw, want, n, &n_want);
		if (memcmp(draw, fresh_draw, n) != 0)
			break;
	}
	const struct { double dist; bool away; int fresh; } frames[] = {
		{ d, false, 1 }, { d * 1.1, false, 0 }, { d * 1.1, true, -1 }, { d * 1.1, false, 1 },
	};
	/* Frames A and C choose their LOD and draw nothing (lod_only, no target): the state
	 * they leave is the one B and D start from. */
	const size_t depth_bytes = sizeof(float) * s.target.width * s.target.height;
	float *before = malloc(depth_bytes);
	for (size_t k = 0; k < sizeof(frames) / sizeof(frames[0]); k++) {
		v = hysteresis_view(at, dir, frames[k].dist, frames[k].away);
		struct relief_terrain_stats st;
		const struct relief_draw_options only = { .lod_only = true };
		const bool drawn = k % 2 == 1;
		memcpy(before, s.target.depth_readback.map, depth_bytes);
		assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, drawn ? &s.target : NULL, 10 + k,
		                                     drawn ? NULL : &only, &st),
		                 0);
		if (!drawn) {
			assert_int_equal(st.triangles, 0);
			assert_memory_equal(s.target.depth_readback.map, before, depth_bytes);
		} else if (gpu_test_has_statistics(s.ctx))
			assert_true(st.triangles > 0);
		uint32_t ng = view_drawn(s.view, gpu, n);
		qsort(gpu, ng, 4, cmp_u32);
		uint32_t nc = relief_lod_select(s.f, &v, resident, &border, prev, next, draw, want, n, &n_want);
		relief_lod_select(s.f, &v, resident, &border, zero, fresh_next, fresh_draw, want, n, &n_want);
		bool same_as_fresh = memcmp(draw, fresh_draw, n) == 0;
		print_message("frame %c, %.0f m out%s: GPU %u patches, CPU %u, %s a selection without history\n",
		              (char)('A' + k), frames[k].dist, frames[k].away ? ", looking away" : "", ng, nc,
		              same_as_fresh ? "as" : "unlike");
		assert_int_equal(ng, nc);
		for (uint32_t i = 0, j = 0; i < n; i++)
			if (draw[i])
				assert_int_equal(gpu[j++], i);
		if (frames[k].fresh >= 0)
			assert_int_equal(same_as_fresh, frames[k].fresh);
		memcpy(prev, next, n);
	}
	/* Nothing to draw into is refused unless nothing is drawn; lod_only draws no wireframe
	 * and captures no mesh. */
	const struct relief_draw_options wire_only = { .lod_only = true, .wire = true };
	const struct relief_draw_options mesh_only = { .lod_only = true, .mesh = true };
	assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, NULL, 20, NULL, NULL), -EINVAL);
	assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, 20, &wire_only, NULL), -EINVAL);
	assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, 20, &mesh_only, NULL), -EINVAL);
	free(before);
	free(resident); free(prev); free(next); free(draw); free(fresh_next); free(fresh_draw); free(zero); free(last);
	free(want); free(gpu);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* A W x H DEM of samples `spacing` metres apart, every one valid, heights from `height`
 * (the deep-tree tests' corridors and strips). */
static struct relief_dem field_dem(uint32_t W, uint32_t H, double spacing, double (*height)(uint32_t x, uint32_t y))
{
	struct relief_dem dem = { .width = W, .height = H, .spacing_x = spacing, .spacing_y = spacing,
	                          .origin_y = spacing * (H - 1) };
	dem.heights = malloc(sizeof(float) * W * H);
	dem.valid = malloc((size_t)W * H);
	assert_non_null(dem.heights);
	assert_non_null(dem.valid);
	memset(dem.valid, 1, (size_t)W * H);
	for (uint32_t y = 0; y < H; y++)
		for (uint32_t x = 0; x < W; x++)
			dem.heights[(size_t)y * W + x] = (float)height(x, y);
	return dem;
}

static double corridor_height(uint32_t x, uint32_t y)
{
	return 300 + 250 * sin(x / 310.0) + 40 * sin(x / 23.0) * cos(y / 9.0);
}

/* A deep-tree test's scene: field_dem() packed with 65-sample patches, a 320 x 180 view. */
static void deep_scene_open(struct scene *s, uint32_t W, uint32_t H, double spacing,
                            double (*height)(uint32_t x, uint32_t y))
{
	struct relief_dem dem = field_dem(W, H, spacing, height);
	scene_open_dem_patch(s, vk, &dem, 65, 1.0, 320, 180, 0);
	relief_dem_finish(&dem);
}

/* The terrain's and the view's buffer bytes, printed with the tree's patch and entry counts. */
static uint64_t deep_buffer_bytes(const struct scene *s)
{
	uint64_t bytes = relief_terrain_bytes(s->terrain) + relief_terrain_view_bytes(s->view);
	print_message("%u patches, %u index entries: terrain and view buffers %llu bytes\n", s->f->hdr.patch_count,
	              s->f->hdr.index_records, (unsigned long long)bytes);
	return bytes;
}

/* The deep-tree tests' check of one 320 x 180 view: rendered until nothing more is asked
 * for, then a fresh view's selection equal to the CPU reference's (frame `frame`). Returns
 * the mask of the levels drawn; ids (index_records long) and *n receive the drawn patches,
 * *terrain (may be NULL) the pixels that show terrain. */
static uint32_t deep_view_matches_cpu(struct scene *s, struct relief_view *v, uint64_t frame, uint32_t *ids,
                                      uint32_t *n, uint32_t *terrain)
{
	float *depth = malloc(sizeof(float) * 320 * 180);
	struct relief_terrain_stats st;
	render(s, v, depth, &st);
	if (terrain) {
		*terrain = 0;
		for (size_t k = 0; k < 320 * 180; k++)
			*terrain += depth[k] > 0.0f;
	}
	free(depth);
	assert_true(fresh_view_matches_cpu(s, v, frame, NULL) > 0);
	return drawn_levels(s, ids, n);
}

/* A deep tree: a 655 km x 640 m corridor, 65537 x 65 samples 10 m apart at 65-sample
 * patches, is a tree of 11 levels and 1,398,101 patches, almost all EMPTY (packed over a
 * window around the data: docs/format.md, "Known limits"). The selection visits only
 * its frontiers level by level; from views along the corridor, each drawn until nothing
 * more is asked for, a fresh view's selection equals the CPU reference's, with the
 * forced-split pre-pass over levels 1 .. 5 on, and patches of level 8 or finer are
 * drawn (of 10 in the nearest view). Negative control, run when the test was written: a
 * selection that pushes no children below level 8 fails it (0 requests against the CPU's
 * 8). */
static void test_deep_tree_matches_cpu(void **state)
{
	struct scene s;
	deep_scene_open(&s, 65537, 65, 10, corridor_height);
	assert_int_equal(s.f->hdr.levels, 11);
	assert_int_equal(s.f->hdr.patch_count, 1398101);
	uint32_t *ids = malloc(4 * s.f->hdr.index_records); /* drawn patches have entries */
	const double along[] = { 2000, 150000, 400000, 640000 };
	for (size_t i = 0; i < sizeof(along) / sizeof(along[0]); i++) {
		struct relief_view v = {
			.eye = { along[i], 320, 900 + 300 * (double)i },
			.target = { along[i] + (i % 2 ? -4000 : 4000), 320, 200 },
			.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = 2.0,
		};
		uint32_t n, terrain, mask = deep_view_matches_cpu(&s, &v, 100 + i, ids, &n, &terrain);
		print_message("corridor at %.0f m: %u terrain pixels, levels drawn 0x%x\n", along[i], terrain, mask);
		assert_true(terrain > 320 * 180 / 20);
		assert_true(mask >= 1u << 8); /* the deep levels are drawn */
	}
	free(ids);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* A 262 km strip, two samples wide (262145 x 2 at P = 65): 13 levels, 22,369,621 patches
 * of which 8,191 have an index entry, the only ones with elements in the per-patch
 * buffers. From two views along it (low, looking along the strip both ways) the GPU's
 * selection equals the CPU reference's, the finest levels are drawn, and the terrain's and
 * view's buffers stay under a byte per patch of the tree (they took 36 bytes a patch when
 * every patch had elements). Negative control, run when the test was written: a selection
 * that loses the east child's entry below level 9 draws 34 patches where the CPU draws 35. */
static double strip_height(uint32_t x, uint32_t y)
{
	return 300 + 200 * sin(x / 700.0) + 30 * sin(x / 37.0 + y);
}

static void test_strip_tree_matches_cpu(void **state)
{
	struct scene s;
	deep_scene_open(&s, 262145, 2, 1, strip_height);
	assert_int_equal(s.f->hdr.levels, 13);
	assert_int_equal(s.f->hdr.index_records, 8191);
	assert_true(deep_buffer_bytes(&s) < s.f->hdr.patch_count);
	uint32_t *ids = malloc(4 * s.f->hdr.index_records); /* drawn patches have entries */
	const double along[] = { 100000, 200000 };
	for (size_t i = 0; i < sizeof(along) / sizeof(along[0]); i++) {
		struct relief_view v = {
			.eye = { along[i], -300, 420 }, .target = { along[i] + (i % 2 ? -3000 : 3000), 1, 150 },
			.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = 2.0,
		};
		uint32_t n, mask = deep_view_matches_cpu(&s, &v, 400 + i, ids, &n, NULL);
		print_message("strip at %.0f m: %u patches, levels drawn 0x%x\n", along[i], n, mask);
		assert_true(mask >= 1u << 11); /* the finest levels */
	}
	free(ids);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* Forced splits that force others (trees of 11 levels or more). A 65537 x 65 corridor at
 * P = 65 (11 levels), flat at 0 m but for 61 columns of rough ground just east of the
 * border between the level-5 patches A (x = 16) and B (x = 17). Looking west from above
 * the rough ground: B's chain along that border down to level 9 wants to split, so flat A
 * is forced and its level-6 children lie beside the corridor's western half, the flat
 * level-1 patch C, 5 levels coarser. C must be forced in turn, through the chain east of
 * it whose level-5 link is A, which wants to split only because it is forced. The GPU's
 * selection equals the CPU reference's, C is split and no two patches side by side are
 * more than 4 levels apart. Negative control, run when the test was written: with one
 * sweep of the pre-pass (the pass before the fixed point), C stays whole beside level 6
 * (a jump of 5) at each view, on the GPU and the CPU alike. */
/* Flat at 0 m but for columns 34818 .. 34878, just inside level-5 patch 17 of 65536. */
static double cascade_height(uint32_t x, uint32_t y)
{
	return x < 34818 || x > 34878 ? 0.0 : 50 + 50 * sin(x * 1.7 + y * 0.9) * cos(x * 0.3 - y * 2.1);
}

static void test_forced_splits_cascade(void **state)
{
	struct scene s;
	deep_scene_open(&s, 65537, 65, 10, cascade_height);
	assert_int_equal(s.f->hdr.levels, 11);
	/* The per-patch buffers follow the index entries, not the 1,398,101 patches of the
	 * tree (they once took 36 bytes a patch on the GPU). */
	assert_true(deep_buffer_bytes(&s) < 4ull * s.f->hdr.patch_count);
	const uint32_t c_id = relief_patch_id(1, 0, 0);
	uint32_t *ids = malloc(4 * s.f->hdr.index_records); /* drawn patches have entries */
	const struct {
		double x, z, tau;
	} views[] = { { 348500, 300, 2 }, { 348500, 800, 4 }, { 349000, 150, 2 } };
	for (size_t i = 0; i < sizeof(views) / sizeof(views[0]); i++) {
		struct relief_view v = {
			.eye = { views[i].x, 320, views[i].z }, .target = { views[i].x - 3000, 320, 0 },
			.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = views[i].tau,
		};
		uint32_t n, mask = deep_view_matches_cpu(&s, &v, 300 + i, ids, &n, NULL), jump = max_level_jump(&s, ids, n);
		bool c_drawn = false;
		for (uint32_t k = 0; k < n; k++)
			c_drawn = c_drawn || ids[k] == c_id;
		print_message("view %zu (tau %g): %u patches, levels drawn 0x%x, largest level jump %u, C %s\n", i,
		              v.tau, n, mask, jump, c_drawn ? "whole" : "split");
		assert_false(c_drawn);
		assert_true(mask & (1u << 6)); /* A's children */
		assert_true(jump <= 4);
	}
	free(ids);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* Requests look ahead: from a cold cache, the first frame asks for the whole tree the view
 * draws once everything has arrived, down to the finest level (not one level per frame),
 * and the GPU's requests equal the CPU reference's, there and with part of the tree
 * resident. After one flush the next frame is complete. */
static void test_requests_look_ahead(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, 320, 180);
	const uint32_t n = s.f->hdr.patch_count, levels = s.f->hdr.levels;
	uint8_t *resident = malloc(n), *prev = calloc(n, 1), *next = malloc(n), *draw = malloc(n);
	uint32_t *gpu = malloc(4 * n), *cpu = malloc(4 * n), n_cpu;
	const struct { double eye[3], at[3]; } poses[] = {
		{ { 100000, 50000, 5500 }, { 128480, 79200, 3000 } },   /* towards Mt Rainier */
		{ { 5000, 5000, 400 }, { 160000, 150000, 100 } },       /* grazing, low */
		{ { 20000, 150000, 2500 }, { 40000, 140000, 1000 } },   /* elsewhere: part of the tree there */
	};
	uint64_t frame = 1;
	for (size_t p = 0; p < sizeof(poses) / sizeof(poses[0]); p++) {
		struct relief_view v = {
			.eye = { poses[p].eye[0], poses[p].eye[1], poses[p].eye[2] },
			.target = { poses[p].at[0], poses[p].at[1], poses[p].at[2] },
			.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = 1.0,
		};
		uint32_t was_resident = 0;
		const struct relief_lod_borders border = scene_residency(&s, resident);
		for (uint32_t id = 0; id < n; id++)
			was_resident += resident[id];
		struct relief_terrain_stats st;
		assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, frame++, NULL, &st), 0);
		uint32_t ng = relief_terrain_view_wants(s.view, gpu, n);
		relief_lod_select(s.f, &v, resident, &border, prev, next, draw, cpu, n, &n_cpu);
		qsort(gpu, ng, 4, cmp_u32);
		uint32_t finest = 0;
		for (uint32_t k = 0; k < ng; k++) {
			uint32_t l, px, py;
			assert_true(relief_patch_coords(&s.f->layout, gpu[k], &l, &px, &py));
			finest = l > finest ? l : finest;
		}
		print_message("pose %zu, %u patches resident: GPU asks for %u (finest level %u of %u), CPU for %u\n", p,
		              was_resident, ng, finest, levels - 1, n_cpu);
		assert_int_equal(ng, n_cpu);
		assert_memory_equal(gpu, cpu, 4 * ng);
		assert_true(ng > 0 && finest == levels - 1);
		/* Everything asked for arrives; the next frame draws the whole tree. */
		assert_int_equal(relief_patch_cache_flush(s.cache, frame), 0);
		assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, frame++, NULL, &st), 0);
		assert_int_equal(st.requests, 0);
		/* The next pose starts from what this one left resident, with a fresh view. */
		relief_terrain_view_destroy(s.view);
		assert_int_equal(relief_terrain_view_create(s.terrain, &s.view), 0);
	}
	free(resident); free(prev); free(next); free(draw); free(gpu); free(cpu);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* The ancestor of patch id at level a (a at most id's level). */
static uint32_t ancestor_at(const struct scene *s, uint32_t id, uint32_t a)
{
	uint32_t l, px, py;
	assert_true(relief_patch_coords(&s->f->layout, id, &l, &px, &py));
	assert_true(a <= l);
	return relief_patch_id(a, px >> (l - a), py >> (l - a));
}

/* Part of the tree resident: a patch is drawn only where every ancestor is resident with
 * all four children there; elsewhere the deepest such ancestor draws the area and its
 * resident descendants are visited (for their requests and use) but not drawn. Puget
 * Sound packed with 65-sample patches, a tree of 5 levels: levels 0-3 visited by the
 * selection's first dispatch, an invocation per patch that decides from its ancestors,
 * level 4 through its frontier (lod_select.comp). Everything resident but one patch the
 * view splits the parent of at each of levels 4, 3 and 2, and their subtrees: each
 * missing patch's parent is drawn and none of its siblings, and the GPU's selection and
 * requests equal the CPU reference's. Negative controls, run when the test was written: a
 * first dispatch that takes every ancestor's children as there draws 63 patches where the
 * CPU draws 61, frontier entries all marked 66 (no other test failed with either). */
static void test_partial_tree_matches_cpu(void **state)
{
	struct scene s;
	struct relief_dem dem;
	test_dem_load(DEM_PUGET, &dem);
	scene_open_dem_patch(&s, vk, &dem, 65, 1.0, 320, 180, 0);
	relief_dem_finish(&dem);
	const uint32_t n = s.f->hdr.patch_count, levels = s.f->hdr.levels;
	assert_int_equal(levels, 5);
	struct relief_view v = {
		.eye = { 78000, 78000, 1500 }, .target = { 90000, 90000, 0 }, /* over the middle, low */
		.fovy = 50 * M_PI / 180, .width = 320, .height = 180, .znear = 1, .zfar = 2e6, .tau = 1.0,
	};
	uint8_t *resident = malloc(n), *prev = calloc(n, 1), *next = malloc(n), *draw = malloc(n);
	uint32_t *want = malloc(4 * n), n_want;
	memset(resident, 1, n);
	/* Which patches to leave out: from the tree the view draws with everything there
	 * (nothing is yet, so no border charges: the choice does not need them). */
	relief_lod_select(s.f, &v, resident, NULL, prev, next, draw, want, n, &n_want);
	/* Missing: for l = 4, 3, 2 the level-l ancestor of a patch drawn at level l or finer,
	 * each under another level-1 patch, so that every ancestor of a missing patch's parent
	 * has all of its children there. */
	uint32_t missing[3], missing_level[3], n_missing = 0;
	for (uint32_t l = levels - 1; l >= 2; l--) {
		for (uint32_t id = relief_level_first_id(l); id < n && n_missing < levels - l; id++) {
			bool apart = draw[id] != 0;
			for (uint32_t k = 0; k < n_missing; k++)
				apart = apart && ancestor_at(&s, missing[k], 1) != ancestor_at(&s, id, 1);
			if (apart) {
				missing_level[n_missing] = l;
				missing[n_missing++] = ancestor_at(&s, id, l);
			}
		}
		assert_int_equal(n_missing, levels - l);
	}
	for (uint32_t id = 0; id < n; id++) {
		uint32_t l, px, py;
		assert_true(relief_patch_coords(&s.f->layout, id, &l, &px, &py));
		for (uint32_t k = 0; k < n_missing; k++)
			if (l >= missing_level[k] && ancestor_at(&s, id, missing_level[k]) == missing[k])
				resident[id] = 0;
	}
	for (uint32_t l = 0; l < levels; l++) {
		for (uint32_t id = relief_level_first_id(l); id < relief_level_first_id(l + 1); id++)
			if (resident[id])
				assert_int_equal(relief_patch_cache_request(s.cache, id, 0), 0);
		assert_int_equal(relief_patch_cache_flush(s.cache, 1), 0);
	}
	for (uint32_t id = 0; id < n; id++)
		assert_int_equal(relief_patch_cache_state(s.cache, id) == RELIEF_PATCH_RESIDENT, resident[id]);
	const struct relief_lod_borders border = scene_residency(&s, resident);
	/* The CPU reference's own semantics first: each missing patch's parent drawn, none of
	 * its siblings. */
	relief_lod_select(s.f, &v, resident, &border, prev, next, draw, want, n, &n_want);
	for (uint32_t k = 0; k < n_missing; k++) {
		uint32_t l, px, py;
		assert_true(relief_patch_coords(&s.f->layout, missing[k], &l, &px, &py));
		assert_true(draw[relief_patch_id(l - 1, px / 2, py / 2)]);
		for (uint32_t c = 0; c < 4; c++)
			assert_false(draw[relief_patch_id(l, (px & ~1u) + (c & 1), (py & ~1u) + (c >> 1))]);
		print_message("missing patch %u (level %u): its parent drawn\n", missing[k], l);
	}
	assert_true(fresh_view_matches_cpu(&s, &v, 2, NULL) > 0);
	free(resident); free(prev); free(next); free(draw); free(want);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_view_check),
		cmocka_unit_test(test_view_axes),
		cmocka_unit_test(test_gpu_matches_cpu),
		cmocka_unit_test(test_hysteresis_matches_cpu),
		cmocka_unit_test(test_deep_tree_matches_cpu),
		cmocka_unit_test(test_forced_splits_cascade),
		cmocka_unit_test(test_strip_tree_matches_cpu),
		cmocka_unit_test(test_requests_look_ahead),
		cmocka_unit_test(test_partial_tree_matches_cpu),
	};
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
