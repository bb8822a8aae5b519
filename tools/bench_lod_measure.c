/* relief bench lod: one configuration rendered over the flight and measured (bench_lod.h):
 * GPU times, errors against the finest surface (rechecked at three times the resolution
 * over tau, and triangle by triangle where the device captures meshes), popping between a
 * key pose and its next frame. The measures are defined at the top of bench_lod.c. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_flight.h"
#include "bench_lod.h"
#include "bench_util.h"
#include "mesh_diff.h"
#include "mesh_seams.h"
#include "terrain.h"

/* Errors of one rendered frame (depth in the target) against the finest surface: signed
 * per-pixel error in `err` (NaN where there is no terrain or the reference is noise, or
 * where `curtain`, if not NULL, marks a terrain-edge curtain), and the statistics
 * accumulated into `a` and `res`; with a == NULL only `err` is written. Frame f of the
 * run's sequence. */
struct error_stats {
	double worst, sum2;
	uint64_t *hist; /* 0.01 px bins up to 100 px, for the 99.9th percentile */
	/* Rechecks: with bound >= 0 (tau), the frame's pixels over it (every pixel with
	 * --recheck-all) go to over[] (indices, errors in over_px[]) and the rest to worst_ok,
	 * which recheck() then raises by the rechecked values. bound < 0: no rechecks. */
	double bound, worst_ok, recheck_diff, recheck_sum2;
	uint64_t recheck_n;
	uint32_t *over, nover;
	float *over_px;
};
enum { BINS = 10001 };

static void frame_errors(struct run *r, const struct config *c, const struct relief_view *v, uint32_t f, float *err,
                         const uint8_t *curtain, struct error_stats *a, struct result *res)
{
	const uint32_t W = r->gpu.target.width, H = r->gpu.target.height;
	const float *depth = r->gpu.target.depth_readback.map;
	float *ref = r->ref_err + (size_t)f * W * H;
	for (uint32_t y = 0; y < H; y++)
		for (uint32_t x = 0; x < W; x++) {
			size_t k = (size_t)y * W + x;
			err[k] = NAN;
			if (c->reference && a)
				ref[k] = NAN; /* no terrain, unless written below */
			if (!(depth[k] > 0.0f)) /* reversed Z: 0 is the background */
				continue;
			struct relief_vec3 p = relief_view_unproject(v, (int)x, (int)y, depth[k]);
			double mid, dz = relief_surface_vertical_error(r->f, r->drawn, r->valid, r->fw, r->fh, 1, p, &mid);
			double px = relief_view_segment_px(v, p, fabs(dz)), pm = relief_view_segment_px(v, p, fabs(mid));
			if (c->reference) {
				if (a)
					ref[k] = isfinite(px) ? (float)px : NAN;
			} else if (ref[k] > REF_NOISE_PX) {
				if (a)
					res->excluded++;
				continue;
			} else if (curtain && curtain[k]) {
				if (a)
					res->curtain++;
				continue;
			}
			if (!isfinite(px))
				continue;
			/* Popping compares these: against one fixed surface (lod.h). */
			err[k] = isfinite(pm) ? (float)(mid < 0 ? -pm : pm) : NAN;
			if (!a)
				continue;
			a->worst = fmax(a->worst, px);
			if (a->bound >= 0 && (r->recheck_all || px > a->bound)) {
				a->over_px[a->nover] = (float)px;
				a->over[a->nover++] = (uint32_t)k;
			} else
				a->worst_ok = fmax(a->worst_ok, px);
			a->hist[px >= 100.0 ? BINS - 1 : (size_t)(px * 100.0)]++;
			a->sum2 += px * px;
			res->pixels++;
		}
}

/* The pixels of frame i that error_stats.over lists, measured again at three times the
 * resolution (top of the file); `triangles`: the frame's own count (0 where the device has
 * no pipeline statistics: then nothing can be checked and every pixel stays unresolved).
 * The view's hysteresis state is that frame's, and selecting again at the same angular
 * threshold keeps it (idempotent, docs/lod.md "Frozen level of detail"), so the frames
 * that follow are the ones drawn without the recheck. */
static int recheck(struct run *r, const struct config *c, struct relief_terrain_view *tv, const struct relief_view *v,
                   uint32_t i, uint64_t triangles, struct error_stats *a, struct result *res)
{
	const uint32_t W = r->gpu.target.width, W3 = r->fine.width;
	struct relief_view v3 = *v;
	v3.width = W3;
	v3.height = r->fine.height;
	v3.tau *= 3;
	struct relief_draw_options o = c->opts;
	o.select_tau *= 3;
	o.target_px *= 3;
	struct relief_terrain_stats st;
	int ret = relief_terrain_draw(r->gpu.terrain, tv, &v3, &r->fine, 1001 + i, &o, &st);
	if (ret < 0)
		return ret;
	const float *depth = r->fine.depth_readback.map;
	for (uint32_t j = 0; j < a->nover; j++) {
		uint32_t x = a->over[j] % W, y = a->over[j] / W;
		size_t k3 = (size_t)(3 * y + 1) * W3 + 3 * x + 1;
		double px = a->over_px[j], px3 = NAN;
		if (triangles > 0 && st.triangles == triangles && depth[k3] > 0.0f) {
			struct relief_vec3 p = relief_view_unproject(&v3, (int)(3 * x + 1), (int)(3 * y + 1), depth[k3]);
			double dz = relief_surface_vertical_error(r->f, r->drawn, r->valid, r->fw, r->fh, 1, p, NULL);
			px3 = relief_view_segment_px(&v3, p, fabs(dz)) / 3.0;
		}
		if (isfinite(px3)) {
			a->recheck_diff = fmax(a->recheck_diff, fabs(px3 - px));
			a->recheck_sum2 += (px3 - px) * (px3 - px);
			a->recheck_n++;
			px = px3;
		} else
			res->unresolved++;
		a->worst_ok = fmax(a->worst_ok, px);
	}
	res->over_tau += a->nover;
	a->nover = 0;
	return 0;
}

static void mesh_unmeasured(struct result *res)
{
	res->mesh_max = res->mesh_transition = res->mesh_regular_worse = res->transitions = -1;
	res->mesh_kind[0] = res->mesh_kind[1] = res->mesh_kind[2] = res->mesh_other = res->mesh_seams = -1;
}

/* Frame i of the analysed run drawn again (untimed; selecting again for the same camera
 * keeps the LOD, as for recheck()) with its triangles captured and measured whole
 * (relief_mesh_error()): the maxima go to res, which starts at 0 (-1 once a frame did not
 * fit the capture). *captured: the triangles the capture holds (r->mesh, r->mesh_quads). */
static int mesh_measure(struct run *r, const struct config *c, struct relief_terrain_view *tv,
                        const struct relief_view *v, uint32_t i, struct result *res, int64_t *captured)
{
	struct relief_draw_options o = c->opts;
	o.mesh = true;
	struct relief_terrain_stats st;
	int ret = relief_terrain_draw(r->gpu.terrain, tv, v, &r->gpu.target, 1001 + i, &o, &st);
	if (ret < 0)
		return ret;
	int64_t n = relief_terrain_view_mesh(tv, r->mesh, r->mesh_quads, r->mesh_cap);
	if (n < 0)
		return (int)n;
	*captured = n;
	if (n > r->mesh_cap || res->mesh_max < 0) {
		mesh_unmeasured(res);
		return 0;
	}
	struct relief_mesh_error e;
	relief_mesh_error(r->f, v, r->drawn, r->valid, r->fw, r->fh, r->mesh, r->mesh_quads, (uint64_t)n, &e);
	res->mesh_max = fmax(res->mesh_max, e.max_px);
	res->mesh_transition = fmax(res->mesh_transition, e.max_px_transition);
	res->mesh_regular_worse = fmax(res->mesh_regular_worse, e.max_px_regular_worse);
	res->transitions += (double)e.transition / (2.0 * r->frames);
	for (int k = 0; k < 3; k++)
		res->mesh_kind[k] = fmax(res->mesh_kind[k], e.kind_max_px[RELIEF_MESH_COARSE_EDGE + k]);
	res->mesh_other += (double)(e.kind_triangles[RELIEF_MESH_OTHER] + e.kind_triangles[RELIEF_MESH_UNKNOWN]);
	mesh_cover_add(r->f, v, r->mesh, (uint64_t)n, &res->cover);
	struct relief_mesh_seams seams;
	ret = relief_mesh_seams(r->mesh, (uint64_t)n, RELIEF_MESH_SEAM_TOL_M, &seams);
	if (ret < 0)
		return ret;
	res->mesh_seams += (double)(seams.split + seams.junctions);
	return 0;
}

/* A pixel whose signed error changes by more than this between the frozen and the own level
 * of detail counts as changed. The full-resolution render, whose level of detail never
 * changes, moves its pixels by under 0.005 px (drawn from another camera's origin), but for
 * a few single ones on long flights (docs/benchmarks.md, "What an event is"). */
#define POP_EVENT_PX 0.01

/* RMS over pixels showing terrain in both of the change of the signed error; -1 if none.
 * With `changed`, also how many of them changed by more than POP_EVENT_PX, and with
 * `largest` the largest change. */
static double error_change(const float *a, const float *b, size_t n, uint64_t *changed, double *largest)
{
	double sum = 0, most = 0;
	uint64_t count = 0, moved = 0;
	for (size_t k = 0; k < n; k++)
		if (!isnan(a[k]) && !isnan(b[k])) {
			const double d = (double)a[k] - b[k];
			sum += d * d;
			count++;
			moved += fabs(d) > POP_EVENT_PX;
			most = fmax(most, fabs(d));
		}
	if (changed)
		*changed = moved;
	if (largest)
		*largest = most;
	return count ? sqrt(sum / count) : -1;
}

/* RMS over pixels where both depths show terrain of the RGB distance / sqrt(3) between two
 * RGBA8 pictures; -1 if none. */
static double colour_change(const uint8_t *a, const uint8_t *b, const float *da, const float *db, size_t n)
{
	double sum = 0;
	uint64_t count = 0;
	for (size_t k = 0; k < n; k++)
		if (da[k] > 0.0f && db[k] > 0.0f) {
			for (int c = 0; c < 3; c++)
				sum += ((double)a[4 * k + c] - b[4 * k + c]) * ((double)a[4 * k + c] - b[4 * k + c]) / 3.0;
			count++;
		}
	return count ? sqrt(sum / count) : -1;
}

/* The quads of the n triangles a capture drew (r->mesh_quads) into qs, emptied first; *ok
 * false when they were not all kept (a frame over r->mesh_cap triangles). */
static int capture_quads(struct run *r, int64_t n, struct mesh_quads *qs, bool *ok)
{
	mesh_quads_finish(qs);
	*ok = n <= r->mesh_cap;
	return *ok ? mesh_quads_init(qs, r->mesh_quads, (uint64_t)n) : 0;
}

struct relief_view bench_lod_config_view(const struct config *c, const struct relief_view *pose)
{
	struct relief_view v = *pose;
	v.tau = c->param > 0 && c->opts.fine == RELIEF_FINE_ERRORS ? c->param : 1.0;
	v.morph = c->morph;
	v.loose_transitions = c->loose;
	return v;
}

/* What mark_curtains() keeps between frames. */
struct curtain_scratch {
	float *depth;
	uint8_t *rgba, *curtain;
};

/* The pixels of the frame just drawn (frame i, in the target) where a terrain-edge curtain
 * shows: those whose depth changes when the same frame is drawn again without curtains
 * (relief_draw_options.no_skirts; the same level of detail, since selecting again for the
 * same camera keeps it, as for recheck()). A curtain is not the surface, so its pixels say
 * nothing of the surface's error: the ones the reference shows too are left out as its
 * noise, and a frame can show others where the level of detail moves coverage (up to tau
 * past the data's edge, docs/lod.md "No-data") or a silhouette (within tau) in front of a
 * curtain's inner face, 1-3 km below the edge; measured, they read as several tau. The
 * target's depth and colour are put back as the frame drew them. */
static int mark_curtains(struct run *r, const struct config *c, struct relief_terrain_view *tv,
                         const struct relief_view *v, uint32_t i, struct curtain_scratch *s)
{
	const size_t px = (size_t)r->gpu.target.width * r->gpu.target.height;
	float *depth = r->gpu.target.depth_readback.map;
	uint8_t *rgba = r->gpu.target.color_readback.map;
	memcpy(s->depth, depth, sizeof(float) * px);
	memcpy(s->rgba, rgba, 4 * px);
	struct relief_draw_options o = c->opts;
	o.no_skirts = true;
	struct relief_terrain_stats st;
	int ret = relief_terrain_draw(r->gpu.terrain, tv, v, &r->gpu.target, 1001 + i, &o, &st);
	if (ret < 0)
		return ret;
	for (size_t k = 0; k < px; k++)
		s->curtain[k] = depth[k] != s->depth[k];
	memcpy(depth, s->depth, sizeof(float) * px);
	memcpy(rgba, s->rgba, 4 * px);
	return 0;
}

int bench_lod_measure(struct run *r, const struct config *c, bool analyse, const struct frame_times *t,
                      struct result *res)
{
	const uint32_t W = r->gpu.target.width, H = r->gpu.target.height, n = 2 * r->frames;
	float *err = malloc(sizeof(float) * W * H), *prev = malloc(sizeof(float) * W * H);
	float *frozen = malloc(sizeof(float) * W * H), *frozen_depth = malloc(sizeof(float) * W * H);
	uint8_t *frozen_rgba = malloc((size_t)4 * W * H);
	struct curtain_scratch scratch = { malloc(sizeof(float) * W * H), malloc((size_t)4 * W * H),
		                           malloc((size_t)W * H) };
	/* per pair, NaN where not measured (no terrain in view): popping, camera and shade popping */
	double *pair = malloc(sizeof(double) * 3 * (r->frames ? r->frames : 1));
	for (uint32_t k = 0; pair && k < 3 * r->frames; k++)
		pair[k] = NAN;
	/* Methods that bound their error by tau get their pixels over it rechecked. */
	const bool bounded = !c->reference && c->opts.fine != RELIEF_FINE_DISTANCE;
	struct error_stats a = {
		.hist = calloc(BINS, sizeof(uint64_t)),
		.bound = bounded ? c->param : -1,
		.over = malloc(sizeof(uint32_t) * W * H),
		.over_px = malloc(sizeof(float) * W * H),
	};
	struct relief_terrain_view *tv = NULL;
	int ret = err && prev && frozen && frozen_depth && frozen_rgba && pair && a.hist && a.over && a.over_px &&
	                  scratch.depth && scratch.rgba && scratch.curtain
	              ? relief_terrain_view_create(r->gpu.terrain, &tv)
	              : -ENOMEM;
	if (ret == 0 && analyse && r->mesh)
		ret = relief_terrain_view_mesh_enable(tv, r->mesh_cap);
	if (analyse && !r->mesh)
		mesh_unmeasured(res);
	double tri = 0, quads = 0, patches = 0, shade_sum = 0;
	uint32_t shade_frames = 0;
	/* With a mesh capture, the frozen frame's quads, compared with the own frame's in each
	 * popping event (the frozen frame is drawn through the capture's pipelines, which draw
	 * the same picture). */
	struct mesh_quads frozen_quads = { 0 }, own_quads = { 0 };
	bool frozen_captured = false;
	if (analyse)
		res->pop_quads_measured = r->mesh != NULL;
	for (uint32_t i = 0; i < n && ret == 0; i++) {
		struct relief_view view = bench_lod_config_view(c, &r->views[i]), *v = &view;
		struct relief_terrain_stats st;
		/* --every-frame: the line's frames since the last pair, so that the hysteresis is the flight's */
		const uint32_t from = i < 2 || !r->flight_at ? 0 : r->flight_at[i / 2 - 1] + 2;
		if (r->flight_at && i % 2 == 0 && from < r->flight_at[i / 2] &&
		    (ret = bench_flight_replay(r->f, r->gpu.terrain, tv, v, &c->opts, from, r->flight_at[i / 2])) < 0)
			break;
		/* One untimed frame settles the view's hysteresis on the first pose. */
		if (i == 0 && (ret = relief_terrain_draw(r->gpu.terrain, tv, v, &r->gpu.target, 1000, &c->opts, &st)) < 0)
			break;
		if (analyse && i % 2 == 1) {
			/* Untimed: this camera with the previous frame's LOD. The view's selection state
			 * is that frame's, and selecting again for its camera keeps it (hysteresis is
			 * idempotent), so the timed frame below is unchanged. */
			struct relief_view before = bench_lod_config_view(c, &r->views[i - 1]);
			struct relief_draw_options o = c->opts;
			o.lod_view = &before;
			o.mesh = r->mesh != NULL;
			if ((ret = relief_terrain_draw(r->gpu.terrain, tv, v, &r->gpu.target, 1001 + i, &o, &st)) < 0)
				break;
			if (r->mesh) {
				int64_t n_frozen = relief_terrain_view_mesh(tv, r->mesh, r->mesh_quads, r->mesh_cap);
				if ((ret = n_frozen < 0 ? (int)n_frozen : capture_quads(r, n_frozen, &frozen_quads, &frozen_captured)) < 0)
					break;
			}
			frame_errors(r, c, v, i, frozen, NULL, NULL, NULL);
			memcpy(frozen_depth, r->gpu.target.depth_readback.map, sizeof(float) * W * H);
			memcpy(frozen_rgba, r->gpu.target.color_readback.map, (size_t)4 * W * H);
		}
		struct relief_draw_options timed = c->opts;
		timed.pass_timing = t->pass != NULL;
		if ((ret = relief_terrain_draw(r->gpu.terrain, tv, v, &r->gpu.target, 1001 + i, &timed, &st)) < 0)
			break;
		t->ms[i] = st.gpu_ns / 1e6;
		t->sel[i] = st.select_ns / 1e6;
		t->lod[i] = st.lod_ns / 1e6;
		for (int p = 0; t->pass && p < RELIEF_LOD_PASSES; p++)
			t->pass[(size_t)p * n + i] = st.pass_ns[p] / 1e6;
		tri += (double)st.triangles;
		quads += (double)st.quads;
		patches += st.patches;
		if (!analyse)
			continue;
		res->face_culled += st.face_culled;
		if (!c->reference && (ret = mark_curtains(r, c, tv, v, i, &scratch)) < 0)
			break;
		frame_errors(r, c, v, i, err, c->reference ? NULL : scratch.curtain, &a, res);
		if (a.nover && (ret = recheck(r, c, tv, v, i, st.triangles, &a, res)) < 0)
			break;
		uint8_t *ref_rgba = r->ref_rgba + (size_t)i * 4 * W * H;
		float *ref_depth = r->ref_depth + (size_t)i * W * H;
		if (c->reference) {
			memcpy(ref_rgba, r->gpu.target.color_readback.map, (size_t)4 * W * H);
			memcpy(ref_depth, r->gpu.target.depth_readback.map, sizeof(float) * W * H);
		} else {
			double e = colour_change(ref_rgba, r->gpu.target.color_readback.map, ref_depth,
			                         r->gpu.target.depth_readback.map, (size_t)W * H);
			if (e >= 0) {
				shade_sum += e * e;
				shade_frames++;
			}
		}
		uint64_t moved = 0; /* this frame's popping event: pixels changed, the largest change */
		double most = 0;
		if (i % 2 == 1) { /* the frame after a key pose: popping */
			uint8_t *noise = r->pop_noise + (size_t)(i / 2) * W * H;
			for (size_t k = 0; k < (size_t)W * H && !c->reference; k++)
				if (noise[k]) {
					res->pop_excluded += !isnan(frozen[k]) && !isnan(err[k]);
					frozen[k] = NAN;
					frozen_depth[k] = 0.0f;
				}
			double d = error_change(frozen, err, (size_t)W * H, &moved, &most);
			for (size_t k = 0; k < (size_t)W * H && c->reference; k++)
				noise[k] = fabs((double)frozen[k] - err[k]) > POP_EVENT_PX; /* false where either is NaN */
			double dc = error_change(prev, err, (size_t)W * H, NULL, NULL);
			double ds = colour_change(frozen_rgba, r->gpu.target.color_readback.map, frozen_depth,
			                          r->gpu.target.depth_readback.map, (size_t)W * H);
			if (d >= 0 && dc >= 0 && ds >= 0) {
				pair[i / 2] = d;
				pair[r->frames + i / 2] = dc;
				pair[2 * r->frames + i / 2] = ds;
				res->pop_events += moved > 0;
				res->pop_event_pixels += moved;
				res->pop_pixel_max = fmax(res->pop_pixel_max, most);
			} else {
				moved = 0;
			}
		}
		/* Last: it draws the frame again into the target the statistics above read. */
		int64_t captured = 0;
		if (r->mesh && (ret = mesh_measure(r, c, tv, v, i, res, &captured)) < 0)
			break;
		if (r->mesh && moved > 0) { /* an event: which quads changed (mesh_measure() captured them) */
			bool own_captured;
			if ((ret = capture_quads(r, captured, &own_quads, &own_captured)) < 0)
				break;
			res->pop_quads_measured &= frozen_captured && own_captured;
			if (r->trace_events)
				fprintf(stderr, "popping event: %s %g, pair %u, %llu pixels, largest %.3f px; changed quads:\n",
				        c->method, c->param, i / 2, (unsigned long long)moved, most);
			if (frozen_captured && own_captured)
				mesh_quads_compare(&frozen_quads, &own_quads, r->trace_events ? stderr : NULL, &res->pop_quads);
		}
		float *swap = prev;
		prev = err;
		err = swap;
	}
	if (ret == 0) {
		res->triangles = tri / n;
		res->quads = quads / n;
		res->patches = patches / n;
	}
	if (ret == 0 && analyse) {
		res->max_err = a.worst;
		res->max_err_3x = bounded ? a.worst_ok : -1;
		res->recheck_diff = bounded ? a.recheck_diff : -1;
		res->recheck_rms = a.recheck_n ? sqrt(a.recheck_sum2 / a.recheck_n) : 0;
		uint64_t seen = 0;
		for (size_t b = 0; b < BINS; b++) {
			seen += a.hist[b];
			if (seen * 1000 >= res->pixels * 999) {
				res->p999_err = (b + 1) / 100.0;
				break;
			}
		}
		res->rms_err = res->pixels ? sqrt(a.sum2 / res->pixels) : 0;
		res->shade_err = shade_frames ? sqrt(shade_sum / shade_frames) : 0;
		/* The means over the pairs measured; popping, camera and shade popping are NaN
		 * together where a pair was not. */
		double sum[3] = { 0, 0, 0 };
		uint32_t pairs = 0;
		res->popping_max = 0;
		for (uint32_t k = 0; k < r->frames; k++)
			if (!isnan(pair[k])) {
				for (int q = 0; q < 3; q++)
					sum[q] += pair[(size_t)q * r->frames + k];
				res->popping_max = fmax(res->popping_max, pair[k]);
				pairs++;
			}
		res->popping = pairs ? sum[0] / pairs : 0;
		res->camera_popping = pairs ? sum[1] / pairs : 0;
		res->shade_popping = pairs ? sum[2] / pairs : 0;
		if (r->flight_at) { /* over every pair of the line (bench_flight.h) */
			for (int q = 0; q < 3; q++)
				res->every[q] = bench_flight_mean(r->flight_pairs, c->changed, r->flight_at, r->flight_sampled,
				                                 r->frames, pair + (size_t)q * r->frames);
			res->popping = res->every[0].mean;
			res->camera_popping = res->every[1].mean;
			res->shade_popping = res->every[2].mean;
		}
		uint32_t m = 0; /* the pairs measured, first, for the median (which sorts them) */
		for (uint32_t k = 0; k < r->frames; k++)
			if (!isnan(pair[k]))
				pair[m++] = pair[k];
		res->popping_median = m ? bench_median(pair, m) : 0;
	}
	mesh_quads_finish(&frozen_quads);
	mesh_quads_finish(&own_quads);
	relief_terrain_view_destroy(tv);
	free(a.hist);
	free(a.over);
	free(a.over_px);
	free(err);
	free(prev);
	free(frozen);
	free(frozen_depth);
	free(frozen_rgba);
	free(scratch.depth);
	free(scratch.rgba);
	free(scratch.curtain);
	free(pair);
	return ret;
}
