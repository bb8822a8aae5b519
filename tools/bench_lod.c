/* relief bench lod FILE.relief: what accuracy costs in time. A fixed flight over the terrain
 * is rendered with relief's LOD at several tau, and in the same run with three baselines:
 *   full-grid   the finest patches at full tessellation (no LOD at all);
 *   distance    the finest patches, tessellated from the projected edge length alone
 *               (Cantlay / Sascha Willems style, no error metric), target_px per triangle;
 *   chunked     the same quadtree selection with tau, patches at full resolution
 *               (no fine tessellation LOD).
 * On request, relief again with views that geomorph (--morphed, relief-morphed), with the
 * transition strips unbounded (--loose, relief-loose: what bounding them costs) and relief
 * and chunked without block culling (--unculled).
 * The cache is warm (every patch resident), so frames measure LOD, not streaming.
 * triangles and quads: per frame, the primitives reaching the clipper and the quad patches
 * the control shader ran for (pipeline statistics; 0 where the device has none). Where the
 * device captures meshes, the same triangles by where they fall (mesh_cover.h), per frame:
 * tri_outside (beyond a plane of the frustum), tri_eye (reaching the eye's plane), tri_back
 * (facing away), tri_no_pixel (facing the camera, no pixel centre inside), tri_pixels (some
 * inside), and pixels_per_tri, the centres inside those on average: a CPU device's
 * rasteriser does little for the first kinds (docs/benchmarks.md, "What a triangle costs").
 *
 * Error: at every pixel showing terrain, the vertical distance from the drawn surface to the
 * finest decoded surface, projected to pixels (the quantity tau bounds); max and RMS over all
 * frames. The full-resolution render runs first and is the reference: where it is itself
 * more than REF_NOISE_PX off the surface (a near edge-on triangle at a silhouette, whose
 * depth the rasteriser interpolates badly, or a terrain-edge curtain), the pixel measures
 * the rasteriser or the curtain, not the LOD, and is left out of every method's
 * statistics; the count is reported (excluded_pixels). So is every other pixel where a
 * method's frame shows a terrain-edge curtain (curtain_pixels: the pixels whose depth
 * changes when the frame is drawn again without curtains, bench_lod_measure.c): where the
 * level of detail moves coverage beside no-data (within tau) or a silhouette (within tau)
 * in front of a curtain's inner face, the reference shows the surface or nothing there,
 * and the curtain's depth below the edge would read as several tau.
 * Rechecked maximum (max_err_3x_px, for the methods that bound their error by tau: relief
 * and chunked): every pixel whose error comes out over tau is measured again on a render at
 * three times the resolution with three times tau, which is the same angular threshold and
 * so the same level of detail (checked: the same triangle count), and whose pixel
 * (3x + 1, 3y + 1) is the same ray. Where the two disagree, what differed is how the
 * rasteriser interpolated depth at that pixel centre (a far sliver triangle, whose plane
 * the snapped vertices tilt), not the surface drawn; the ray's error at three times the
 * resolution, in pixels of the frame, stands for the pixel. max_err_px stays the raw value;
 * over_tau_pixels counts the pixel-frames rechecked, unresolved_pixels those that could not
 * be (another level of detail, or no terrain on the ray), which keep their raw value;
 * recheck_diff_px and recheck_rms_diff_px are the largest and the RMS change a recheck
 * made. --recheck-all rechecks every pixel, a check of the recheck itself (tests/cli).
 * Triangle by triangle (December 2026, where the device has the mesh capture,
 * relief_terrain_view_mesh()): each frame of the first run is drawn once more with its
 * triangles captured, and relief_mesh_error() measures every one of them in the frustum
 * against the finest surface everywhere on it, hidden ones included: max_err_mesh_px
 * (nearer diagonal, as the pixels), and split by kind, max_err_mesh_transition_px (the
 * tessellator's transition triangles, which no block error bounds) and
 * max_err_mesh_regular_worse_px (the triangles of a block level's own triangulation above
 * full resolution, against the worse diagonal: what the block errors bound);
 * transition_triangles per frame; the transition triangles by kind (relief_mesh_kind()):
 * max_err_mesh_coarse_edge_px (strips along an edge coarser than the interior),
 * max_err_mesh_fine_edge_px (finer than the interior), max_err_mesh_fan_px (finer than an
 * interior that is its centre alone), and other_triangles, those of no kind over all
 * frames (0 for relief and chunked LOD wherever the tessellator builds its transition
 * strips as docs/lod.md describes; the distance baseline's factors are not powers of two,
 * and its transitions are of no kind); mesh_seams, the positions drawn at two heights and
 * the T-junctions over all frames (relief_mesh_seams(): 0 for a watertight mesh, every
 * method's). Absent where not measured.
 * Popping: what the change of level of detail alone does between consecutive frames (each
 * key pose and the frame after it, 1/60 s later at 250 m/s): the second frame's camera
 * draws once with its own LOD and once with the first frame's LOD (frozen, see
 * relief_draw_options.lod_view); the RMS over pixels of the difference of the two signed
 * errors, averaged over the pairs. Same camera, same pixels, so this is the DSS paper's
 * measure (the change of the height difference at the same place) in pixels. Those signed
 * errors are taken against one fixed surface, the mean of a finest cell's two diagonal
 * triangulations (since the eighth December 2026 session; before, against the nearer
 * diagonal, as the error statistics are, whose side flips when a point crosses the middle
 * between the two, so that a surface moving by a hair counted twice its error there).
 * Until the fourth session popping_px was the change of the error between the two frames' own
 * pictures, which also counts the error field moving under the pixels as the camera moves
 * (static geometry pops there too); that measure is still printed as camera_popping_px.
 * The JSON also has the median and the largest per-pair value (popping_pair_median_px,
 * popping_pair_max_px): the average is made by a few pairs that catch a level switch of
 * a distant ridge, and a small change of the LOD moves it a lot (docs/benchmarks.md). So it
 * also counts those events: popping_events of popping_pairs pairs changed some pixel's
 * error by more than POP_EVENT_PX, popping_event_pixels pixels in all, popping_pixel_max_px
 * the largest change of one pixel. The full-resolution render's own such pixels (its level
 * of detail never changes: the rasteriser drawing from the other camera's origin, up to
 * 55 px at a silhouette on Mont Blanc) are left out of every other method's popping,
 * counted as popping_excluded_pixels. Where the device captures meshes, each event's two
 * frames' quads are compared place by place (mesh_diff.h): popping_event_interiors,
 * popping_event_edges and popping_event_coarse count, over the events, the quads whose inner
 * factor changed, those whose outer factors alone did, and the places only one frame draws
 * (the coarse selection or the block culling changed there); --trace-events lists them
 * per event on stderr.
 * --every-frame K: the pairs are those of every frame of the flight's line that some
 * method's level change falls in and K spread evenly, and popping_px, camera_popping_px and
 * shade_popping are each method's stratified means over all of the line's pairs
 * (bench_flight.h), with popping_se_px and the others' standard errors.
 * shade_popping is the same comparison on the picture itself: the RMS over pixels showing
 * terrain in both of the colour difference (RGB distance / sqrt 3, in 8-bit steps)
 * between the two renders, averaged over the pairs; what a viewer sees change, lighting
 * included, where popping_px is the surface alone. shade_err compares each frame's picture
 * with the full-resolution render's the same way (RMS over all frames): what the level of
 * detail costs in what a viewer sees, lighting included (docs/lod.md, shading).
 * face_culled_frames: frames of the first run drawn with back faces culled (the camera above
 * the surface drawn under it, docs/lod.md "Back faces").
 * GPU time: timestamps around LOD compute, drawing and copy-out, per frame; median and p95
 * over all frames of all runs, the runs taken in turn over the configurations. All LOD
 * compute (selection, tessellation factors, draw records) is lod_ms (JSON lod_ms_median),
 * the coarse part alone (the setup and the selection; with a pass of its own for the draw
 * records until the thirty-second December session) sel_ms (select_ms_median; until the
 * third session select_ms_median meant all LOD compute).
 * At equal measured error (relief's configurations, relief-* included): for each baseline
 * (full-grid, distance, chunked), its fastest configuration whose largest error is at most
 * the row's (bench_match.h), and the row's speedup over it (that configuration's median
 * frame time over the row's; JSON objects with baseline, its tau_px, error, gpu_ms_median
 * and speedup, -1 where the device gave no times): at_equal_error by max_err_px (the error at pixels, this
 * benchmark's measure), at_equal_mesh_error by max_err_mesh_px (on any triangle) where the
 * mesh is measured; a baseline none of whose configurations is as accurate is left out. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "bench_flight.h"
#include "bench_lod.h"
#include "bench_match.h"
#include "bench_util.h"
#include "cli.h"
#include "decode.h"
#include "format.h"
#include "patch_cache.h"
#include "renderer.h"
#include "terrain.h"
#include "vk.h"

/* --passes: one more run of each configuration, its timed frames drawn with a timestamp
 * after each LOD pass; the medians of each pass and of the LOD compute they make up. */
static int measure_passes(struct run *r, const struct config *cfg, int n, struct result *res)
{
	const size_t frames = 2 * (size_t)r->frames;
	double *ms = malloc(sizeof(double) * frames * (3 + RELIEF_LOD_PASSES));
	int ret = ms ? 0 : -ENOMEM;
	const struct frame_times t = { ms, ms + frames, ms + 2 * frames, ms + 3 * frames };
	for (int i = 0; i < n && ret == 0; i++) {
		if ((ret = bench_lod_measure(r, &cfg[i], false, &t, &res[i])) < 0) {
			fprintf(stderr, "relief bench lod: %s with pass timing: %s\n", cfg[i].method, strerror(-ret));
			break;
		}
		res[i].profiled_lod_ms = bench_median(t.lod, frames);
		for (int p = 0; p < RELIEF_LOD_PASSES; p++)
			res[i].pass_ms[p] = bench_median(t.pass + (size_t)p * frames, frames);
	}
	free(ms);
	return ret;
}

/* The flight: `frames` key poses (bench_flight.h), each followed by the next frame
 * (views 2i and 2i + 1), so that popping is measured between frames as close as a real
 * image generator renders them. */
static void flight(const struct relief_file *f, uint32_t frames, uint32_t w, uint32_t h, struct relief_view *views)
{
	const double step = bench_flight_step(f, frames);
	for (uint32_t i = 0; i < 2 * frames; i++)
		views[i] = bench_flight_view(f, w, h, frames, i / 2 + (i % 2 ? step : 0.0));
}

/* -1 for what could not be measured (JSON has no NaN). */
static double finite_or(double x)
{
	return isfinite(x) ? x : -1;
}

/* At most this many pairs measured with --every-frame. */
#define EVERY_FRAME_CAP 500

/* The pairs measured with --every-frame: each configuration's level of detail chosen for
 * every frame of the line in turn (bench_flight_events()), then every pair in which one of
 * them draws other patches and `sample` pairs spread evenly (bench_flight_choose()). Sets
 * r->frames to their count and r->flight_*; cfg[i].changed keeps configuration i's
 * LOD-change pairs. -E2BIG when more than EVERY_FRAME_CAP pairs are needed. */
static int every_frame_choose(struct run *r, struct config *cfg, int n, uint32_t sample, uint32_t w, uint32_t h,
                              uint32_t *at, uint8_t *sampled)
{
	const uint32_t pairs = bench_flight_frames(r->f) - 1;
	const struct relief_view pose = bench_flight_view(r->f, w, h, 1, 0.0);
	const uint8_t *changed[MAX_CONFIGS];
	for (int i = 0; i < n; i++) {
		if (!(cfg[i].changed = calloc(pairs, 1)))
			return -ENOMEM;
		struct relief_terrain_view *tv;
		int ret = relief_terrain_view_create(r->gpu.terrain, &tv);
		if (ret < 0)
			return ret;
		const struct relief_view like = bench_lod_config_view(&cfg[i], &pose);
		ret = bench_flight_events(r->f, r->gpu.terrain, tv, &like, &cfg[i].opts, cfg[i].changed);
		relief_terrain_view_destroy(tv);
		if (ret < 0)
			return ret;
		changed[i] = cfg[i].changed;
	}
	int count = bench_flight_choose(pairs, changed, (uint32_t)n, sample, at, sampled, EVERY_FRAME_CAP);
	if (count < 0)
		return count;
	r->frames = (uint32_t)count;
	r->flight_at = at;
	r->flight_sampled = sampled;
	r->flight_pairs = pairs;
	return 0;
}

/* Every configuration rendered `runs` times, the runs going round the configurations so that
 * a slow spell of the machine spreads over all of them, the errors measured on the first run
 * (they do not change); each configuration's medians and p95 over all its timed frames go
 * to res[i]. Negative errno on failure, said on stderr. */
static int runs_measure(struct run *r, const struct config *cfg, int n, uint32_t runs, struct result *res)
{
	const size_t per_run = 2 * (size_t)r->frames, total = (size_t)n * runs * per_run;
	double *ms = calloc(3 * total, sizeof(double));
	if (!ms) {
		fprintf(stderr, "relief bench lod: out of memory\n");
		return -ENOMEM;
	}
	double *sel = ms + total, *lod = sel + total;
	int ret = 0;
	for (uint32_t run = 0; run < runs && ret == 0; run++)
		for (int i = 0; i < n && ret == 0; i++) {
			size_t at = ((size_t)i * runs + run) * per_run;
			const struct frame_times t = { ms + at, sel + at, lod + at, NULL };
			if ((ret = bench_lod_measure(r, &cfg[i], run == 0, &t, &res[i])) < 0)
				fprintf(stderr, "relief bench lod: %s: %s\n", cfg[i].method, strerror(-ret));
		}
	for (int i = 0; i < n && ret == 0; i++) {
		size_t at = (size_t)i * runs * per_run, count = runs * per_run;
		res[i].ms_median = bench_median(ms + at, count);
		res[i].ms_p95 = bench_quantile(ms + at, count, 0.95);
		res[i].select_ms = bench_median(sel + at, count);
		res[i].lod_ms = bench_median(lod + at, count);
	}
	free(ms);
	return ret;
}

/* The configurations in the order they run: the full grid (the reference, first), relief at
 * each tau, the distance baseline at each target, chunked LOD at each tau, then the optional
 * methods. Returns their count (at most MAX_CONFIGS: 8 values each). */
static int configs_fill(struct config *cfg, const double *taus, uint32_t ntau, const double *targets,
                        uint32_t ntarget, bool unculled, bool morphed, bool loose)
{
	int n = 0;
	cfg[n++] = (struct config){
		.method = "full-grid", .opts = { .fine = RELIEF_FINE_FULL, .select_tau = 1e-4 }, .reference = true
	};
	for (uint32_t i = 0; i < ntau; i++)
		cfg[n++] = (struct config){
			.method = "relief", .param = taus[i], .opts = { .fine = RELIEF_FINE_ERRORS, .select_tau = taus[i] }
		};
	for (uint32_t i = 0; i < ntarget; i++)
		cfg[n++] = (struct config){
			.method = "distance", .param = targets[i],
			.opts = { .fine = RELIEF_FINE_DISTANCE, .target_px = (float)targets[i], .select_tau = 1e-4 }
		};
	for (uint32_t i = 0; i < ntau; i++)
		cfg[n++] = (struct config){
			.method = "chunked", .param = taus[i], .opts = { .fine = RELIEF_FINE_FULL, .select_tau = taus[i] }
		};
	for (uint32_t i = 0; i < ntau && unculled; i++) {
		cfg[n++] = (struct config){
			.method = "relief-unculled", .param = taus[i],
			.opts = { .fine = RELIEF_FINE_ERRORS, .select_tau = taus[i], .no_block_cull = true }
		};
		cfg[n++] = (struct config){
			.method = "chunked-unculled", .param = taus[i],
			.opts = { .fine = RELIEF_FINE_FULL, .select_tau = taus[i], .no_block_cull = true }
		};
	}
	for (uint32_t i = 0; i < ntau && morphed; i++)
		cfg[n++] = (struct config){
			.method = "relief-morphed", .param = taus[i],
			.opts = { .fine = RELIEF_FINE_ERRORS, .select_tau = taus[i] }, .morph = true
		};
	for (uint32_t i = 0; i < ntau && loose; i++)
		cfg[n++] = (struct config){
			.method = "relief-loose", .param = taus[i],
			.opts = { .fine = RELIEF_FINE_ERRORS, .select_tau = taus[i] }, .loose = true
		};
	return n;
}

/* The baselines relief's configurations are compared with at equal measured error. */
static const char *const equal_error_baselines[] = { "full-grid", "distance", "chunked" };
#define EQUAL_ERROR_BASELINES (sizeof(equal_error_baselines) / sizeof(*equal_error_baselines))

static bool config_is_relief(const struct config *c)
{
	return strncmp(c->method, "relief", 6) == 0;
}

/* The largest error of result x by the measure: at pixels, or on any triangle (mesh; -1
 * where not measured). */
static double result_err(const struct result *x, bool mesh)
{
	return mesh ? x->mesh_max : x->max_err;
}

/* The configuration of `method` to compare configuration i with at equal or lower error by
 * the measure (bench_match_cheapest()): its index in cfg, or -1. */
static int equal_error_match(const struct config *cfg, const struct result *res, int n, int i, const char *method,
                             bool mesh)
{
	struct bench_point points[MAX_CONFIGS];
	int index[MAX_CONFIGS], m = 0;
	for (int k = 0; k < n; k++)
		if (strcmp(cfg[k].method, method) == 0) {
			points[m] = (struct bench_point){ result_err(&res[k], mesh), res[k].ms_median };
			index[m++] = k;
		}
	int j = bench_match_cheapest(points, m, result_err(&res[i], mesh));
	return j < 0 ? -1 : index[j];
}

/* Configuration i's baselines at equal or lower error, as the JSON array `name`. */
static void equal_error_print_json(const struct config *cfg, const struct result *res, int n, int i, bool mesh,
                                   const char *name)
{
	printf(",\"%s\":[", name);
	bool first = true;
	for (size_t b = 0; b < EQUAL_ERROR_BASELINES; b++) {
		int j = equal_error_match(cfg, res, n, i, equal_error_baselines[b], mesh);
		if (j < 0)
			continue;
		printf("%s{\"baseline\":\"%s\",\"tau_px\":%g,\"%s\":%.4f,\"gpu_ms_median\":%.3f,\"speedup\":%.3f}",
		       first ? "" : ",", cfg[j].method, cfg[j].param, mesh ? "max_err_mesh_px" : "max_err_px",
		       result_err(&res[j], mesh), res[j].ms_median, finite_or(res[j].ms_median / res[i].ms_median));
		first = false;
	}
	printf("]");
}

/* Text output: each relief configuration against each baseline at equal or lower error at
 * pixels. */
static void equal_error_print_text(const struct config *cfg, const struct result *res, int n)
{
	printf("\nAt equal or lower error: each baseline's fastest configuration whose max_err is at most the row's "
	       "(its tau/px, ms_median; speedup: its ms_median over the row's)\n%-16s %7s %10s",
	       "method", "tau/px", "ms_median");
	for (size_t b = 0; b < EQUAL_ERROR_BASELINES; b++)
		printf("   %-24s", equal_error_baselines[b]);
	printf("\n");
	for (int i = 0; i < n; i++) {
		if (!config_is_relief(&cfg[i]))
			continue;
		printf("%-16s %7g %10.2f", cfg[i].method, cfg[i].param, res[i].ms_median);
		for (size_t b = 0; b < EQUAL_ERROR_BASELINES; b++) {
			int j = equal_error_match(cfg, res, n, i, equal_error_baselines[b], false);
			char cell[64] = "-";
			if (j >= 0)
				snprintf(cell, sizeof(cell), "%g: %.2f ms, %.2fx", cfg[j].param, res[j].ms_median,
				         res[j].ms_median / res[i].ms_median);
			printf("   %-24s", cell);
		}
		printf("\n");
	}
}

/* Configuration i's result (of cfg[0 .. n), res[0 .. n)) as a JSON line (fields at the top
 * of the file), of `runs` runs; with `passes`, each LOD pass's median. */
static void result_print_json(const struct run *r, const struct config *cfg, const struct result *results, int n,
                              int i, uint32_t runs, bool passes)
{
	const struct config *c = &cfg[i];
	const struct result *res = &results[i];
	const uint32_t w = r->gpu.target.width, h = r->gpu.target.height;
	printf("{\"method\":\"%s\",\"tau_px\":%g,\"gpu_ms_median\":%.3f,\"gpu_ms_p95\":%.3f,"
	       "\"lod_ms_median\":%.4f,\"select_ms_median\":%.4f,\"triangles\":%.0f,\"quads\":%.0f,"
	       "\"patches\":%.1f,\"max_err_px\":%.4f,\"p999_err_px\":%.2f,\"rms_err_px\":%.4f,\"popping_px\":%.5f,"
	       "\"camera_popping_px\":%.4f,\"popping_pair_median_px\":%.5f,\"popping_pair_max_px\":%.5f,"
	       "\"popping_pairs\":%u,\"popping_events\":%u,\"popping_event_pixels\":%llu,"
	       "\"popping_pixel_max_px\":%.4f,\"popping_excluded_pixels\":%llu,"
	       "\"shade_popping\":%.4f,\"shade_err\":%.3f,\"pixels\":%llu,\"excluded_pixels\":%llu,\"curtain_pixels\":%llu,"
	       "\"frames\":%zu,\"runs\":%u,\"width\":%u,\"height\":%u,\"face_culled_frames\":%u",
	       c->method, c->param, res->ms_median, res->ms_p95, res->lod_ms, res->select_ms,
	       res->triangles, res->quads, res->patches, res->max_err, res->p999_err, res->rms_err,
	       res->popping, res->camera_popping, res->popping_median, res->popping_max, r->frames,
	       res->pop_events, (unsigned long long)res->pop_event_pixels, res->pop_pixel_max,
	       (unsigned long long)res->pop_excluded, res->shade_popping, res->shade_err,
	       (unsigned long long)res->pixels,
	       (unsigned long long)res->excluded, (unsigned long long)res->curtain, 2 * (size_t)r->frames, runs, w, h,
	       res->face_culled);
	if (res->max_err_3x >= 0)
		printf(",\"max_err_3x_px\":%.4f,\"over_tau_pixels\":%llu,\"unresolved_pixels\":%llu,"
		       "\"recheck_diff_px\":%.4f,\"recheck_rms_diff_px\":%.5f",
		       res->max_err_3x, (unsigned long long)res->over_tau,
		       (unsigned long long)res->unresolved, res->recheck_diff, res->recheck_rms);
	if (r->flight_at)
		printf(",\"flight_pairs\":%u,\"lod_change_pairs\":%u,\"sampled_pairs\":%u,\"popping_se_px\":%.5f,"
		       "\"camera_popping_se_px\":%.5f,\"shade_popping_se\":%.5f",
		       r->flight_pairs, res->every[0].events, res->every[0].sampled, finite_or(res->every[0].se),
		       finite_or(res->every[1].se), finite_or(res->every[2].se));
	if (passes) {
		printf(",\"lod_profiled_ms_median\":%.4f,\"lod_pass_ms\":{", res->profiled_lod_ms);
		for (int p = 0; p < RELIEF_LOD_PASSES; p++)
			printf("%s\"%s\":%.4f", p ? "," : "", relief_lod_pass_name(p), res->pass_ms[p]);
		printf("}");
	}
	if (res->pop_quads_measured)
		printf(",\"popping_event_interiors\":%llu,\"popping_event_edges\":%llu,\"popping_event_coarse\":%llu",
		       (unsigned long long)res->pop_quads.interiors, (unsigned long long)res->pop_quads.edges,
		       (unsigned long long)res->pop_quads.coarse);
	if (res->mesh_max >= 0)
		printf(",\"max_err_mesh_px\":%.4f,\"max_err_mesh_transition_px\":%.4f,"
		       "\"max_err_mesh_regular_worse_px\":%.4f,\"transition_triangles\":%.1f,"
		       "\"max_err_mesh_coarse_edge_px\":%.4f,\"max_err_mesh_fine_edge_px\":%.4f,"
		       "\"max_err_mesh_fan_px\":%.4f,\"other_triangles\":%.0f,\"mesh_seams\":%.0f",
		       res->mesh_max, res->mesh_transition, res->mesh_regular_worse, res->transitions,
		       res->mesh_kind[0], res->mesh_kind[1], res->mesh_kind[2], res->mesh_other, res->mesh_seams);
	if (res->mesh_max >= 0) {
		/* per analysed frame, as transition_triangles */
		const struct mesh_cover *m = &res->cover;
		const double frames = 2.0 * r->frames;
		printf(",\"tri_outside\":%.1f,\"tri_eye\":%.1f,\"tri_back\":%.1f,\"tri_no_pixel\":%.1f,"
		       "\"tri_pixels\":%.1f,\"pixels_per_tri\":%.3f",
		       m->kind[MESH_COVER_OUTSIDE] / frames, m->kind[MESH_COVER_EYE] / frames, m->kind[MESH_COVER_BACK] / frames,
		       m->kind[MESH_COVER_EMPTY] / frames, m->kind[MESH_COVER_PIXELS] / frames,
		       m->kind[MESH_COVER_PIXELS] ? (double)m->centres / (double)m->kind[MESH_COVER_PIXELS] : 0.0);
	}
	if (config_is_relief(c)) {
		equal_error_print_json(cfg, results, n, i, false, "at_equal_error");
		if (res->mesh_max >= 0)
			equal_error_print_json(cfg, results, n, i, true, "at_equal_mesh_error");
	}
	bench_json_machine(r->gpu.vk);
}

/* One configuration's result as a row of the text table. */
static void result_print_text(const struct config *c, const struct result *res)
{
	char m3[16] = "-", mm[16] = "-";
	if (res->max_err_3x >= 0)
		snprintf(m3, sizeof(m3), "%.3f", res->max_err_3x);
	if (res->mesh_max >= 0)
		snprintf(mm, sizeof(mm), "%.3f", res->mesh_max);
	printf("%-10s %7g %10.2f %10.2f %9.3f %8.3f %11.0f %8.1f %10.3f %9s %9s %9.2f %10.3f %10.5f %10.4f "
	       "%9llu %8llu\n",
	       c->method, c->param, res->ms_median, res->ms_p95, res->lod_ms, res->select_ms,
	       res->triangles, res->patches, res->max_err, m3, mm, res->p999_err, res->rms_err,
	       res->popping, res->camera_popping, (unsigned long long)res->excluded, (unsigned long long)res->curtain);
}

/* --passes, text output: each configuration's LOD pass medians, their sum, and lod_ms. */
static void passes_print_text(const struct config *cfg, const struct result *res, int n)
{
	printf("\nLOD passes, medians in ms (one more run with a timestamp after each pass; profiled: their sum)\n"
	       "%-16s %7s", "method", "tau/px");
	for (int p = 0; p < RELIEF_LOD_PASSES; p++)
		printf(" %8s", relief_lod_pass_name(p));
	printf(" %9s %8s\n", "profiled", "lod_ms");
	for (int i = 0; i < n; i++) {
		printf("%-16s %7g", cfg[i].method, cfg[i].param);
		for (int p = 0; p < RELIEF_LOD_PASSES; p++)
			printf(" %8.3f", res[i].pass_ms[p]);
		printf(" %9.3f %8.3f\n", res[i].profiled_lod_ms, res[i].lod_ms);
	}
}

int bench_lod(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "json", no_argument, NULL, 'J' }, { "frames", required_argument, NULL, 'n' },
		{ "size", required_argument, NULL, 's' }, { "taus", required_argument, NULL, 'T' },
		{ "targets", required_argument, NULL, 'P' }, { "device", required_argument, NULL, 'd' },
		{ "runs", required_argument, NULL, 'r' }, { "unculled", no_argument, NULL, 'U' },
		{ "morphed", no_argument, NULL, 'M' }, { "recheck-all", no_argument, NULL, 'A' },
		{ "loose", no_argument, NULL, 'L' },  { "trace-events", no_argument, NULL, 'E' },
		{ "every-frame", required_argument, NULL, 'K' }, { "passes", no_argument, NULL, 'S' },
		{ "validation", no_argument, NULL, 'V' },        { "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	bool json = false, unculled = false, morphed = false, recheck_all = false, loose = false, trace = false;
	bool passes = false, validation = false;
	uint32_t frames = 8, w = 480, h = 270, runs = 3, every = 0;
	bool frames_given = false;
	double taus[8] = { 0.5, 1, 2, 4, 8 }, targets[8] = { 0.5, 1, 2, 4, 8 };
	uint32_t ntau = 5, ntarget = 5;
	const char *device = NULL;
	int ch;
	opterr = 0;
	while ((ch = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
		switch (ch) {
		case 'J': json = true; break;
		case 'n':
			if (!cli_parse_u32("bench lod", "--frames", optarg, 1, 1000, &frames))
				return EXIT_USAGE;
			frames_given = true;
			break;
		case 'K':
			if (!cli_parse_u32("bench lod", "--every-frame", optarg, 1, EVERY_FRAME_CAP, &every))
				return EXIT_USAGE;
			break;
		case 'r':
			if (!cli_parse_u32("bench lod", "--runs", optarg, 1, 100, &runs))
				return EXIT_USAGE;
			break;
		case 's':
			if (!cli_parse_size("bench lod", "--size", optarg, &w, &h))
				return EXIT_USAGE;
			break;
		case 'T':
		case 'P':
			if (!cli_parse_list("bench lod", ch == 'T' ? "--taus" : "--targets", optarg, 1e-3, 1e3,
			                    ch == 'T' ? taus : targets, 8, ch == 'T' ? &ntau : &ntarget))
				return EXIT_USAGE;
			break;
		case 'd': device = optarg; break;
		case 'U': unculled = true; break;
		case 'M': morphed = true; break;
		case 'L': loose = true; break;
		case 'A': recheck_all = true; break;
		case 'E': trace = true; break;
		case 'S': passes = true; break;
		case 'V': validation = true; break;
		case 'h':
			printf("usage: relief bench lod FILE.relief [--json] [--frames N] [--runs N] [--size WxH]\n"
			       "                        [--taus a,b,..] [--targets a,b,..] [--unculled] [--morphed]\n"
			       "                        [--loose] [--recheck-all] [--trace-events] [--passes]\n"
			       "                        [--every-frame K] [--device DEV] [--validation]\n"
			       "A fixed flight (default 8 key poses, each with the next frame at 250 m/s and 60 Hz,\n"
			       "480x270) with relief's LOD at each tau (default 0.5,1,2,4,8 px) and the baselines\n"
			       "full-grid, distance (target triangle widths, default 0.5,1,2,4,8 px) and chunked (each\n"
			       "tau): GPU ms per frame (median, p95 over N runs, default 3, taken in turn), triangles,\n"
			       "patches, max and RMS screen-space error against the full-resolution surface, and\n"
			       "popping between each key pose and its next frame: what the change of LOD alone does\n"
			       "(the second camera drawn with both frames' LOD), and cam_pop, the change between the\n"
			       "two pictures, camera motion included. --unculled: relief and chunked also drawn\n"
			       "without culling the blocks the camera cannot see (methods relief-unculled,\n"
			       "chunked-unculled, taken in turn with the rest): what that culling saves.\n"
			       "--morphed: relief also drawn with geomorphing (method relief-morphed, views with\n"
			       "morph set): what morphing costs and what it does to popping.\n"
			       "--loose: relief also drawn with the tessellator's transition strips unbounded\n"
			       "(method relief-loose, views with loose_transitions set): what bounding them costs.\n"
			       "For relief and chunked, each pixel over tau is measured again at three times the\n"
			       "resolution with three times tau (same LOD, same ray): max_3x is the maximum with those\n"
			       "values, which tells the rasteriser's depth at a far sliver from a surface over tau;\n"
			       "--recheck-all rechecks every pixel (a check of the recheck, slow).\n"
			       "mesh_max: every triangle of every frame captured and measured whole against the\n"
			       "finest surface, between pixel centres and behind other triangles too (the JSON also\n"
			       "splits it into the tessellator's transition triangles and the regular ones, and\n"
			       "counts the triangles by where they fall: beyond the frustum, facing away, on no\n"
			       "pixel centre, or on some, with the centres each of those covers).\n"
			       "Popping events (pairs in which some pixel's error changes by over 0.01 px): the\n"
			       "JSON counts the quads whose factors the change of LOD alone changed in them;\n"
			       "--trace-events lists each event's quads on stderr.\n"
			       "--every-frame K: popping over every frame of the flight's line (a tenth of the map):\n"
			       "each method's LOD is chosen for all of them in turn, and the pairs in which some\n"
			       "method's drawn patches change are measured with K more spread evenly; popping is then\n"
			       "each method's mean over all the line's pairs, its events counted once, the rest by the\n"
			       "sample (JSON popping_se_px: that part's standard error). Not with --frames.\n"
			       "--passes: one more run of each configuration with a timestamp after each LOD pass\n"
			       "(not in the times above: on a CPU device each timestamp costs time of its own): the\n"
			       "median of each pass (setup, select, borders, factors, lists) and of their sum.\n"
			       "--validation: the Khronos validation layer on (exit status 1 on any message).\n");
			return 0;
		default: return cli_option_error("bench lod", ch, argv);
		}
	}
	if (every && frames_given) {
		fprintf(stderr, "relief bench lod: --frames and --every-frame exclude each other (the line sets the pairs)\n");
		return EXIT_USAGE;
	}
	if (argc - optind != 1) {
		fprintf(stderr, "relief bench lod: expected one FILE.relief\n");
		return EXIT_USAGE;
	}
	const char *path = argv[optind];
	char err[512];
	struct relief_file *f;
	if (relief_file_open(path, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief bench lod: %s: %s\n", path, err);
		return 1;
	}
	struct run r = { .f = f, .frames = frames, .recheck_all = recheck_all, .trace_events = trace };
	float *drawn = NULL;
	uint8_t *valid = NULL;
	int status = 1, ret;
	struct relief_vk_options vo = { .device = device, .validation = validation, .log = &cli_log, .mesh_capture = true };
	struct relief_patch_cache_options co = { .budget_bytes = 1ull << 30 };
	struct config cfg[MAX_CONFIGS];
	int n = 0;
	uint32_t *flight_at = NULL;
	uint8_t *flight_sampled = NULL;
	relief_level_extent(&f->hdr, f->hdr.levels - 1, &r.fw, &r.fh);
	const size_t samples = (size_t)r.fw * r.fh;
	drawn = malloc(sizeof(float) * samples);
	valid = malloc(samples);
	if (!drawn || !valid || (ret = relief_decode_level_drawn(f, f->hdr.levels - 1, 0, drawn, valid)) < 0) {
		fprintf(stderr, "relief bench lod: %s: cannot decode the finest level\n", path);
		goto out;
	}
	r.drawn = drawn;
	r.valid = valid;
	if ((ret = tool_renderer_init(&r.gpu, &vo, f, &co, w, h)) < 0 ||
	    (ret = relief_vk_target_init(r.gpu.vk, &r.fine, 3 * w, 3 * h)) < 0) {
		fprintf(stderr, "relief bench lod: GPU setup failed: %s\n", strerror(-ret));
		goto out;
	}
	for (uint32_t l = 0; l < f->hdr.levels; l++) {
		for (uint32_t id = relief_level_first_id(l); id < relief_level_first_id(l + 1); id++)
			relief_patch_cache_request(r.gpu.cache, id, 0);
		if ((ret = relief_patch_cache_flush(r.gpu.cache, 1)) < 0) {
			fprintf(stderr, "relief bench lod: the whole terrain does not fit the cache\n");
			goto out;
		}
	}
	r.mesh_cap = relief_terrain_mesh_limit(r.gpu.vk);
	r.mesh_cap = r.mesh_cap < MESH_CAP ? r.mesh_cap : MESH_CAP;
	if (r.gpu.vk->has.mesh_capture && (!(r.mesh = malloc(sizeof(*r.mesh) * 3 * (size_t)r.mesh_cap)) ||
	                                   !(r.mesh_quads = malloc(sizeof(*r.mesh_quads) * (size_t)r.mesh_cap)))) {
		fprintf(stderr, "relief bench lod: out of memory\n");
		goto out;
	}

	n = configs_fill(cfg, taus, ntau, targets, ntarget, unculled, morphed, loose);
	if (every) {
		flight_at = malloc(sizeof(*flight_at) * EVERY_FRAME_CAP);
		flight_sampled = malloc(EVERY_FRAME_CAP);
		if (!flight_at || !flight_sampled) {
			fprintf(stderr, "relief bench lod: out of memory\n");
			goto out;
		}
		if ((ret = every_frame_choose(&r, cfg, n, every, w, h, flight_at, flight_sampled)) < 0) {
			if (ret == -E2BIG)
				fprintf(stderr, "relief bench lod: more than %u pairs to measure: fewer --taus, --targets or "
				                "a smaller --every-frame\n", EVERY_FRAME_CAP);
			else
				fprintf(stderr, "relief bench lod: every frame of the flight: %s\n", strerror(-ret));
			goto out;
		}
		frames = r.frames;
	}
	r.views = calloc(2 * (size_t)frames, sizeof(*r.views));
	r.ref_err = malloc(sizeof(float) * 2 * frames * w * h);
	r.ref_rgba = malloc((size_t)4 * 2 * frames * w * h);
	r.ref_depth = malloc(sizeof(float) * 2 * frames * w * h);
	r.pop_noise = calloc((size_t)frames * w * h, 1);
	if (!r.views || !r.ref_err || !r.ref_rgba || !r.ref_depth || !r.pop_noise) {
		fprintf(stderr, "relief bench lod: out of memory\n");
		goto out;
	}
	const struct relief_view start = bench_flight_view(f, w, h, 1, 0.0);
	if (every)
		for (uint32_t k = 0; k < frames; k++) {
			r.views[2 * k] = bench_flight_frame_view(f, &start, flight_at[k]);
			r.views[2 * k + 1] = bench_flight_frame_view(f, &start, flight_at[k] + 1);
		}
	else
		flight(f, frames, w, h, r.views);
	if (!json) {
		const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
		printf("relief bench lod: %s, flight of %u key poses (%u frames, popping between frames %.1f m apart) "
		       "at %ux%u on %s (%s), cache warm, GPU time from timestamps, %u runs\n", base, frames, 2 * frames,
		       BENCH_FLIGHT_SPEED / BENCH_FRAME_RATE, w, h, r.gpu.vk->props.deviceName,
		       relief_vk_device_type_name(r.gpu.vk->props.deviceType), runs);
		if (every)
			printf("every frame: %u frames, %u pairs measured (every pair some method's drawn patches change in, "
			       "and %u spread evenly); popping and cam_pop: means over the line's %u pairs; times, errors over the "
			       "pairs measured\n",
			       r.flight_pairs + 1, frames, every, r.flight_pairs);
		printf("%-10s %7s %10s %10s %9s %8s %11s %8s %10s %9s %9s %9s %10s %10s %10s %9s %8s\n", "method", "tau/px",
		       "ms_median", "ms_p95", "lod_ms", "sel_ms", "triangles", "patches", "max_err", "max_3x", "mesh_max",
		       "p99.9", "rms_err", "popping", "cam_pop", "excluded", "curtain");
	}
	struct result res[MAX_CONFIGS] = { 0 };
	if ((ret = runs_measure(&r, cfg, n, runs, res)) < 0 || (passes && (ret = measure_passes(&r, cfg, n, res)) < 0))
		goto out;
	for (int i = 0; i < n; i++)
		if (json)
			result_print_json(&r, cfg, res, n, i, runs, passes);
		else
			result_print_text(&cfg[i], &res[i]);
	if (!json)
		equal_error_print_text(cfg, res, n);
	if (passes && !json)
		passes_print_text(cfg, res, n);
	status = 0;
out:
	if (r.gpu.vk && r.gpu.vk->validation && atomic_load(&r.gpu.vk->validation_messages))
		status = 1;
	if (r.gpu.vk)
		relief_vk_target_finish(r.gpu.vk, &r.fine);
	tool_renderer_finish(&r.gpu);
	free(drawn);
	free(valid);
	free(r.mesh);
	free(r.mesh_quads);
	free(r.views);
	free(r.ref_err);
	free(r.ref_rgba);
	free(r.ref_depth);
	free(r.pop_noise);
	free(flight_at);
	free(flight_sampled);
	for (int i = 0; i < n; i++)
		free(cfg[i].changed);
	relief_file_close(f);
	return status;
}
