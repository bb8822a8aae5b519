/* The LOD picture: what culling and shading must not change (blocks the camera cannot
 * see, back faces, roll, detail in the shading), an old file version, no-data holes.
 * Validation layer on, zero messages. */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "decode.h"
#include "gpu_test.h"
#include "lod_scene.h"
#include "pack.h"

#define vk gpu_test_vk

/* Roll turns the picture about its centre: a camera rolled by 180 degrees shows the same
 * frame upside down (pixel (x, y) at (W-1-x, H-1-y)); the rotation maps pixel centres onto
 * pixel centres and keeps the frustum, so the same patches are drawn and depths agree
 * except where a triangle edge passes through a pixel centre (the rasteriser's tie rule is
 * not symmetric). A right bank (positive roll) raises the horizon on the right. */
static void test_roll_turns_picture(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	const struct pose level = { { 20000, 20000, 2500 }, { 60000, 60000, 2500 } };
	struct relief_view v = pose_view(&level);
	v.tau = 1;
	struct relief_terrain_stats st0, st1;
	render(&b.s, &v, b.ref, &st0);
	v.roll = M_PI;
	render(&b.s, &v, b.lod, &st1);
	assert_int_equal(st0.patches, st1.patches);
	uint32_t terrain = 0, differ = 0;
	for (int y = 0; y < BH; y++)
		for (int x = 0; x < BW; x++) {
			float a = b.ref[y * BW + x], c = b.lod[(BH - 1 - y) * BW + (BW - 1 - x)];
			terrain += a > 0.0f;
			differ += (a > 0.0f) != (c > 0.0f) || fabsf(a - c) > 1e-3f * fmaxf(a, c);
		}
	print_message("roll 180: %u of %u terrain pixels differ from the level frame turned over\n", differ, terrain);
	assert_true(terrain > BW * BH / 4);
	assert_true(differ <= terrain / 200);
	/* Right bank by 20 degrees: the first terrain row from the top, right column above the left. */
	v.roll = 20 * M_PI / 180;
	render(&b.s, &v, b.lod, &st1);
	int top[2] = { BH, BH };
	for (int side = 0; side < 2; side++) {
		int x = side ? BW - 1 : 0;
		for (int y = BH - 1; y >= 0; y--)
			if (b.lod[y * BW + x] > 0.0f)
				top[side] = y;
	}
	print_message("right bank: horizon at row %d on the left, %d on the right\n", top[0], top[1]);
	assert_true(top[1] + 20 < top[0]);
	bound_close(&b);
}

/* The picture keeps the data's resolution at coarse tessellation: looking straight down on
 * Mt Rainier (no silhouettes), the frame at tau = 8 looks nearly like the full-resolution
 * frame, because normals and the heights that pick colours come from the patch's maps per
 * fragment. What differs is where a vertical error moves a point sideways off the view's
 * centre. Negative controls, run by hand: per-vertex normals and heights (as before) give
 * an RMS difference of 14.75 steps, per-fragment normals with per-vertex heights 6.71;
 * both per fragment 3.03. */
static void test_shading_keeps_detail(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	const struct pose pose = { { 128480, 79200, 12000 }, { 128480, 79200, 0 } };
	struct relief_view v = pose_view(&pose);
	struct relief_terrain_stats full, coarse;
	render(&b.s, &v, b.ref, &full);
	uint8_t *ref = malloc((size_t)4 * BW * BH);
	memcpy(ref, b.s.target.color_readback.map, (size_t)4 * BW * BH);
	v.tau = 8;
	render(&b.s, &v, b.lod, &coarse);
	const uint8_t *rgba = b.s.target.color_readback.map;
	double sum = 0;
	for (size_t k = 0; k < (size_t)BW * BH; k++)
		for (int c = 0; c < 3; c++)
			sum += ((double)ref[4 * k + c] - rgba[4 * k + c]) * ((double)ref[4 * k + c] - rgba[4 * k + c]) / 3.0;
	double rms = sqrt(sum / (BW * BH));
	print_message("straight down on Rainier: %llu triangles at full resolution, %llu at tau 8; RMS colour "
	              "difference %.2f steps\n", (unsigned long long)full.triangles, (unsigned long long)coarse.triangles, rms);
	if (gpu_test_has_statistics(b.s.ctx))
		assert_true(coarse.triangles * 4 < full.triangles); /* really coarser */
	assert_true(rms < 4.5);
	free(ref);
	bound_close(&b);
}

/* Renders v with o, then again with the culling that *keep turns off (set here), and checks
 * that the two pictures, colour and depth, are the same bit for bit with terrain in them,
 * and that culling drew no more triangles, from no more quads; adds both triangle counts
 * to *culled and *all. */
static void check_cull_keeps_picture(struct bound_scene *b, struct relief_view *v, struct relief_draw_options *o,
                                     bool *keep, const char *what, uint64_t *culled, uint64_t *all)
{
	uint8_t *colour = malloc((size_t)BW * BH * 4);
	struct relief_terrain_stats with, without;
	*keep = false;
	render_with(&b->s, v, o, b->lod, &with);
	memcpy(colour, b->s.target.color_readback.map, (size_t)BW * BH * 4);
	*keep = true;
	render_with(&b->s, v, o, b->ref, &without);
	uint32_t terrain = 0;
	for (size_t k = 0; k < (size_t)BW * BH; k++)
		terrain += b->ref[k] > 0.0f;
	print_message("%s, %s tau %g: %u terrain pixels, %llu triangles in %llu quads culled, %llu in %llu not\n",
	              what, o->fine == RELIEF_FINE_ERRORS ? "relief" : "chunked", v->tau, terrain,
	              (unsigned long long)with.triangles, (unsigned long long)with.quads,
	              (unsigned long long)without.triangles, (unsigned long long)without.quads);
	assert_true(terrain > 0);
	assert_memory_equal(b->lod, b->ref, sizeof(float) * BW * BH);
	assert_memory_equal(colour, b->s.target.color_readback.map, (size_t)BW * BH * 4);
	if (gpu_test_has_statistics(b->s.ctx)) {
		assert_true(with.triangles <= without.triangles);
		/* A culled block runs no shader at all: only the quads that draw something are
		 * listed for the draws (lod_commands.comp), so fewer triangles means fewer quads. */
		assert_true(with.quads > 0 && with.quads <= without.quads);
		if (with.triangles < without.triangles)
			assert_true(with.quads < without.quads);
	}
	*culled += with.triangles;
	*all += without.triangles;
	free(colour);
}

/* Blocks the draw camera cannot see are not drawn (block_clip() in lod_factors.comp): the
 * picture, colour and depth, is bit for bit the one drawn with every block tessellated,
 * from views that cut through patches every way (grazing, steep, banked, straight down,
 * inside the mountain, on a patch corner, a level of detail chosen for one camera and
 * drawn from another), for relief at tau 1 and 4 and for chunked LOD; and culling draws
 * fewer triangles, from fewer quads. */
static void test_block_cull_keeps_picture(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	const struct { struct pose pose; double roll_deg; bool frozen; } cases[] = {
		{ { { 100000, 50000, 5500 }, { 128480, 79200, 3000 } }, 0, false },
		{ { { 5000, 5000, 400 }, { 160000, 150000, 100 } }, 0, false },        /* grazing */
		{ { { 126000, 77000, 4200 }, { 128480, 79200, 4000 } }, 0, false },    /* at the summit cliffs */
		{ { { 128480, 79200, 3000 }, { 130000, 80000, 3000 } }, 0, false },    /* inside the mountain */
		{ { { 81920, 81920, 2500 }, { 90000, 81920, 0 } }, 35, false },         /* on a patch corner, banked */
		{ { { 128480, 79200, 9000 }, { 128480, 79200, 0 } }, 150, false },      /* straight down */
		{ { { 60000, 40000, 1500 }, { 70000, 60000, 800 } }, -20, true },       /* LOD from elsewhere */
	};
	const struct { enum relief_fine_lod fine; double tau; } methods[] = {
		{ RELIEF_FINE_ERRORS, 1.0 }, { RELIEF_FINE_ERRORS, 4.0 }, { RELIEF_FINE_FULL, 1.0 },
	};
	uint64_t culled = 0, all = 0;
	const bool counts = gpu_test_has_statistics(b.s.ctx);
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++)
		for (size_t m = 0; m < sizeof(methods) / sizeof(methods[0]); m++) {
			struct relief_view v = pose_view(&cases[c].pose), lod = v;
			v.roll = cases[c].roll_deg * M_PI / 180;
			v.tau = lod.tau = methods[m].tau;
			if (cases[c].frozen) { /* chosen 400 m to the east and 300 m lower, looking elsewhere */
				lod.eye.x += 400;
				lod.eye.z -= 300;
				lod.target.x += 3000;
			}
			struct relief_draw_options o = { .fine = methods[m].fine, .lod_view = cases[c].frozen ? &lod : NULL };
			char what[32];
			snprintf(what, sizeof(what), "view %zu", c);
			check_cull_keeps_picture(&b, &v, &o, &o.no_block_cull, what, &culled, &all);
		}
	print_message("all views: %llu triangles with culling, %llu without\n", (unsigned long long)culled,
	              (unsigned long long)all);
	if (counts)
		assert_true(culled < all);
	bound_close(&b);
}

/* relief_surface_height_bound() holds for whatever a level of detail draws: every sample of
 * every level at the corners of the cell around a point, at every block level's spacing
 * (the vertices of any triangle that can cover it), lies at or below the bound there; at
 * random points and at points on block and patch borders, where the covering triangle may
 * belong to either side. And the bound is local: over most points it is below the file's
 * global bound (highest sample plus delta_0). */
static void test_surface_height_bound(void **state)
{
	(void)state;
	for (enum test_dem d = DEM_PUGET; d <= DEM_ALPS; d++) {
		struct relief_dem dem;
		test_dem_load(d, &dem);
		struct relief_pack_options po = { .patch = 129, .ratio = 2, .tolerance = 1.0 };
		uint8_t *img;
		size_t size;
		assert_int_equal(relief_pack_memory(&dem, &po, &img, &size, NULL), 0);
		relief_dem_finish(&dem);
		struct relief_file *f;
		char err[256];
		assert_int_equal(relief_file_open_memory(img, size, &f, err, sizeof(err)), 0);
		const struct relief_header *hd = &f->hdr;
		const uint32_t L = hd->levels, N = 4000;
		const double global = hd->height_max + f->layout.delta[0];
		uint32_t fw, fh, local = 0, checked = 0;
		relief_level_extent(hd, L - 1, &fw, &fh);
		double *gx = malloc(sizeof(double) * N), *gy = malloc(sizeof(double) * N), *bound = malloc(sizeof(double) * N);
		uint64_t seed = 12345;
		for (uint32_t i = 0; i < N; i++) { /* finest-grid coordinates; every fourth on a border */
			seed = seed * 6364136223846793005ull + 1442695040888963407ull;
			gx[i] = (double)(seed >> 11) / 9007199254740992.0 * (fw - 1);
			seed = seed * 6364136223846793005ull + 1442695040888963407ull;
			gy[i] = (double)(seed >> 11) / 9007199254740992.0 * (fh - 1);
			if (i % 4 == 1) /* on a vertical block border of some level */
				gx[i] = floor(gx[i] / RELIEF_BLOCK_CELLS) * RELIEF_BLOCK_CELLS;
			if (i % 4 == 3) /* on a patch corner */
				gx[i] = floor(gx[i] / (hd->patch_size - 1)) * (hd->patch_size - 1),
				gy[i] = floor(gy[i] / (hd->patch_size - 1)) * (hd->patch_size - 1);
			bound[i] = relief_surface_height_bound(f, hd->origin_x + gx[i] * hd->spacing_x,
			                                       hd->origin_y - gy[i] * hd->spacing_y);
			local += bound[i] < global;
		}
		for (uint32_t l = 0; l < L; l++) {
			uint32_t w, h;
			relief_level_extent(hd, l, &w, &h);
			float *q = malloc(sizeof(float) * w * h);
			assert_int_equal(relief_decode_level(f, l, 0, q, NULL), 0);
			const double scale = (double)(1u << (L - 1 - l)); /* finest samples per level-l sample */
			for (uint32_t i = 0; i < N; i++)
				for (uint32_t s = 1; s <= 16; s *= 2) { /* block levels: every s-th sample */
					double cx = gx[i] / scale, cy = gy[i] / scale;
					uint32_t x0 = (uint32_t)(floor(cx / s) * s), y0 = (uint32_t)(floor(cy / s) * s);
					/* the cell's corners; on a cell border also the cell before it */
					for (int dy = y0 == cy ? -1 : 0; dy <= 1; dy++)
						for (int dx = x0 == cx ? -1 : 0; dx <= 1; dx++) {
							int64_t x = (int64_t)x0 + dx * (int64_t)s, y = (int64_t)y0 + dy * (int64_t)s;
							if (x < 0 || y < 0 || x >= w || y >= h)
								continue;
							float z = q[(size_t)y * w + (size_t)x];
							if (!(z <= bound[i] + 1e-3))
								fail_msg("%s level %u spacing %u: sample (%lld, %lld) at %.3f m, above the bound "
								         "%.3f m at (%.2f, %.2f)", test_dem_name(d), l, s, (long long)x,
								         (long long)y, z, bound[i], gx[i], gy[i]);
							checked++;
						}
				}
			free(q);
		}
		print_message("%s: %u samples at or below the bound; bound local at %u of %u points\n", test_dem_name(d),
		              checked, local, N);
		assert_true(local > N / 2);
		/* Outside the grid: the global bound. */
		assert_true(relief_surface_height_bound(f, hd->origin_x - 10 * hd->spacing_x, hd->origin_y) == global);
		assert_true(relief_surface_height_bound(f, NAN, hd->origin_y) == global);
		free(gx);
		free(gy);
		free(bound);
		relief_file_close(f);
		free(img);
	}
}

/* Back faces are culled only where the camera is above the surface drawn under it, and
 * there the picture is the one drawn with them: views over the land and the water,
 * grazing, straight down, high outside each terrain edge looking at its curtain's outer
 * face, a level of detail chosen elsewhere; relief at tau 1 and chunked. The terrain covers
 * the same pixels; the few depths that differ are pixels whose centre a back face reached
 * first through the rasteriser's rounding. The decision is lod_commands.comp's, from the
 * blocks drawn around the eye: it culls wherever the CPU's bound over every level would
 * (relief_surface_height_bound()) and, at 450 m over the south-west corner, where that
 * bound would not (a hill of 416 m within a block; at 400 m nothing is culled). Inside the
 * mountain nothing is culled and the picture is the same bits. The height the GPU compared
 * the eye with equals its CPU twin's over the patches the frame drew
 * (relief_drawn_height_bound()). Without vkCmdDrawIndirectCount the CPU's bound decides
 * alone (checked by hiding the feature). */
static void test_face_cull_keeps_picture(void **state)
{
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	/* Puget Sound: x, y in [0, 163840] m, Mt Rainier (4380 m) at (128480, 79200). */
	/* frozen: the level of detail chosen 400 m east, `frozen` metres north and 300 m lower */
	const struct { struct pose pose; double roll_deg, frozen; bool culled; } cases[] = {
		{ { { 100000, 50000, 5500 }, { 128480, 79200, 3000 } }, 0, 0, true },
		{ { { 5000, 5000, 400 }, { 160000, 150000, 100 } }, 0, 0, false },      /* grazing, below a hill's top */
		{ { { 5000, 5000, 450 }, { 160000, 150000, 100 } }, 0, 0, true },       /* above it */
		{ { { 60000, 90000, 300 }, { 128480, 79200, 3000 } }, 0, 0, true },    /* low, at Rainier */
		{ { { 128480, 79200, 9000 }, { 128480, 79200, 0 } }, 150, 0, true },    /* straight down */
		{ { { -20000, 80000, 9000 }, { 10000, 80000, 0 } }, 0, 0, true },       /* west curtain */
		{ { { 183840, 80000, 9000 }, { 150000, 80000, 0 } }, 0, 0, true },      /* east */
		{ { { 80000, 183840, 9000 }, { 80000, 150000, 0 } }, 0, 0, true },      /* north */
		{ { { 80000, -20000, 9000 }, { 80000, 10000, 0 } }, 0, 0, true },       /* south */
		{ { { 60000, 40000, 1500 }, { 70000, 60000, 800 } }, -20, 300, true },     /* LOD from elsewhere */
		{ { { 100000, 50000, 9000 }, { 100000, 50000, 0 } }, 0, 5000, true },     /* the same, looking down */
		{ { { 128480, 79200, 3000 }, { 130000, 80000, 3000 } }, 0, 0, false },  /* inside the mountain */
	};
	/* relief and chunked with the GPU deciding, then relief with the CPU deciding */
	const struct { enum relief_fine_lod fine; bool gpu; } runs[] = {
		{ RELIEF_FINE_ERRORS, true }, { RELIEF_FINE_FULL, true }, { RELIEF_FINE_ERRORS, false },
	};
	const bool has_count = vk->has.draw_indirect_count;
	uint8_t *colour = malloc((size_t)BW * BH * 4);
	uint32_t only_gpu = 0, *ids = malloc(sizeof(uint32_t) * b.s.f->hdr.patch_count);
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++)
		for (size_t m = 0; m < sizeof(runs) / sizeof(runs[0]); m++) {
			const bool gpu = runs[m].gpu;
			vk->has.draw_indirect_count = gpu && has_count;
			struct relief_view v = pose_view(&cases[c].pose), lod = v;
			v.roll = cases[c].roll_deg * M_PI / 180;
			v.tau = lod.tau = 1.0;
			if (cases[c].frozen != 0) {
				lod.eye.x += 400;
				lod.eye.y += cases[c].frozen;
				lod.eye.z -= 300;
				lod.target.x += 3000;
			}
			const bool cpu = v.eye.z > relief_surface_height_bound(b.s.f, v.eye.x, v.eye.y) + 0.01;
			struct relief_draw_options o = { .fine = runs[m].fine, .lod_view = cases[c].frozen != 0 ? &lod : NULL };
			struct relief_terrain_stats culled, kept;
			render_with(&b.s, &v, &o, b.lod, &culled);
			memcpy(colour, b.s.target.color_readback.map, (size_t)BW * BH * 4);
			/* the GPU's height is the CPU twin's over the blocks the frame drew */
			uint32_t n = view_drawn(b.s.view, ids, b.s.f->hdr.patch_count);
			double twin = relief_drawn_height_bound(b.s.f, ids, n, v.eye.x, v.eye.y);
			if (gpu)
				assert_true(isnan(twin) ? isnan(culled.cull_height) : fabs(culled.cull_height - twin) < 1e-3);
			else
				assert_true(isnan(culled.cull_height));
			o.no_face_cull = true;
			render_with(&b.s, &v, &o, b.ref, &kept);
			uint32_t terrain = 0, coverage = 0, depths = 0, colours = 0;
			const uint8_t *ref_colour = b.s.target.color_readback.map;
			for (size_t k = 0; k < (size_t)BW * BH; k++) {
				terrain += b.ref[k] > 0.0f;
				coverage += (b.ref[k] > 0.0f) != (b.lod[k] > 0.0f);
				depths += b.ref[k] != b.lod[k];
				colours += memcmp(colour + 4 * k, ref_colour + 4 * k, 4) != 0;
			}
			print_message("view %zu, %s, %s deciding: %s (eye %.0f m, drawn blocks up to %.1f m, CPU bound: %s), "
			              "%u terrain pixels, %u change coverage, %u depth, %u colour\n", c,
			              runs[m].fine == RELIEF_FINE_ERRORS ? "relief" : "chunked", gpu ? "GPU" : "CPU",
			              culled.face_culled ? "culled" : "not culled", v.eye.z, twin, cpu ? "cull" : "draw", terrain,
			              coverage, depths, colours);
			assert_true(terrain > BW);
			assert_int_equal(culled.face_culled, gpu ? cases[c].culled : cpu);
			assert_true(!cpu || culled.face_culled);
			only_gpu += culled.face_culled && !cpu;
			assert_false(kept.face_culled);
			assert_int_equal(coverage, 0);
			assert_true(depths <= terrain / 1000 && colours <= terrain / 1000);
			if (!culled.face_culled)
				assert_int_equal(depths + colours, 0);
		}
	vk->has.draw_indirect_count = has_count;
	assert_true(only_gpu > 0); /* the view at 450 m */
	free(ids);
	free(colour);
	bound_close(&b);
}

/* A version-2 file (tests/data: the Mont Blanc crop, patch 65) still renders within tau
 * and without cracks: its block errors are read as eps_d + Err(P) and its block ranges as
 * the patch's range (format.h), a bound and a measuring height the renderer can use. */
static void test_old_version_renders(void **state)
{
	enum { W = 320, H = 180 };
	struct scene s = { .ctx = vk };
	char err[256];
	assert_int_equal(relief_file_open(test_data("alps-crop-140x100-v2.relief"), &s.f, err, sizeof(err)), 0);
	assert_int_equal(s.f->hdr.version, 2);
	struct relief_patch_cache_options co = { .budget_bytes = 16ull << 20 };
	assert_int_equal(relief_patch_cache_create(vk, s.f, &co, &gpu_test_log, &s.cache), 0);
	assert_int_equal(relief_vk_target_init(vk, &s.target, W, H), 0);
	assert_int_equal(relief_terrain_create(vk, s.f, s.cache, &s.target, &s.terrain), 0);
	assert_int_equal(relief_terrain_view_create(s.terrain, &s.view), 0);
	/* The crop spans x in [0, 12886] m, y in [0, 9177] m: from the south, looking north and down. */
	struct relief_view v = {
		.eye = { 6400, -3000, 5500 }, .target = { 6400, 5000, 2000 },
		.fovy = 50 * M_PI / 180, .width = W, .height = H, .znear = 5, .zfar = 1e5,
	};
	const double taus[] = { 1.0, 4.0 };
	within_tau_of_reference(&s, &v, taus, 2, "version 2 file", W * H / 8);
	scene_close(&s);
}

/* No-data stays a hole: looking down on Luxembourg (54 % valid, no-data outside the
 * border), no pixel shows terrain over a cell whose four samples are all no-data, and the
 * valid area is drawn. */
static void test_nodata_hidden(void **state)
{
	enum { W = 256, H = 256 };
	struct scene s;
	scene_open(&s, vk, DEM_LUX, 1.0, W, H);
	const struct relief_header *hd = &s.f->hdr;
	double cx = hd->origin_x + 0.5 * hd->spacing_x * (hd->width - 1);
	double cy = hd->origin_y - 0.5 * hd->spacing_y * (hd->height - 1);
	struct relief_view v = {
		.eye = { cx, cy - 100, 120000 }, .target = { cx, cy, 0 },
		.fovy = 40 * M_PI / 180, .width = W, .height = H, .znear = 1000, .zfar = 4e5, .tau = 1,
	};
	float *depth = malloc(sizeof(float) * W * H);
	struct relief_terrain_stats st;
	render(&s, &v, depth, &st);
	uint32_t w, h;
	relief_level_extent(hd, hd->levels - 1, &w, &h);
	float *finest = malloc(sizeof(float) * w * h);
	uint8_t *valid = malloc((size_t)w * h);
	assert_int_equal(relief_decode_level(s.f, hd->levels - 1, 0, finest, valid), 0);
	uint32_t over_hole = 0, over_data = 0, data_pixels = 0;
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++) {
			/* The terrain point, or where the background pixel's ray meets z = 300 m. */
			bool terrain = depth[y * W + x] > 0.0f;
			struct relief_vec3 p = relief_view_unproject(&v, x, y, terrain ? depth[y * W + x] : 0.5);
			if (!terrain) {
				double t = (300.0 - v.eye.z) / (p.z - v.eye.z);
				p = (struct relief_vec3){ v.eye.x + t * (p.x - v.eye.x), v.eye.y + t * (p.y - v.eye.y), 300.0 };
			}
			double gx = (p.x - hd->origin_x) / hd->spacing_x, gy = (hd->origin_y - p.y) / hd->spacing_y;
			if (gx < 0 || gy < 0 || gx >= w - 1 || gy >= h - 1)
				continue;
			uint32_t i = (uint32_t)gx, j = (uint32_t)gy;
			int n = valid[j * w + i] + valid[j * w + i + 1] + valid[(j + 1) * w + i] + valid[(j + 1) * w + i + 1];
			if (n == 0 && terrain)
				over_hole++;
			if (n == 4) {
				data_pixels++;
				over_data += terrain;
			}
		}
	print_message("Luxembourg from above: %u terrain pixels over no-data, %u of %u data pixels drawn\n", over_hole,
	              over_data, data_pixels);
	assert_int_equal(over_hole, 0);
	assert_true(data_pixels > 1000 && over_data == data_pixels);
	free(depth);
	free(finest);
	free(valid);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

/* Pixels the frame `lod` draws where the full-resolution frame `ref` of the same view shows
 * background: how many (*n), and the largest distance (pixel centres, Euclidean) from one
 * of them to the nearest pixel `ref` draws, up to `cap`. */
static double over_coverage_px(const float *ref, const float *lod, int W, int H, int cap, uint32_t *n)
{
	double worst = 0.0;
	*n = 0;
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++) {
			if (!(lod[y * W + x] > 0.0f) || ref[y * W + x] > 0.0f)
				continue;
			(*n)++;
			double best = cap;
			for (int yy = y - cap; yy <= y + cap; yy++)
				for (int xx = x - cap; xx <= x + cap; xx++)
					if (xx >= 0 && yy >= 0 && xx < W && yy < H && ref[yy * W + xx] > 0.0f)
						best = fmin(best, hypot(xx - x, yy - y));
			worst = fmax(worst, best);
		}
	return worst;
}

/* What the finest level draws of a flat plain at height 0 (N x N samples 30 m apart,
 * grid_dem()) with validity `valid`, seen by v: 1 where the ray through a pixel's centre
 * meets the plane at a point whose nearest sample is valid, else 0 (the fragment shader's
 * rule, docs/lod.md "No-data"). Worked out here rather than rendered: a frame's coverage
 * follows its selection, which splits a flat plain (E0(P) 0) only for coverage itself. */
static void plain_coverage(const struct relief_view *v, const uint8_t *valid, int N, float *out)
{
	for (int y = 0; y < (int)v->height; y++)
		for (int x = 0; x < (int)v->width; x++) {
			struct relief_vec3 p = relief_view_unproject(v, x, y, 0.5);
			double t = -v->eye.z / (p.z - v->eye.z);
			double col = (v->eye.x + t * (p.x - v->eye.x)) / 30.0;
			double row = (N - 1) - (v->eye.y + t * (p.y - v->eye.y)) / 30.0;
			long c = lround(col), r = lround(row);
			out[y * (int)v->width + x] =
				t > 0 && c >= 0 && r >= 0 && c < N && r < N && valid[(size_t)r * (size_t)N + (size_t)c];
		}
}

/* Coverage past no-data moves by at most tau. A coarse patch draws up to its level's
 * spacing past the data's edge (docs/lod.md, "No-data"), so the selection splits where
 * that projects beyond tau (relief_patch_select_error()). Every pixel a frame draws where
 * the full-resolution frame shows background lies within tau + 1 pixels (the rasteriser's
 * pixel) of one that frame draws, the frame leaves no hole in it, and the no-data shows.
 * Two scenes: a flat plain (every E0(P) 0, so that only coverage makes a patch split)
 * around a round no-data lake, 513 x 513 samples 30 m apart in 65-sample patches (4
 * levels: the root's samples 8 apart), from above and obliquely, against its coverage
 * worked out (plain_coverage()), the GPU's selection equal to the CPU reference's; and
 * Puget Sound with its water as no-data (a real coast), from above, against the
 * full-resolution frame, within tau there too. Negative
 * control, run when this was written (the selection's error E0(P) alone): the plain's
 * root patch drawn alone from 3 km at tau 1, 4,330 pixels past the worked-out coverage,
 * up to 20.5 px from it; the CPU reference alone without the coverage error, its root
 * against the GPU's 8 patches. */
static void test_coverage_within_tau(void **state)
{
	enum { N = 513, CAP = 48 };
	const double lx = 200.5, ly = 300.3, lr = 37.3; /* the lake: centre (column, row) and radius, samples */
	const double cx = 30.0 * lx, cy = 30.0 * (N - 1 - ly); /* its centre, world */
	const struct named_pose { const char *what; struct pose pose; bool hole_at_centre; } lake[] = {
		{ "straight down from 3 km", { { cx, cy, 3000 }, { cx, cy, 0 } }, true },
		{ "straight down from 12 km", { { cx, cy, 12000 }, { cx, cy, 0 } }, true },
		{ "obliquely from 1.5 km", { { cx, cy - 3000, 1500 }, { cx, cy, 0 } }, false },
	}, sound[] = {
		{ "from 40 km", { { 80000, 100000, 40000 }, { 80000, 100001, 0 } }, false },
		{ "from 8 km", { { 60000, 110000, 8000 }, { 60000, 110001, 0 } }, false },
	};
	const double taus[] = { 1.0, 4.0, 16.0 };
	for (int scene = 0; scene < 2; scene++) {
		struct bound_scene b;
		struct relief_dem dem;
		if (scene == 0) {
			dem = grid_dem(N);
			for (int y = 0; y < N; y++)
				for (int x = 0; x < N; x++)
					dem.valid[(size_t)y * N + x] = hypot(x - lx, y - ly) > lr;
			bound_open_dem_patch(&b, vk, &dem, 65);
		} else {
			test_dem_load(DEM_PUGET, &dem);
			for (size_t i = 0; i < (size_t)dem.width * dem.height; i++)
				dem.valid[i] = dem.heights[i] > 0.5f; /* the Sound and the sea as no-data */
			bound_open_dem(&b, vk, &dem);
		}
		relief_dem_finish(&dem);
		uint32_t *ids = malloc(sizeof(uint32_t) * b.s.f->hdr.index_records); /* drawn patches have entries */
		assert_non_null(ids);
		const struct named_pose *cases = scene == 0 ? lake : sound;
		const size_t n_cases = scene == 0 ? sizeof(lake) / sizeof(lake[0]) : sizeof(sound) / sizeof(sound[0]);
		for (size_t c = 0; c < n_cases; c++) {
			struct relief_view v = pose_view(&cases[c].pose);
			struct relief_terrain_stats st;
			if (scene == 0)
				plain_coverage(&v, b.valid, N, b.ref);
			else
				render(&b.s, &v, b.ref, &st);
			for (size_t t = 0; t < sizeof(taus) / sizeof(taus[0]); t++) {
				v.tau = taus[t];
				render(&b.s, &v, b.lod, &st);
				uint32_t n, over;
				const uint32_t levels = drawn_levels(&b.s, ids, &n);
				const double worst = over_coverage_px(b.ref, b.lod, BW, BH, CAP, &over);
				struct comparison cmp = { 0 };
				if (scene == 1) {
					cmp = compare(&b.s, &v, b.ref, b.lod, b.drawn, b.valid, b.fw, b.fh);
					assert_true(cmp.worst_px <= v.tau && cmp.both > (uint32_t)BW * BH / 8);
				} else { /* a hole: the plain shows there and all around, the frame does not */
					for (int y = 1; y + 1 < BH; y++)
						for (int x = 1; x + 1 < BW; x++) {
							bool all = true;
							for (int k = 0; k < 9; k++)
								all = all && b.ref[(y - 1 + k / 3) * BW + x - 1 + k % 3] > 0.0f;
							cmp.holes += all && !(b.lod[y * BW + x] > 0.0f);
						}
				}
				print_message("%s, %s, tau %g: %u patches (levels mask 0x%x), %u pixels drawn past the full-resolution "
				              "frame's, at most %.2f px from it; %u holes, max error %.3f px\n",
				              scene ? "Puget Sound" : "lake", cases[c].what, v.tau, n, levels, over, worst,
				              cmp.holes, cmp.worst_px);
				assert_true(worst <= v.tau + 1.0);
				assert_int_equal(cmp.holes, 0);
				if (cases[c].hole_at_centre)
					assert_true(b.lod[(BH / 2) * BW + BW / 2] <= 0.0f);
				/* the selection that splits for coverage, on the GPU and in the CPU reference */
				if (scene == 0)
					assert_true(fresh_view_matches_cpu(&b.s, &v, 200 + t, NULL) > 0);
			}
		}
		free(ids);
		bound_close(&b);
	}
}

/* `relief bench lod` leaves a frame's terrain-edge curtain out of its error statistics:
 * the pixels whose depth changes when the frame is drawn again without curtains
 * (tools/bench_lod_measure.c, mark_curtains()). That holds where the two draws differ in
 * the curtains alone. From outside three of Puget Sound's edges, low and looking at the
 * curtain's outer face, and from above the terrain along an edge (no curtain shows, and
 * nothing changes), relief at tau 1 and 4:
 * every pixel that changes shows a point on an edge's vertical plane (a curtain hangs from
 * the drawn edge, which may lie above the finest surface by the level of detail's error),
 * and every pixel showing such a point 5 m or more under the finest surface changes. */
static void test_curtain_pixels(void **state)
{
	const struct pose poses[] = {
		{ { 80000, -6000, 200 }, { 80000, 20000, -1500 } },   /* south of the south edge */
		{ { 170000, 30000, 400 }, { 150000, 60000, -1000 } }, /* east of the east edge */
		{ { -3000, 150000, 100 }, { 10000, 120000, -800 } },  /* west of the west edge */
		{ { 30000, 150000, 6000 }, { 90000, 163840, 0 } },   /* over the terrain, along the north edge */
	};
	const double taus[] = { 1.0, 4.0 };
	struct bound_scene b;
	bound_open(&b, vk, DEM_PUGET);
	const struct relief_header *h = &b.s.f->hdr;
	const double x1 = h->spacing_x * (b.fw - 1), y0 = h->origin_y - h->spacing_y * (b.fh - 1);
	const struct relief_draw_options bare = { .no_skirts = true };
	for (size_t c = 0; c < sizeof(poses) / sizeof(poses[0]); c++)
		for (size_t t = 0; t < 2; t++) {
			struct relief_view v = pose_view(&poses[c]);
			v.tau = taus[t];
			struct relief_terrain_stats st;
			render(&b.s, &v, b.lod, &st);
			render_with(&b.s, &v, &bare, b.ref, &st);
			uint32_t changed = 0, curtain = 0, stray = 0, missed = 0;
			for (int y = 0; y < BH; y++)
				for (int x = 0; x < BW; x++) {
					const float d = b.lod[y * BW + x];
					const bool differs = d != b.ref[y * BW + x];
					changed += differs;
					if (!(d > 0.0f)) {
						stray += differs; /* background in the frame with curtains */
						continue;
					}
					struct relief_vec3 p = relief_view_unproject(&v, x, y, d);
					/* on an edge's plane (within 1e-5 of the distance: the depth's rounding; the
					 * surface beside the edge lies farther off) */
					const double tol = 1e-5 * hypot(hypot(p.x - v.eye.x, p.y - v.eye.y), p.z - v.eye.z);
					const bool plane = fabs(p.x - h->origin_x) < tol || fabs(p.x - h->origin_x - x1) < tol ||
					                   fabs(p.y - h->origin_y) < tol || fabs(p.y - y0) < tol;
					const double dz = relief_surface_vertical_error(b.s.f, b.drawn, b.valid, b.fw, b.fh, 1, p, NULL);
					if (differs && !plane)
						stray++;
					if (plane && dz < -5.0) {
						curtain++;
						missed += !differs;
					}
				}
			print_message("pose %zu, tau %g: %u pixels change without curtains, %u on a curtain 5 m or more under the "
			              "surface, %u of those unchanged, %u changed elsewhere\n",
			              c, v.tau, changed, curtain, missed, stray);
			assert_int_equal(stray, 0);
			assert_int_equal(missed, 0);
			if (c < 3)
				assert_true(curtain > (uint32_t)BW * BH / 50); /* the outer face fills part of the frame */
		}
	bound_close(&b);
}

/* Blocks without a valid sample are not tessellated (block_has_data() in lod_factors.comp):
 * the picture, colour and depth, is bit for bit the one drawn with them, and fewer
 * triangles are drawn, on Luxembourg (no-data outside the country, and the padding of its
 * one patch) and on Puget Sound with its water as no-data (a coast), for relief at tau 1
 * and 4 and chunked LOD, from above, obliquely across the edge of the data and grazing. */
static void test_blocks_without_data_culled(void **state)
{
	const struct named_pose { const char *what; struct pose pose; } lux[] = {
		{ "above", { { 0, -100, 120000 }, { 0, 0, 0 } } },
		{ "oblique from the south-west, outside", { { -45000, -60000, 20000 }, { 0, 0, 300 } } },
		{ "grazing across the border", { { 20000, -30000, 900 }, { -10000, 30000, 300 } } },
	}, coast[] = {
		{ "above", { { 82000, 78000, 200000 }, { 82000, 82000, 0 } } },
		{ "oblique over the water", { { 40000, 150000, 6000 }, { 60000, 100000, 0 } } },
		{ "grazing", { { 50000, 160000, 300 }, { 80000, 120000, 100 } } },
	};
	const struct { enum relief_fine_lod fine; double tau; } methods[] = {
		{ RELIEF_FINE_ERRORS, 1.0 }, { RELIEF_FINE_ERRORS, 4.0 }, { RELIEF_FINE_FULL, 1.0 },
	};
	for (int scene = 0; scene < 2; scene++) {
		struct bound_scene b;
		struct relief_dem dem;
		const struct named_pose *cases = scene == 0 ? lux : coast;
		if (scene == 0) {
			bound_open(&b, vk, DEM_LUX);
		} else { /* the Sound and the sea, heights at or below 0.5 m, as no-data */
			test_dem_load(DEM_PUGET, &dem);
			size_t n = (size_t)dem.width * dem.height, water = 0;
			for (size_t i = 0; i < n; i++)
				if (dem.heights[i] <= 0.5f) {
					dem.valid[i] = 0;
					water++;
				}
			print_message("Puget Sound: %zu of %zu samples water (no-data)\n", water, n);
			assert_true(water > n / 50);
			bound_open_dem(&b, vk, &dem);
		}
		const bool counts = gpu_test_has_statistics(b.s.ctx);
		uint64_t culled = 0, all = 0;
		for (size_t c = 0; c < 3; c++)
			for (size_t m = 0; m < sizeof(methods) / sizeof(methods[0]); m++) {
				struct relief_view v = pose_view(&cases[c].pose);
				v.tau = methods[m].tau;
				struct relief_draw_options o = { .fine = methods[m].fine };
				char what[80];
				snprintf(what, sizeof(what), "%s, %s", scene ? "coast" : "Luxembourg", cases[c].what);
				check_cull_keeps_picture(&b, &v, &o, &o.keep_empty_blocks, what, &culled, &all);
			}
		print_message("%s: %llu triangles, %llu with empty blocks\n", scene ? "coast" : "Luxembourg",
		              (unsigned long long)culled, (unsigned long long)all);
		if (counts)
			assert_true(culled < all);
		bound_close(&b);
		if (scene == 1)
			relief_dem_finish(&dem);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_roll_turns_picture),
		cmocka_unit_test(test_shading_keeps_detail),
		cmocka_unit_test(test_block_cull_keeps_picture),
		cmocka_unit_test(test_surface_height_bound),
		cmocka_unit_test(test_face_cull_keeps_picture),
		cmocka_unit_test(test_old_version_renders),
		cmocka_unit_test(test_nodata_hidden),
		cmocka_unit_test(test_coverage_within_tau),
		cmocka_unit_test(test_curtain_pixels),
		cmocka_unit_test(test_blocks_without_data_culled),
	};
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
