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
 * the control shader ran for (pipeline statistics; 0 where the device has none).
 *
 * Error: at every pixel showing terrain, the vertical distance from the drawn surface to the
 * finest decoded surface, projected to pixels (the quantity tau bounds); max and RMS over all
 * frames. The full-resolution render runs first and is the reference: where it is itself
 * more than REF_NOISE_PX off the surface (a near edge-on triangle at a silhouette, whose
 * depth the rasteriser interpolates badly), the pixel measures the rasteriser, not the LOD,
 * and is left out of every method's statistics; the count is reported.
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
 * and its transitions are of no kind). Absent where not measured.
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
 * compute (selection, draw records, tessellation factors) is lod_ms (JSON lod_ms_median),
 * the coarse part alone (selection and draw records) sel_ms (select_ms_median; until the
 * third session select_ms_median meant all LOD compute). */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "bench_flight.h"
#include "bench_util.h"
#include "cli.h"
#include "decode.h"
#include "format.h"
#include "lod.h"
#include "mesh_diff.h"
#include "patch_cache.h"
#include "renderer.h"
#include "terrain.h"
#include "vk.h"

struct config {
	const char *method;
	double param; /* tau_px, or target_px for distance */
	struct relief_draw_options opts;
	bool reference; /* the full-resolution render: fills run.ref_err */
	bool morph;     /* the views geomorph (relief_view.morph) */
	bool loose;     /* the views' transition strips unbounded (relief_view.loose_transitions) */
	uint8_t *changed; /* --every-frame: per pair of the line, whether this method's drawn patches change */
};

/* The full grid, then up to 8 values each for relief, distance, chunked and the --unculled
 * (two), --morphed and --loose methods. */
#define MAX_CONFIGS (1 + 8 * 7)

struct result {
	double ms_median, ms_p95, select_ms, lod_ms, triangles, quads, patches, max_err, p999_err, rms_err, popping;
	/* --passes: the median of each LOD pass and of their sum over the run with pass timing */
	double pass_ms[RELIEF_LOD_PASSES], profiled_lod_ms;
	double camera_popping;
	double popping_median, popping_max; /* over the pairs: the mean above is made by a few */
	/* The pairs in which some pixel's error changed by more than POP_EVENT_PX (events), the
	 * pixels that did in all of them, and the largest single pixel's change. */
	uint32_t pop_events;
	uint64_t pop_event_pixels;
	uint64_t pop_excluded; /* pixel-pairs left out of popping as the full grid's own changes (run.pop_noise) */
	double pop_pixel_max;
	/* In those events' pairs, the quads whose factors or presence the change of LOD alone
	 * changed (mesh_diff.h); pop_quads_measured false where not measured (no capture). */
	struct mesh_quad_changes pop_quads;
	bool pop_quads_measured;
	double shade_popping;               /* colour change of the LOD change alone, 8-bit steps */
	double shade_err;                   /* colour difference from the full-resolution render */
	double max_err_3x, recheck_diff;    /* rechecked maximum (top of the file), -1 if not rechecked */
	double recheck_rms;                 /* RMS of the changes rechecks made */
	uint64_t pixels, excluded; /* pixel-frames measured, and left out as reference noise */
	uint64_t over_tau, unresolved; /* pixel-frames rechecked, and those a recheck could not resolve */
	uint32_t face_culled;          /* timed frames of the first run drawn with back faces culled */
	/* Triangle by triangle (relief_mesh_error(), over the analysed run's frames): the
	 * largest error, that of transition triangles, that of regular triangles above full
	 * resolution against the worse diagonal; transition triangles per frame; -1 where not
	 * measured (no capture on this device, or a frame drew more than MESH_CAP triangles);
	 * the largest error of the kinds COARSE_EDGE, FINE_EDGE and FAN, and the triangles of
	 * kind OTHER or UNKNOWN over all frames */
	double mesh_max, mesh_transition, mesh_regular_worse, transitions;
	double mesh_kind[3], mesh_other;
	/* --every-frame: popping, camera popping and shade popping over every pair of the line */
	struct bench_flight_mean every[3];
};
/* Triangles one frame's mesh capture holds (64 bytes each on the device, 96 on the CPU). */
#define MESH_CAP (1u << 22)

/* The full-resolution render's own error at a pixel is 0.01 px or less at 99.9 % of pixels;
 * beyond this it is rasterisation noise (see the top of the file). */
#define REF_NOISE_PX 0.1

struct run {
	struct tool_renderer gpu;
	const struct relief_file *f;
	const float *finest;
	uint32_t fw, fh, frames;
	struct relief_view *views;
	/* the mesh capture's triangles (MESH_CAP), or NULL when the device has no capture */
	struct relief_mesh_vertex *mesh;
	struct relief_mesh_quad *mesh_quads;
	/* three times the frame's width and height, for rechecks; recheck_all: every pixel */
	struct relief_vk_target fine;
	bool recheck_all;
	bool trace_events; /* each popping event's changed quads to stderr */
	/* --every-frame: pair i is the line's pair flight_at[i] (frames flight_at[i] and + 1), of
	 * flight_pairs; flight_sampled[i]: in the even sample (bench_flight.h). NULL otherwise. */
	const uint32_t *flight_at;
	const uint8_t *flight_sampled;
	uint32_t flight_pairs;
	/* |error| in px per frame and pixel of the reference render (NaN: no terrain), or NULL
	 * while the reference itself is measured */
	float *ref_err;
	/* per pair and pixel: the full-resolution render's own error changed there by more than
	 * POP_EVENT_PX between the frozen and the own frame (its level of detail never changes:
	 * the rasteriser, drawing from the other camera's origin); left out of every other
	 * method's popping */
	uint8_t *pop_noise;
	/* the reference render's pictures and depths per frame (RGBA8, reversed Z), for
	 * shade_err */
	uint8_t *ref_rgba;
	float *ref_depth;
};

/* Errors of one rendered frame (depth in the target) against the finest surface: signed
 * per-pixel error in `err` (NaN where there is no terrain or the reference is noise), and
 * the statistics accumulated into `a` and `res`; with a == NULL only `err` is written.
 * Frame f of the run's sequence. */
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
                         struct error_stats *a, struct result *res)
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
			double mid, dz = relief_surface_vertical_error(r->f, r->finest, r->fw, r->fh, 1, p, &mid);
			double px = relief_view_segment_px(v, p, fabs(dz)), pm = relief_view_segment_px(v, p, fabs(mid));
			if (c->reference) {
				if (a)
					ref[k] = isfinite(px) ? (float)px : NAN;
			} else if (ref[k] > REF_NOISE_PX) {
				if (a)
					res->excluded++;
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
			double dz = relief_surface_vertical_error(r->f, r->finest, r->fw, r->fh, 1, p, NULL);
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
	res->mesh_kind[0] = res->mesh_kind[1] = res->mesh_kind[2] = res->mesh_other = -1;
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
	int64_t n = relief_terrain_view_mesh(tv, r->mesh, r->mesh_quads, MESH_CAP);
	if (n < 0)
		return (int)n;
	*captured = n;
	if (n > MESH_CAP || res->mesh_max < 0) {
		mesh_unmeasured(res);
		return 0;
	}
	struct relief_mesh_error e;
	relief_mesh_error(r->f, v, r->finest, r->fw, r->fh, r->mesh, r->mesh_quads, (uint64_t)n, &e);
	res->mesh_max = fmax(res->mesh_max, e.max_px);
	res->mesh_transition = fmax(res->mesh_transition, e.max_px_transition);
	res->mesh_regular_worse = fmax(res->mesh_regular_worse, e.max_px_regular_worse);
	res->transitions += (double)e.transition / (2.0 * r->frames);
	for (int k = 0; k < 3; k++)
		res->mesh_kind[k] = fmax(res->mesh_kind[k], e.kind_max_px[RELIEF_MESH_COARSE_EDGE + k]);
	res->mesh_other += (double)(e.kind_triangles[RELIEF_MESH_OTHER] + e.kind_triangles[RELIEF_MESH_UNKNOWN]);
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
 * false when they were not all kept (a frame over MESH_CAP triangles). */
static int capture_quads(struct run *r, int64_t n, struct mesh_quads *qs, bool *ok)
{
	mesh_quads_finish(qs);
	*ok = n <= MESH_CAP;
	return *ok ? mesh_quads_init(qs, r->mesh_quads, (uint64_t)n) : 0;
}

/* Pose `pose` as configuration c draws it: the tessellator's tau, morphing, strips. */
static struct relief_view config_view(const struct config *c, const struct relief_view *pose)
{
	struct relief_view v = *pose;
	v.tau = c->param > 0 && c->opts.fine == RELIEF_FINE_ERRORS ? c->param : 1.0;
	v.morph = c->morph;
	v.loose_transitions = c->loose;
	return v;
}

/* Per frame of one run (2 x run.frames): GPU ms, the LOD compute's and the selection's
 * part of it, and with `pass` non-NULL (the frames then drawn with pass timing) each LOD
 * pass's, pass by pass (pass p of frame i at p x 2 x run.frames + i). */
struct frame_times {
	double *ms, *sel, *lod, *pass;
};

/* Renders the flight once with configuration c; the times of its timed frames go to *t.
 * With `analyse`, also the errors and popping. */
static int measure(struct run *r, const struct config *c, bool analyse, const struct frame_times *t,
                   struct result *res)
{
	const uint32_t W = r->gpu.target.width, H = r->gpu.target.height, n = 2 * r->frames;
	float *err = malloc(sizeof(float) * W * H), *prev = malloc(sizeof(float) * W * H);
	float *frozen = malloc(sizeof(float) * W * H), *frozen_depth = malloc(sizeof(float) * W * H);
	uint8_t *frozen_rgba = malloc((size_t)4 * W * H);
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
	int ret = err && prev && frozen && frozen_depth && frozen_rgba && pair && a.hist && a.over && a.over_px
	              ? relief_terrain_view_create(r->gpu.terrain, &tv)
	              : -ENOMEM;
	if (ret == 0 && analyse && r->mesh)
		ret = relief_terrain_view_mesh_enable(tv, MESH_CAP);
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
		struct relief_view view = config_view(c, &r->views[i]), *v = &view;
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
			struct relief_view before = config_view(c, &r->views[i - 1]);
			struct relief_draw_options o = c->opts;
			o.lod_view = &before;
			o.mesh = r->mesh != NULL;
			if ((ret = relief_terrain_draw(r->gpu.terrain, tv, v, &r->gpu.target, 1001 + i, &o, &st)) < 0)
				break;
			if (r->mesh) {
				int64_t n_frozen = relief_terrain_view_mesh(tv, r->mesh, r->mesh_quads, MESH_CAP);
				if ((ret = n_frozen < 0 ? (int)n_frozen : capture_quads(r, n_frozen, &frozen_quads, &frozen_captured)) < 0)
					break;
			}
			frame_errors(r, c, v, i, frozen, NULL, NULL);
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
		frame_errors(r, c, v, i, err, &a, res);
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
	free(pair);
	return ret;
}

/* --passes: one more run of each configuration, its timed frames drawn with a timestamp
 * after each LOD pass; the medians of each pass and of the LOD compute they make up. */
static int measure_passes(struct run *r, const struct config *cfg, int n, struct result *res)
{
	const size_t frames = 2 * (size_t)r->frames;
	double *ms = malloc(sizeof(double) * frames * (3 + RELIEF_LOD_PASSES));
	int ret = ms ? 0 : -ENOMEM;
	const struct frame_times t = { ms, ms + frames, ms + 2 * frames, ms + 3 * frames };
	for (int i = 0; i < n && ret == 0; i++) {
		if ((ret = measure(r, &cfg[i], false, &t, &res[i])) < 0) {
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
		const struct relief_view like = config_view(&cfg[i], &pose);
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
		{ "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	bool json = false, unculled = false, morphed = false, recheck_all = false, loose = false, trace = false;
	bool passes = false;
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
		case 'h':
			printf("usage: relief bench lod FILE.relief [--json] [--frames N] [--runs N] [--size WxH]\n"
			       "                        [--taus a,b,..] [--targets a,b,..] [--unculled] [--morphed]\n"
			       "                        [--loose] [--recheck-all] [--trace-events] [--passes]\n"
			       "                        [--every-frame K] [--device DEV]\n"
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
			       "splits it into the tessellator's transition triangles and the regular ones).\n"
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
			       "median of each pass (setup, select, records, borders, factors, lists) and of their sum.\n");
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
	float *finest = NULL;
	int status = 1, ret;
	struct relief_vk_options vo = { .device = device, .log = &cli_log, .mesh_capture = true };
	struct relief_patch_cache_options co = { .budget_bytes = 1ull << 30 };
	struct config cfg[MAX_CONFIGS];
	int n = 0;
	uint32_t *flight_at = NULL;
	uint8_t *flight_sampled = NULL;
	relief_level_extent(&f->hdr, f->hdr.levels - 1, &r.fw, &r.fh);
	finest = malloc(sizeof(float) * r.fw * r.fh);
	if (!finest || (ret = relief_decode_level(f, f->hdr.levels - 1, 0, finest, NULL)) < 0) {
		fprintf(stderr, "relief bench lod: %s: cannot decode the finest level\n", path);
		goto out;
	}
	r.finest = finest;
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
	if (r.gpu.vk->has.mesh_capture && (!(r.mesh = malloc(sizeof(*r.mesh) * 3 * (size_t)MESH_CAP)) ||
	                                   !(r.mesh_quads = malloc(sizeof(*r.mesh_quads) * (size_t)MESH_CAP)))) {
		fprintf(stderr, "relief bench lod: out of memory\n");
		goto out;
	}

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
		printf("%-10s %7s %10s %10s %9s %8s %11s %8s %10s %9s %9s %9s %10s %10s %10s %9s\n", "method", "tau/px",
		       "ms_median", "ms_p95", "lod_ms", "sel_ms", "triangles", "patches", "max_err", "max_3x", "mesh_max",
		       "p99.9", "rms_err", "popping", "cam_pop", "excluded");
	}
	/* Runs go round the configurations, so that a slow spell of the machine spreads over
	 * all of them; errors are measured on the first run (they do not change). */
	const size_t per_run = 2 * (size_t)frames;
	struct result res[MAX_CONFIGS] = { 0 };
	const size_t total = (size_t)n * runs * per_run;
	double *ms = calloc(3 * total, sizeof(double));
	if (!ms) {
		fprintf(stderr, "relief bench lod: out of memory\n");
		goto out;
	}
	double *sel = ms + total, *lod = sel + total;
	ret = 0;
	for (uint32_t run = 0; run < runs && ret == 0; run++)
		for (int i = 0; i < n && ret == 0; i++) {
			size_t at = ((size_t)i * runs + run) * per_run;
			const struct frame_times t = { ms + at, sel + at, lod + at, NULL };
			if ((ret = measure(&r, &cfg[i], run == 0, &t, &res[i])) < 0)
				fprintf(stderr, "relief bench lod: %s: %s\n", cfg[i].method, strerror(-ret));
		}
	if (ret == 0 && passes)
		ret = measure_passes(&r, cfg, n, res);
	if (ret < 0) {
		free(ms);
		goto out;
	}
	for (int i = 0; i < n; i++) {
		size_t at = (size_t)i * runs * per_run, count = runs * per_run;
		double *m = ms + at;
		res[i].ms_median = bench_median(m, count);
		res[i].ms_p95 = bench_quantile(m, count, 0.95);
		res[i].select_ms = bench_median(sel + at, count);
		res[i].lod_ms = bench_median(lod + at, count);
		if (json) {
			printf("{\"method\":\"%s\",\"tau_px\":%g,\"gpu_ms_median\":%.3f,\"gpu_ms_p95\":%.3f,"
			       "\"lod_ms_median\":%.4f,\"select_ms_median\":%.4f,\"triangles\":%.0f,\"quads\":%.0f,"
			       "\"patches\":%.1f,\"max_err_px\":%.4f,\"p999_err_px\":%.2f,\"rms_err_px\":%.4f,\"popping_px\":%.5f,"
			       "\"camera_popping_px\":%.4f,\"popping_pair_median_px\":%.5f,\"popping_pair_max_px\":%.5f,"
			       "\"popping_pairs\":%u,\"popping_events\":%u,\"popping_event_pixels\":%llu,"
			       "\"popping_pixel_max_px\":%.4f,\"popping_excluded_pixels\":%llu,"
			       "\"shade_popping\":%.4f,\"shade_err\":%.3f,\"pixels\":%llu,\"excluded_pixels\":%llu,"
			       "\"frames\":%zu,\"runs\":%u,\"width\":%u,\"height\":%u,\"face_culled_frames\":%u",
			       cfg[i].method, cfg[i].param, res[i].ms_median, res[i].ms_p95, res[i].lod_ms, res[i].select_ms,
			       res[i].triangles, res[i].quads, res[i].patches, res[i].max_err, res[i].p999_err, res[i].rms_err,
			       res[i].popping, res[i].camera_popping, res[i].popping_median, res[i].popping_max, frames,
			       res[i].pop_events, (unsigned long long)res[i].pop_event_pixels, res[i].pop_pixel_max,
			       (unsigned long long)res[i].pop_excluded, res[i].shade_popping, res[i].shade_err,
			       (unsigned long long)res[i].pixels,
			       (unsigned long long)res[i].excluded, per_run, runs, w, h, res[i].face_culled);
			if (res[i].max_err_3x >= 0)
				printf(",\"max_err_3x_px\":%.4f,\"over_tau_pixels\":%llu,\"unresolved_pixels\":%llu,"
				       "\"recheck_diff_px\":%.4f,\"recheck_rms_diff_px\":%.5f",
				       res[i].max_err_3x, (unsigned long long)res[i].over_tau,
				       (unsigned long long)res[i].unresolved, res[i].recheck_diff, res[i].recheck_rms);
			if (r.flight_at)
				printf(",\"flight_pairs\":%u,\"lod_change_pairs\":%u,\"sampled_pairs\":%u,\"popping_se_px\":%.5f,"
				       "\"camera_popping_se_px\":%.5f,\"shade_popping_se\":%.5f",
				       r.flight_pairs, res[i].every[0].events, res[i].every[0].sampled, finite_or(res[i].every[0].se),
				       finite_or(res[i].every[1].se), finite_or(res[i].every[2].se));
			if (passes) {
				printf(",\"lod_profiled_ms_median\":%.4f,\"lod_pass_ms\":{", res[i].profiled_lod_ms);
				for (int p = 0; p < RELIEF_LOD_PASSES; p++)
					printf("%s\"%s\":%.4f", p ? "," : "", relief_lod_pass_name(p), res[i].pass_ms[p]);
				printf("}");
			}
			if (res[i].pop_quads_measured)
				printf(",\"popping_event_interiors\":%llu,\"popping_event_edges\":%llu,\"popping_event_coarse\":%llu",
				       (unsigned long long)res[i].pop_quads.interiors, (unsigned long long)res[i].pop_quads.edges,
				       (unsigned long long)res[i].pop_quads.coarse);
			if (res[i].mesh_max >= 0)
				printf(",\"max_err_mesh_px\":%.4f,\"max_err_mesh_transition_px\":%.4f,"
				       "\"max_err_mesh_regular_worse_px\":%.4f,\"transition_triangles\":%.1f",
				       res[i].mesh_max, res[i].mesh_transition, res[i].mesh_regular_worse, res[i].transitions);
			if (res[i].mesh_max >= 0)
				printf(",\"max_err_mesh_coarse_edge_px\":%.4f,\"max_err_mesh_fine_edge_px\":%.4f,"
				       "\"max_err_mesh_fan_px\":%.4f,\"other_triangles\":%.0f",
				       res[i].mesh_kind[0], res[i].mesh_kind[1], res[i].mesh_kind[2], res[i].mesh_other);
			bench_json_machine(r.gpu.vk->props.deviceName);
		} else {
			char m3[16] = "-", mm[16] = "-";
			if (res[i].max_err_3x >= 0)
				snprintf(m3, sizeof(m3), "%.3f", res[i].max_err_3x);
			if (res[i].mesh_max >= 0)
				snprintf(mm, sizeof(mm), "%.3f", res[i].mesh_max);
			printf("%-10s %7g %10.2f %10.2f %9.3f %8.3f %11.0f %8.1f %10.3f %9s %9s %9.2f %10.3f %10.5f %10.4f "
			       "%9llu\n",
			       cfg[i].method, cfg[i].param, res[i].ms_median, res[i].ms_p95, res[i].lod_ms, res[i].select_ms,
			       res[i].triangles, res[i].patches, res[i].max_err, m3, mm, res[i].p999_err, res[i].rms_err,
			       res[i].popping, res[i].camera_popping, (unsigned long long)res[i].excluded);
		}
	}
	if (passes && !json) {
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
	free(ms);
	status = 0;
out:
	if (r.gpu.vk)
		relief_vk_target_finish(r.gpu.vk, &r.fine);
	tool_renderer_finish(&r.gpu);
	free(finest);
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
