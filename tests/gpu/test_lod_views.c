/* Compute LOD, the views: several views share one cache (a tight one settles, near detail
 * takes far patches' layers), frames of several views in flight and captured in one
 * command buffer, a frozen level of detail seen from elsewhere, the LOD compute timed by
 * pass, a view's memory allocations, device limits the terrain needs. Validation layer
 * on, zero messages. (The selection against its CPU reference: test_lod_select.c.) */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "gpu_test.h"
#include "lod_scene.h"

#define vk gpu_test_vk

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
	/* The four caches and terrains above (one after the other, each frame equal to the
	 * others') took the decode and LOD pipelines the device made for the first: one shared
	 * object each (relief_vk_shared()). */
	assert_int_equal(vk->n_shared, 2);
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
	struct comparison c = compare(&s, &moved, b.ref, frozen, b.drawn, b.valid, b.fw, b.fh);
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
		if (i <= RELIEF_LOD_PASS_SELECT)
			select += st[1].pass_ns[i];
	}
	print_message("LOD compute %.3f ms, of which selection %.3f ms\n", st[1].lod_ns / 1e6,
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
		{ "maxPerStageDescriptorSampledImages", &vk->props.limits.maxPerStageDescriptorSampledImages },
		{ "maxDescriptorSetSampledImages", &vk->props.limits.maxDescriptorSetSampledImages },
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

/* Texel buffers (relief_vk_texel_view_create()): a view whose buffers hold more texels than
 * maxTexelBufferElements is refused naming the limit, and a cache takes no more layers
 * than its block records' texel view can hold, maxTexelBufferElements / the words of a
 * layer's record (Puget Sound has 85 patches; the limit leaves room for 40). */
static void test_texel_buffer_limits(void **state)
{
	struct scene s;
	scene_open(&s, vk, DEM_PUGET, 1.0, 64, 64);
	const VkPhysicalDeviceLimits saved = vk->props.limits;
	const struct relief_logger saved_log = vk->log;
	vk->log = (struct relief_logger){ keep_error, NULL };
	limit_message[0] = '\0';
	vk->props.limits.maxTexelBufferElements = 1;
	struct relief_terrain_view *v = NULL;
	assert_int_equal(relief_terrain_view_create(s.terrain, &v), -ENOTSUP);
	assert_null(v);
	print_message("limit 1: %s\n", limit_message);
	assert_non_null(strstr(limit_message, "maxTexelBufferElements"));
	vk->log = saved_log;
	vk->props.limits = saved;
	assert_int_equal(relief_terrain_view_create(s.terrain, &v), 0);
	relief_terrain_view_destroy(v);

	const size_t words = relief_patch_layer_floats(s.f->hdr.patch_size);
	const struct relief_patch_cache_options o = { .budget_bytes = 64u << 20, .staging_slots = 2 };
	struct relief_patch_cache *c = NULL;
	vk->props.limits.maxTexelBufferElements = (uint32_t)(40 * words + words / 2);
	int ret = relief_patch_cache_create(vk, s.f, &o, NULL, &c);
	vk->props.limits = saved;
	assert_int_equal(ret, 0);
	assert_int_equal(relief_patch_cache_pool(c)->layers, 40);
	relief_patch_cache_destroy(c);
	scene_close(&s);
	gpu_test_assert_clean(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_views_share_cache),
		cmocka_unit_test(test_near_detail_takes_layers),
		cmocka_unit_test(test_tight_cache_settles),
		cmocka_unit_test(test_frozen_lod),
		cmocka_unit_test(test_views_in_flight),
		cmocka_unit_test(test_frames_captured),
		cmocka_unit_test(test_pass_timing),
		cmocka_unit_test(test_view_allocations),
		cmocka_unit_test(test_device_limits_named),
		cmocka_unit_test(test_texel_buffer_limits),
	};
	return cmocka_run_group_tests(tests, gpu_test_group_setup, gpu_test_group_teardown);
}
