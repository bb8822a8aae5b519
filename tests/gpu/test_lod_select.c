/* Compute LOD, the selection: the GPU equals the CPU reference (common/lod.c) on the same
 * camera over poses that stress it (grazing, inside the terrain, far away, looking at a
 * patch corner); requests look ahead; several views share one cache; a tight cache settles;
 * a frozen level of detail seen from elsewhere; view checks and axes; a view's memory
 * allocations; device limits the terrain needs. Validation layer on, zero messages. */
#include <assert.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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
	for (uint32_t id = 0; id < n; id++)
		resident[id] = relief_patch_cache_state(s.cache, id) == RELIEF_PATCH_RESIDENT;
	const double at[3] = { 128480, 79200, 3000 }, dir[3] = { -0.55, -0.6, 0.58 };
	double d = 2000;
	struct relief_view v;
	for (;; d *= 1.02) {
		assert_true(d < 100000);
		v = hysteresis_view(at, dir, d, false);
		relief_lod_select(s.f, &v, resident, zero, last, draw, want, n, &n_want);
		v = hysteresis_view(at, dir, d * 1.1, false);
		relief_lod_select(s.f, &v, resident, last, next, draw, want, n, &n_want);
		relief_lod_select(s.f, &v, resident, zero, fresh_next, fresh_draw, want, n, &n_want);
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
		uint32_t nc = relief_lod_select(s.f, &v, resident, prev, next, draw, want, n, &n_want);
		relief_lod_select(s.f, &v, resident, zero, fresh_next, fresh_draw, want, n, &n_want);
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
		for (uint32_t id = 0; id < n; id++)
			was_resident += resident[id] = relief_patch_cache_state(s.cache, id) == RELIEF_PATCH_RESIDENT;
		struct relief_terrain_stats st;
		assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, frame++, NULL, &st), 0);
		uint32_t ng = relief_terrain_view_wants(s.view, gpu, n);
		relief_lod_select(s.f, &v, resident, prev, next, draw, cpu, n, &n_cpu);
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

/* Marks in need[] the layers the scene's view needs for what it drew last frame: each drawn
 * patch, its ancestors, and every non-empty child of each ancestor (a split requests all
 * four children, drawn or culled). Returns how many patches need[] marks. */
static uint32_t mark_needed(const struct scene *s, uint8_t *need)
{
	const struct relief_file *f = s->f;
	const uint32_t n = f->hdr.patch_count;
	uint32_t *ids = malloc(4 * n), drawn = view_drawn(s->view, ids, n), count = 0;
	for (uint32_t k = 0; k < drawn; k++) {
		uint32_t l, px, py;
		assert_true(relief_patch_coords(&f->layout, ids[k], &l, &px, &py));
		need[ids[k]] = 1;
		while (l > 0) {
			l--, px /= 2, py /= 2;
			need[relief_patch_id(l, px, py)] = 1;
			for (uint32_t c4 = 0; c4 < 4; c4++) {
				uint32_t c = relief_patch_id(l + 1, 2 * px + (c4 & 1), 2 * py + (c4 >> 1));
				struct relief_patch_record r;
				relief_file_record(f, c, &r);
				if (!(r.flags & RELIEF_PATCH_EMPTY))
					need[c] = 1;
			}
		}
	}
	for (uint32_t id = 0; id < n; id++)
		count += need[id];
	free(ids);
	return count;
}

/* Draws views[0..n) once each per tick, all with the tick's frame number, until a tick in
 * which none asks for a patch; the last depth image of each view goes to depth[i]. */
static void draw_ticks(struct scene *s, struct relief_terrain_view **tv, const struct relief_view *views, size_t n,
                       float **depth, uint64_t *frame)
{
	for (int tick = 0; tick < 60; tick++, (*frame)++) {
		uint32_t asked = 0;
		for (size_t i = 0; i < n; i++) {
			struct relief_terrain_stats st;
			assert_int_equal(relief_patch_cache_update(s->cache, *frame) >= 0, 1);
			assert_int_equal(relief_terrain_draw(s->terrain, tv[i], &views[i], &s->target, *frame, NULL, &st), 0);
			asked += st.requests;
			if (depth)
				memcpy(depth[i], s->target.depth_readback.map, sizeof(float) * BW * BH);
		}
		if (!asked)
			return;
		/* -ENOSPC: some patches wait for layers that become free in a later tick. */
		int ret = relief_patch_cache_flush(s->cache, *frame);
		assert_true(ret == 0 || ret == -ENOSPC);
	}
	fail_msg("the views still ask for patches after 60 ticks");
}

/* Two views share one cache (the daemon's case: several clients, one terrain cache). Drawn
 * alternately until neither asks for more, each frame equals bit for bit what the view
 * draws alone in a cache of its own. Also when the cache has only 2 layers more than the
 * two views need together and a third view, elsewhere, filled it first: the third view's
 * patches are evicted to make room, never a patch either view drew in the last tick. */
static void test_views_share_cache(void **state)
{
	const struct pose poses[] = {
		{ { 100000, 50000, 5500 }, { 128480, 79200, 3000 } },  /* towards Mt Rainier */
		{ { 5000, 5000, 400 }, { 160000, 150000, 100 } },      /* grazing from the south-west */
		{ { 8000, 156000, 1500 }, { 2000, 162000, 0 } },       /* the north-west corner: fills */
	};
	struct relief_view views[3];
	for (int i = 0; i < 3; i++) {
		views[i] = pose_view(&poses[i]);
		views[i].tau = i == 1 ? 2.0 : 1.0;
	}
	views[1].roll = 20 * M_PI / 180;
	float *alone[2], *shared[2];
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	uint8_t *need = calloc(s.f->hdr.patch_count, 1);
	uint32_t needed = 0;
	uint64_t frame = 1;
	for (int i = 0; i < 2; i++) {
		alone[i] = malloc(sizeof(float) * BW * BH);
		shared[i] = malloc(sizeof(float) * BW * BH);
		if (i) { /* a fresh cache and view for the second */
			scene_close(&s);
			scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
		}
		draw_ticks(&s, &s.view, &views[i], 1, &alone[i], &frame);
		needed = mark_needed(&s, need);
	}
	scene_close(&s);
	for (int tight = 0; tight < 2; tight++) {
		scene_open_at(&s, vk, DEM_PUGET, 1.0, BW, BH, 0, 0, tight ? needed + 2 : 0);
		struct relief_terrain_view *tv[3] = { s.view };
		for (int i = 1; i < 3; i++)
			assert_int_equal(relief_terrain_view_create(s.terrain, &tv[i]), 0);
		if (tight)
			draw_ticks(&s, &tv[2], &views[2], 1, NULL, &frame);
		draw_ticks(&s, tv, views, 2, shared, &frame);
		struct relief_patch_cache_stats cs;
		relief_patch_cache_stats(s.cache, &cs);
		uint32_t differ[2];
		for (int i = 0; i < 2; i++)
			differ[i] = (uint32_t)(memcmp(alone[i], shared[i], sizeof(float) * BW * BH) != 0);
		print_message("%s cache (%u layers, the two views need %u): %llu evicted, frames %s / %s\n",
		              tight ? "tight" : "roomy", cs.layers, needed, (unsigned long long)cs.evicted,
		              differ[0] ? "differ" : "equal", differ[1] ? "differ" : "equal");
		assert_int_equal(differ[0] + differ[1], 0);
		if (tight)
			assert_true(cs.layers == needed + 2 && cs.evicted > 0);
		relief_terrain_view_destroy(tv[1]);
		relief_terrain_view_destroy(tv[2]);
		scene_close(&s);
	}
	for (int i = 0; i < 2; i++) {
		free(alone[i]);
		free(shared[i]);
	}
	free(need);
	gpu_test_assert_clean(vk);
}

/* Three views of Puget Sound that see different terrain: Mt Rainier, grazing across the
 * map, the north-west corner. */
static const struct pose three_views[] = {
	{ { 100000, 50000, 5500 }, { 128480, 79200, 3000 } },
	{ { 5000, 5000, 400 }, { 160000, 150000, 100 } },
	{ { 8000, 156000, 1500 }, { 2000, 162000, 0 } },
};

/* Several views' frames in flight at once (relief_terrain_draw_submit(), then
 * relief_terrain_view_wait() for each) give each view, target for target, the pictures
 * and counts it gets when each frame is waited for before the next is submitted; while they
 * are in flight the cache refuses to update, a view refuses a second frame and its drawn
 * ids, and the validation layer's synchronisation checks see no hazard. */
static void test_views_in_flight(void **state)
{
	const struct pose *poses = three_views;
	enum { N = sizeof(three_views) / sizeof(three_views[0]), FRAMES = 2 };
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	load_everything(&s);
	struct relief_view views[N];
	struct relief_vk_target targets[N];
	struct relief_terrain_view *tv[2][N];
	uint8_t *pictures[2][N];
	struct relief_terrain_stats st[2][N];
	const size_t bytes = (size_t)BW * BH * 8; /* colour, then depth */
	for (int i = 0; i < N; i++) {
		views[i] = pose_view(&poses[i]);
		views[i].tau = 1.0 + i;
		assert_int_equal(relief_vk_target_init(vk, &targets[i], BW, BH), 0);
		for (int k = 0; k < 2; k++) {
			assert_int_equal(relief_terrain_view_create(s.terrain, &tv[k][i]), 0);
			pictures[k][i] = malloc(bytes);
		}
	}
	uint32_t ids[4];
	uint64_t span;
	assert_int_equal(relief_terrain_views_span_ns(s.terrain, tv[1], N, &span), -ENODATA); /* nothing drawn yet */
	for (uint64_t frame = 1; frame <= FRAMES; frame++) {
		/* k = 0: one frame at a time; k = 1: all submitted, then waited for. */
		for (int k = 0; k < 2; k++) {
			assert_true(relief_patch_cache_update(s.cache, frame) >= 0);
			struct timespec t0, t1;
			clock_gettime(CLOCK_MONOTONIC, &t0);
			for (int i = 0; i < N; i++) {
				assert_int_equal(relief_terrain_draw_submit(s.terrain, tv[k][i], &views[i], &targets[i], frame, NULL), 0);
				if (k == 0)
					assert_int_equal(relief_terrain_view_wait(s.terrain, tv[k][i], &st[k][i]), 0);
			}
			if (k == 1) {
				assert_int_equal(relief_patch_cache_update(s.cache, frame), -EBUSY);
				assert_int_equal(relief_patch_cache_flush(s.cache, frame), -EBUSY);
				assert_int_equal(relief_terrain_draw_submit(s.terrain, tv[1][0], &views[0], &targets[0], frame, NULL),
				                 -EBUSY);
				assert_int_equal(relief_terrain_view_drawn(tv[1][0], ids, 4), -EBUSY);
				assert_int_equal(relief_terrain_views_span_ns(s.terrain, tv[1], N, &span), -EBUSY);
				for (int i = 0; i < N; i++)
					assert_int_equal(relief_terrain_view_wait(s.terrain, tv[1][i], &st[1][i]), 0);
				clock_gettime(CLOCK_MONOTONIC, &t1);
				assert_int_equal(relief_terrain_view_wait(s.terrain, tv[1][0], NULL), -EINVAL);
				/* The round's span on the device: at least each frame's own time, at most
				 * the host's time from the first submission to the last wait; of one
				 * view, its frame's time. */
				if (vk->timestamp_valid_bits) {
					uint64_t wall = (uint64_t)(t1.tv_sec - t0.tv_sec) * 1000000000u + (uint64_t)t1.tv_nsec -
					                (uint64_t)t0.tv_nsec;
					assert_int_equal(relief_terrain_views_span_ns(s.terrain, tv[1], N, &span), 0);
					print_message("frame %llu: span %.3f ms, frames %.3f + %.3f + %.3f ms, wall %.3f ms\n",
					              (unsigned long long)frame, span / 1e6, st[1][0].gpu_ns / 1e6,
					              st[1][1].gpu_ns / 1e6, st[1][2].gpu_ns / 1e6, wall / 1e6);
					for (int i = 0; i < N; i++)
						assert_true(span >= st[1][i].gpu_ns && st[1][i].gpu_ns > 0);
					assert_true(span <= wall);
					/* A CPU device (lavapipe) runs the frames one after the other: the span
					 * then also covers their sum. A GPU may overlap them. */
					if (vk->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU)
						assert_true(span >= st[1][0].gpu_ns + st[1][1].gpu_ns + st[1][2].gpu_ns);
					struct relief_terrain_view *reversed[N] = { tv[1][2], tv[1][1], tv[1][0] };
					uint64_t span_reversed;
					assert_int_equal(relief_terrain_views_span_ns(s.terrain, reversed, N, &span_reversed), 0);
					assert_true(span_reversed + 1 >= span && span_reversed <= span + 1); /* each rounded once */
					assert_int_equal(relief_terrain_views_span_ns(s.terrain, &tv[1][2], 1, &span), 0);
					assert_int_equal(span, st[1][2].gpu_ns);
				}
			}
			for (int i = 0; i < N; i++) {
				memcpy(pictures[k][i], targets[i].color_readback.map, (size_t)BW * BH * 4);
				memcpy(pictures[k][i] + (size_t)BW * BH * 4, targets[i].depth_readback.map, (size_t)BW * BH * 4);
			}
		}
		for (int i = 0; i < N; i++) {
			print_message("frame %llu, view %d: %u patches, %llu triangles, pictures %s\n", (unsigned long long)frame,
			              i, st[1][i].patches, (unsigned long long)st[1][i].triangles,
			              memcmp(pictures[0][i], pictures[1][i], bytes) ? "differ" : "equal");
			assert_memory_equal(pictures[0][i], pictures[1][i], bytes);
			assert_int_equal(st[0][i].patches, st[1][i].patches);
			assert_int_equal(st[0][i].triangles, st[1][i].triangles);
			assert_int_equal(st[0][i].requests, st[1][i].requests);
			assert_true(st[1][i].patches > 0);
		}
	}
	assert_true(relief_patch_cache_update(s.cache, FRAMES + 1) >= 0);
	/* A view destroyed with its frame in flight waits for it and lets go of the cache. */
	assert_int_equal(relief_terrain_draw_submit(s.terrain, tv[1][1], &views[1], &targets[1], FRAMES + 2, NULL), 0);
	assert_int_equal(relief_patch_cache_update(s.cache, FRAMES + 2), -EBUSY);
	relief_terrain_view_destroy(tv[1][1]);
	tv[1][1] = NULL;
	assert_true(relief_patch_cache_update(s.cache, FRAMES + 3) >= 0);
	/* The three views see different terrain: the comparison is not of three equal frames. */
	assert_true(memcmp(pictures[1][0], pictures[1][1], bytes) != 0 && memcmp(pictures[1][1], pictures[1][2], bytes) != 0);
	for (int i = 0; i < N; i++) {
		for (int k = 0; k < 2; k++) {
			relief_terrain_view_destroy(tv[k][i]);
			free(pictures[k][i]);
		}
		relief_vk_target_finish(vk, &targets[i]);
	}
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* Several views' frames and the patch cache's decode batches recorded into one command
 * buffer (relief_vk_capture_begin()): the validation layer's synchronisation checks, which
 * do not look across submissions, then check the barriers between them, from a cold cache
 * (decodes between frames, every view asking) to a warm one. Negative control, run by
 * hand: without the barrier that ends a decode batch the layer reports 8 read-after-write
 * hazards (drawing reading decoded heights), which test_views_in_flight does not see. */
static void test_frames_captured(void **state)
{
	const struct pose *poses = three_views;
	enum { N = sizeof(three_views) / sizeof(three_views[0]), ROUNDS = 6 };
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	struct relief_view views[N];
	struct relief_vk_target targets[N];
	struct relief_terrain_view *tv[N];
	for (int i = 0; i < N; i++) {
		views[i] = pose_view(&poses[i]);
		views[i].tau = 1.0 + i;
		assert_int_equal(relief_vk_target_init(vk, &targets[i], BW, BH), 0);
		assert_int_equal(relief_terrain_view_create(s.terrain, &tv[i]), 0);
	}
	struct relief_patch_cache_stats before, after;
	relief_patch_cache_stats(s.cache, &before);
	uint32_t requests = 0, drawn = 0;
	uint64_t frame = 1;
	/* At least ROUNDS rounds, and on until every view draws (a slow worker, as under a
	 * sanitizer, may take longer to bring the root). */
	for (; frame <= ROUNDS || (drawn < N && frame <= 20 * ROUNDS); frame++) {
		assert_int_equal(relief_vk_capture_begin(vk), 0);
		assert_int_equal(relief_vk_capture_begin(vk), -EBUSY);
		assert_true(relief_patch_cache_update(s.cache, frame) >= 0);
		for (int i = 0; i < N; i++)
			assert_int_equal(relief_terrain_draw_submit(s.terrain, tv[i], &views[i], &targets[i], frame, NULL), 0);
		assert_int_equal(relief_terrain_view_wait(s.terrain, tv[0], NULL), -EDEADLK); /* not submitted yet */
		assert_int_equal(relief_vk_capture_end(vk), 0);
		requests = drawn = 0;
		for (int i = 0; i < N; i++) {
			struct relief_terrain_stats st;
			assert_int_equal(relief_terrain_view_wait(s.terrain, tv[i], &st), 0);
			drawn += st.patches > 0; /* the first frames wait for the root */
			requests += st.requests;
		}
		/* The worker's share between rounds, outside the capture (it is the CPU's). */
		struct timespec pause = { 0, 50 * 1000 * 1000 };
		nanosleep(&pause, NULL);
	}
	assert_int_equal(relief_vk_capture_end(vk), -EINVAL);
	relief_patch_cache_stats(s.cache, &after);
	print_message("%llu captured rounds of %d views: %llu patches decoded in %llu captured batches, %u requests left\n",
	              (unsigned long long)(frame - 1), N, (unsigned long long)(after.decoded - before.decoded),
	              (unsigned long long)(after.batches - before.batches), requests);
	assert_int_equal(drawn, N);
	assert_true(after.batches > before.batches); /* decodes were captured between frames */
	for (int i = 0; i < N; i++) {
		relief_terrain_view_destroy(tv[i]);
		relief_vk_target_finish(vk, &targets[i]);
	}
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* The number of finest-level patches view tv drew in its last frame. */
static uint32_t finest_drawn(const struct scene *s, struct relief_terrain_view *tv)
{
	uint32_t *ids = malloc(4 * s->f->hdr.patch_count), n, counts[RELIEF_MAX_LEVELS] = { 0 };
	view_levels(s, tv, ids, &n, counts);
	free(ids);
	return counts[s->f->hdr.levels - 1];
}

/* A shared cache short of layers serves the nearest detail of every view, not the first
 * comer's (patch_cache.h): a view from high above the terrain's west edge fills a cache
 * that holds exactly what it wants, then a low view by Mt Rainier shares it. The low view's
 * nearest patches take the layers of the high view's farthest, the two settle (nothing
 * decoded or evicted in the last 20 of 80 ticks, so no patch is taken back and forth), and
 * both still draw. Negative control, run by hand with the eviction of the least recently
 * used only (as before): the low view never draws a finest-level patch, and keeps asking. */
static void test_near_detail_takes_layers(void **state)
{
	const struct pose poses[] = {
		{ { -30000, 80000, 50000 }, { 80000, 80000, 0 } },    /* high above the west edge */
		{ { 125000, 76000, 3200 }, { 128480, 79200, 4000 } }, /* low, by Mt Rainier */
	};
	struct relief_view views[2] = { pose_view(&poses[0]), pose_view(&poses[1]) };
	views[0].tau = views[1].tau = 1.0;
	struct scene s;
	uint64_t frame = 1;
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	draw_ticks(&s, &s.view, &views[1], 1, NULL, &frame);
	const uint32_t finest_alone = finest_drawn(&s, s.view);
	scene_close(&s);
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	uint8_t *need = calloc(s.f->hdr.patch_count, 1);
	draw_ticks(&s, &s.view, &views[0], 1, NULL, &frame);
	const uint32_t needed = mark_needed(&s, need);
	scene_close(&s);

	scene_open_at(&s, vk, DEM_PUGET, 1.0, BW, BH, 0, 0, needed);
	struct relief_terrain_view *tv[2] = { s.view };
	assert_int_equal(relief_terrain_view_create(s.terrain, &tv[1]), 0);
	draw_ticks(&s, &tv[0], &views[0], 1, NULL, &frame); /* fills the cache exactly */
	struct relief_patch_cache_stats cs;
	uint64_t at60[2] = { 0 };
	struct relief_terrain_stats st[2];
	for (int tick = 1; tick <= 80; tick++, frame++) {
		int ret = relief_patch_cache_flush(s.cache, frame);
		assert_true(ret == 0 || ret == -ENOSPC);
		for (int i = 0; i < 2; i++)
			assert_int_equal(relief_terrain_draw(s.terrain, tv[i], &views[i], &s.target, frame, NULL, &st[i]), 0);
		if (tick == 60) {
			relief_patch_cache_stats(s.cache, &cs);
			at60[0] = cs.decoded;
			at60[1] = cs.evicted;
		}
	}
	relief_patch_cache_stats(s.cache, &cs);
	const uint32_t finest = finest_drawn(&s, tv[1]);
	print_message("%u layers, all the high view's: the low view draws %u finest patches (%u alone), %u patches; the high "
	              "view %u; %llu decoded, %llu evicted (%llu, %llu after 60 ticks)\n", cs.layers, finest, finest_alone,
	              st[1].patches, st[0].patches, (unsigned long long)cs.decoded, (unsigned long long)cs.evicted,
	              (unsigned long long)at60[0], (unsigned long long)at60[1]);
	assert_true(finest_alone > 0 && finest > 0);
	assert_true(cs.evicted > 0 && st[0].patches > 0 && st[1].patches > 0);
	assert_true(cs.decoded == at60[0] && cs.evicted == at60[1]);
	relief_terrain_view_destroy(tv[1]);
	free(need);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* A cache with half the layers a still view wants: it fills, a request more than twice as
 * near as a resident patch's takes its layer (once here), and then it stays as it is. Every
 * frame still asks for the rest and draws the resident parents in their place, but nothing
 * is decoded or evicted after the first 10 frames: a wanted patch counts as in use even
 * while it cannot be drawn (its siblings missing), so patches are not evicted for their
 * siblings and those again for them, frame after frame. (Negative control, run by hand:
 * with only drawn patches marked in use, as before, the 60 frames decoded 167 patches into
 * these 16 layers, evicted 151, and the last frame drew the root alone.) */
static void test_tight_cache_settles(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	const struct pose pose = { { 100000, 50000, 5500 }, { 128480, 79200, 3000 } };
	struct relief_view v = pose_view(&pose);
	v.tau = 1;
	float *depth = malloc(sizeof(float) * BW * BH);
	uint64_t frame = 1;
	draw_ticks(&s, &s.view, &v, 1, &depth, &frame);
	uint8_t *need = calloc(s.f->hdr.patch_count, 1);
	uint32_t needed = mark_needed(&s, need);
	scene_close(&s);

	scene_open_at(&s, vk, DEM_PUGET, 1.0, BW, BH, 0, 0, needed / 2);
	uint64_t decoded[7] = { 0 }, evicted = 0;
	struct relief_terrain_stats st = { 0 };
	for (int f = 1; f <= 60; f++) {
		int ret = relief_patch_cache_flush(s.cache, (uint64_t)f);
		assert_true(ret == 0 || ret == -ENOSPC);
		assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, &s.target, (uint64_t)f, NULL, &st), 0);
		if (f % 10 == 0) {
			struct relief_patch_cache_stats cs;
			relief_patch_cache_stats(s.cache, &cs);
			decoded[f / 10] = cs.decoded;
			evicted = cs.evicted;
		}
	}
	print_message("%u layers for a view that wants %u: decoded after 10, 20, .. 60 frames: %llu %llu %llu %llu %llu "
	              "%llu, %llu evicted, %u requests in the last frame, %u patches drawn\n", needed / 2, needed,
	              (unsigned long long)decoded[1], (unsigned long long)decoded[2], (unsigned long long)decoded[3],
	              (unsigned long long)decoded[4], (unsigned long long)decoded[5], (unsigned long long)decoded[6],
	              (unsigned long long)evicted, st.requests, st.patches);
	assert_true(st.requests > 0 && st.patches > 0);
	/* Full after 10 frames, every later decode in place of a farther patch, none after. */
	assert_true(decoded[1] == needed / 2 + evicted && decoded[6] == decoded[1]);
	assert_true(evicted < needed / 4);
	free(depth);
	free(need);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* A frozen level of detail (relief_draw_options.lod_view): drawn from its own camera it is
 * the normal frame bit for bit; drawn from a camera 60 m further along the flight it keeps
 * exactly that frame's patches and tessellation (the same primitive count) and stays
 * watertight against a full-resolution render of the new camera, while a normal frame there
 * does tessellate differently. */
static void test_frozen_lod(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	struct scene s = b.s;
	const struct pose pose = { { 100000, 50000, 5500 }, { 128480, 79200, 3000 } };
	struct relief_view v = pose_view(&pose), moved = v;
	const double step[3] = { 40, 40, -20 }; /* 60 m towards the summit */
	moved.eye.x += step[0], moved.eye.y += step[1], moved.eye.z += step[2];
	moved.target.x += step[0], moved.target.y += step[1], moved.target.z += step[2];
	float *frozen = malloc(sizeof(float) * BW * BH);
	uint32_t *ids = malloc(4 * s.f->hdr.patch_count), *ids_frozen = malloc(4 * s.f->hdr.patch_count);
	struct relief_terrain_stats st, st_moved, st_frozen;
	render(&s, &moved, b.ref, &st); /* full resolution (tau 0.001), the new camera */
	v.tau = moved.tau = 2.0;
	render(&s, &moved, b.lod, &st_moved);
	render(&s, &v, b.lod, &st);
	uint32_t n, n_frozen;
	drawn_levels(&s, ids, &n);
	/* Its own camera: the same frame. */
	const struct relief_draw_options self = { .lod_view = &v };
	render_with(&s, &v, &self, frozen, &st_frozen);
	assert_memory_equal(frozen, b.lod, sizeof(float) * BW * BH);
	const bool counts = gpu_test_has_statistics(s.ctx);
	if (counts)
		assert_int_equal(st_frozen.triangles, st.triangles);
	/* From the moved camera. */
	const struct relief_draw_options from_v = { .lod_view = &v };
	render_with(&s, &moved, &from_v, frozen, &st_frozen);
	drawn_levels(&s, ids_frozen, &n_frozen);
	qsort(ids, n, 4, cmp_u32);
	qsort(ids_frozen, n_frozen, 4, cmp_u32);
	assert_int_equal(n_frozen, n);
	assert_memory_equal(ids_frozen, ids, 4 * n);
	print_message("frozen LOD: %llu primitives (its own frame %llu, a normal frame at the moved camera %llu)\n",
	              (unsigned long long)st_frozen.triangles, (unsigned long long)st.triangles,
	              (unsigned long long)st_moved.triangles);
	if (counts) {
		assert_true(st.triangles > 0);
		assert_int_equal(st_frozen.triangles, st.triangles);
		assert_true(st_moved.triangles != st.triangles);
	}
	struct comparison c = compare(&s, &moved, b.ref, frozen, b.finest, b.fw, b.fh);
	print_message("frozen LOD from the moved camera: %u holes, max vertical error %.3f px over %u pixels\n",
	              c.holes, c.worst_px, c.both);
	assert_int_equal(c.holes, 0);
	assert_true(c.both > BW * BH / 8);
	/* A different viewport size is refused. */
	struct relief_view small = v;
	small.width = BW / 2;
	const struct relief_draw_options bad = { .lod_view = &small };
	assert_int_equal(relief_terrain_draw(s.terrain, s.view, &moved, &s.target, 200, &bad, &st), -EINVAL);
	free(frozen);
	free(ids);
	free(ids_frozen);
	bound_close(&b);
}

/* With pass_timing, the LOD compute's time comes split by pass: intervals between
 * consecutive timestamps, so they add up to lod_ns, the first three to select_ns (each
 * rounded to a nanosecond on its own); every pass has work in a frame over Puget Sound.
 * The timestamps change nothing drawn; without them the split is 0. */
static void test_pass_timing(void **state)
{
	if (!vk->timestamp_valid_bits)
		skip();
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, BW, BH);
	load_everything(&s);
	struct relief_view v = pose_view(&three_views[0]);
	float *depth[2] = { malloc(sizeof(float) * BW * BH), malloc(sizeof(float) * BW * BH) };
	uint8_t *colour = malloc((size_t)4 * BW * BH);
	struct relief_terrain_stats st[2];
	const struct relief_draw_options timed = { .pass_timing = true };
	render_with(&s, &v, &timed, depth[1], &st[1]);
	memcpy(colour, s.target.color_readback.map, (size_t)4 * BW * BH);
	render(&s, &v, depth[0], &st[0]);
	assert_memory_equal(depth[1], depth[0], sizeof(float) * BW * BH);
	assert_memory_equal(colour, s.target.color_readback.map, (size_t)4 * BW * BH);
	uint64_t sum = 0, select = 0;
	for (int i = 0; i < RELIEF_LOD_PASSES; i++) {
		print_message("%-8s %.3f ms\n", relief_lod_pass_name(i), st[1].pass_ns[i] / 1e6);
		assert_true(st[1].pass_ns[i] > 0);
		assert_int_equal(st[0].pass_ns[i], 0);
		sum += st[1].pass_ns[i];
		if (i <= RELIEF_LOD_PASS_RECORDS)
			select += st[1].pass_ns[i];
	}
	print_message("LOD compute %.3f ms, of which selection and records %.3f ms\n", st[1].lod_ns / 1e6,
	              st[1].select_ns / 1e6);
	assert_true(sum <= st[1].lod_ns + RELIEF_LOD_PASSES && sum + RELIEF_LOD_PASSES >= st[1].lod_ns);
	assert_true(select <= st[1].select_ns + 3 && select + 3 >= st[1].select_ns);
	/* A frame that chooses its LOD only is timed the same way. */
	const struct relief_draw_options lod_only = { .pass_timing = true, .lod_only = true };
	assert_int_equal(relief_terrain_draw(s.terrain, s.view, &v, NULL, 200, &lod_only, &st[1]), 0);
	assert_true(st[1].pass_ns[RELIEF_LOD_PASS_FACTORS] > 0);
	assert_string_equal(relief_lod_pass_name(RELIEF_LOD_PASSES), "unknown");
	free(depth[0]);
	free(depth[1]);
	free(colour);
	scene_close(&s);
}

/* A view's buffers share two device memory allocations (device-local and host-visible), so
 * that a daemon keeping a view per client channel stays far below the 4,096 allocations a
 * device may allow; they used to take twelve. Its frames are unchanged (every LOD test
 * draws through such views). */
static void test_view_allocations(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_LUX, 1.0, 64, 64);
	unsigned before = atomic_load(&vk->allocations);
	struct relief_terrain_view *views[3];
	for (int i = 0; i < 3; i++)
		assert_int_equal(relief_terrain_view_create(s.terrain, &views[i]), 0);
	unsigned with = atomic_load(&vk->allocations);
	print_message("three more views: %u device memory allocations, %u before\n", with, before);
	assert_int_equal(with, before + 3 * 2);
	for (int i = 0; i < 3; i++)
		relief_terrain_view_destroy(views[i]);
	assert_int_equal(atomic_load(&vk->allocations), before);
	scene_close(&s);
}

static char limit_message[256];

static void keep_error(void *data, enum relief_log_level level, const char *fmt, va_list ap)
{
	if (level == RELIEF_LOG_ERROR)
		vsnprintf(limit_message, sizeof(limit_message), fmt, ap);
}

/* A device with less of a limit than the terrain needs beyond Vulkan's minimums is refused
 * with the limit's name and the need (check_limits() in terrain.c); with exactly the need,
 * the terrain is made. The limits are lowered in the context's copy of the device's. */
static void test_device_limits_named(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_LUX, 1.0, 64, 64);
	const VkPhysicalDeviceLimits saved = vk->props.limits;
	const struct relief_logger saved_log = vk->log;
	struct { const char *name; uint32_t *limit; } cases[] = {
		{ "maxPerStageDescriptorStorageBuffers", &vk->props.limits.maxPerStageDescriptorStorageBuffers },
		{ "maxDescriptorSetStorageBuffers", &vk->props.limits.maxDescriptorSetStorageBuffers },
		{ "maxDrawIndirectCount", &vk->props.limits.maxDrawIndirectCount },
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		vk->log = (struct relief_logger){ keep_error, NULL };
		struct relief_terrain *t = NULL;
		*cases[i].limit = 0;
		limit_message[0] = '\0';
		assert_int_equal(relief_terrain_create(vk, s.f, s.cache, &s.target, &t), -ENOTSUP);
		assert_null(t);
		print_message("limit 0: %s\n", limit_message);
		assert_non_null(strstr(limit_message, cases[i].name));
		const char *need = strstr(limit_message, "needs ");
		assert_non_null(need);
		uint32_t n = (uint32_t)strtoul(need + 6, NULL, 10);
		assert_true(n >= 1);
		*cases[i].limit = n - 1;
		assert_int_equal(relief_terrain_create(vk, s.f, s.cache, &s.target, &t), -ENOTSUP);
		vk->log = saved_log; /* nothing more is refused */
		*cases[i].limit = n;
		assert_int_equal(relief_terrain_create(vk, s.f, s.cache, &s.target, &t), 0);
		relief_terrain_destroy(t);
		vk->props.limits = saved;
	}
	scene_close(&s);
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
		cmocka_unit_test(test_views_share_cache),
		cmocka_unit_test(test_near_detail_takes_layers),
		cmocka_unit_test(test_tight_cache_settles),
		cmocka_unit_test(test_frozen_lod),
		cmocka_unit_test(test_views_in_flight),
		cmocka_unit_test(test_frames_captured),
		cmocka_unit_test(test_pass_timing),
		cmocka_unit_test(test_view_allocations),
		cmocka_unit_test(test_device_limits_named),
	};
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
