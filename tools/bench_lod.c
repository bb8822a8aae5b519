/* relief bench lod FILE.relief: what accuracy costs in time. A fixed flight over the terrain
 * is rendered with relief's LOD at several tau, and in the same run with three baselines:
 *   full-grid   the finest patches at full tessellation (no LOD at all);
 *   distance    the finest patches, tessellated from the projected edge length alone
 *               (Cantlay / Sascha Willems style, no error metric), target_px per triangle;
 *   chunked     the same quadtree selection with tau, patches at full resolution
 *               (no fine tessellation LOD).
 * The cache is warm (every patch resident), so frames measure LOD, not streaming.
 *
 * Error: at every pixel showing terrain, the vertical distance from the drawn surface to the
 * finest decoded surface, projected to pixels (the quantity tau bounds); max and RMS over all
 * frames. The full-resolution render runs first and is the reference: where it is itself
 * more than REF_NOISE_PX off the surface (a near edge-on triangle at a silhouette, whose
 * depth the rasteriser interpolates badly), the pixel measures the rasteriser, not the LOD,
 * and is left out of every method's statistics; the count is reported. Popping: the RMS over pixels of the change of that (signed) error between
 * consecutive frames, averaged over the frame pairs (the DSS paper's measure, per pixel).
 * GPU time: timestamps around selection, drawing and copy-out, per frame; median and p95. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "bench_util.h"
#include "cli.h"
#include "decode.h"
#include "format.h"
#include "lod.h"
#include "patch_cache.h"
#include "terrain.h"
#include "vk.h"

struct config {
	const char *method;
	double param; /* tau_px, or target_px for distance */
	struct relief_draw_options opts;
	bool reference; /* the full-resolution render: fills run.ref_err */
};

struct result {
	double ms_median, ms_p95, select_ms, triangles, patches, max_err, p999_err, rms_err, popping;
	uint64_t pixels, excluded; /* pixel-frames measured, and left out as reference noise */
};

/* The full-resolution render's own error at a pixel is 0.01 px or less at 99.9 % of pixels;
 * beyond this it is rasterisation noise (see the top of the file). */
#define REF_NOISE_PX 0.1

struct run {
	struct relief_vk *vk;
	const struct relief_file *f;
	struct relief_patch_cache *cache;
	struct relief_vk_target target;
	struct relief_terrain *terrain;
	const float *finest;
	uint32_t fw, fh, frames;
	struct relief_view *views;
	/* |error| in px per frame and pixel of the reference render (NaN: no terrain), or NULL
	 * while the reference itself is measured */
	float *ref_err;
};

static double parse_list(const char *s, double *out, int cap, int *n)
{
	char buf[256];
	snprintf(buf, sizeof(buf), "%s", s);
	*n = 0;
	char *save = NULL;
	for (char *t = strtok_r(buf, ",", &save); t && *n < cap; t = strtok_r(NULL, ",", &save)) {
		char *end;
		out[*n] = strtod(t, &end);
		if (*end || !(out[*n] > 0) || !isfinite(out[*n]))
			return -1;
		(*n)++;
	}
	return *n > 0 ? 0 : -1;
}

static int measure(struct run *r, const struct config *c, struct result *res)
{
	const uint32_t W = r->target.width, H = r->target.height;
	double *ms = calloc(r->frames, sizeof(double)), *sel = calloc(r->frames, sizeof(double));
	float *err = malloc(sizeof(float) * W * H), *prev = malloc(sizeof(float) * W * H);
	struct relief_terrain_view *tv = NULL;
	int ret = ms && sel && err && prev ? relief_terrain_view_create(r->terrain, &tv) : -ENOMEM;
	double tri = 0, patches = 0, worst = 0, sum2 = 0, pop = 0;
	/* Histogram of per-pixel errors for the 99.9th percentile, 0.01 px bins up to 100 px. */
	enum { BINS = 10001 };
	uint64_t *hist = calloc(BINS, sizeof(uint64_t));
	if (!hist)
		ret = -ENOMEM;
	uint32_t pairs = 0;
	for (uint32_t i = 0; i < r->frames && ret == 0; i++) {
		struct relief_view view = r->views[i], *v = &view;
		view.tau = c->param > 0 && c->opts.fine == RELIEF_FINE_ERRORS ? c->param : 1.0; /* the tessellator's tau */
		struct relief_terrain_stats st;
		/* One untimed frame settles the view's hysteresis on the first pose. */
		if (i == 0 && (ret = relief_terrain_draw(r->terrain, tv, v, &r->target, 1000, &c->opts, &st)) < 0)
			break;
		if ((ret = relief_terrain_draw(r->terrain, tv, v, &r->target, 1001 + i, &c->opts, &st)) < 0)
			break;
		ms[i] = st.gpu_ns / 1e6;
		sel[i] = st.select_ns / 1e6;
		tri += (double)st.triangles;
		patches += st.patches;
		const float *depth = r->target.depth_readback.map;
		double dsum = 0;
		uint64_t dn = 0;
		const float *ref = c->reference ? NULL : r->ref_err + (size_t)i * W * H;
		for (uint32_t y = 0; y < H; y++)
			for (uint32_t x = 0; x < W; x++) {
				size_t k = (size_t)y * W + x;
				float e = NAN;
				if (depth[k] > 0.0f) { /* reversed Z: 0 is the background */
					struct relief_vec3 p = relief_view_unproject(v, (int)x, (int)y, depth[k]);
					double dz = relief_surface_vertical_error(r->f, r->finest, r->fw, r->fh, 1, p);
					double px = relief_view_segment_px(v, p, fabs(dz));
					if (c->reference)
						r->ref_err[i * (size_t)W * H + k] = isfinite(px) ? (float)px : NAN;
					if (ref && ref[k] > REF_NOISE_PX) {
						res->excluded++;
					} else if (isfinite(px)) {
						e = (float)(dz < 0 ? -px : px);
						worst = fmax(worst, px);
						hist[px >= 100.0 ? BINS - 1 : (size_t)(px * 100.0)]++;
						sum2 += px * px;
						res->pixels++;
					}
				}
				if (i > 0 && !isnan(e) && !isnan(prev[k])) {
					dsum += ((double)e - prev[k]) * ((double)e - prev[k]);
					dn++;
				}
				err[k] = e;
			}
		if (i > 0 && dn) {
			pop += sqrt(dsum / dn);
			pairs++;
		}
		float *t = prev;
		prev = err;
		err = t;
	}
	if (ret == 0) {
		res->ms_median = bench_median(ms, r->frames);
		res->ms_p95 = ms[(size_t)ceil(0.95 * r->frames) - 1]; /* sorted by bench_median */
		res->select_ms = bench_median(sel, r->frames);
		res->triangles = tri / r->frames;
		res->patches = patches / r->frames;
		res->max_err = worst;
		uint64_t seen = 0;
		for (size_t b = 0; b < BINS; b++) {
			seen += hist[b];
			if (seen * 1000 >= res->pixels * 999) {
				res->p999_err = (b + 1) / 100.0;
				break;
			}
		}
		res->rms_err = res->pixels ? sqrt(sum2 / res->pixels) : 0;
		res->popping = pairs ? pop / pairs : 0;
	}
	relief_terrain_view_destroy(tv);
	free(hist);
	free(ms);
	free(sel);
	free(err);
	free(prev);
	return ret;
}

/* A straight, low flight across the terrain's middle, looking ahead and down. It starts a
 * fraction of a sample off the patch grid: a camera exactly in the plane of a patch border
 * sees that border's skirt edge-on, and the resulting sliver triangles can put single
 * pixels at a wrong depth (docs/lod.md, known issues). */
static void flight(const struct relief_file *f, uint32_t frames, uint32_t w, uint32_t h, struct relief_view *views)
{
	const struct relief_header *hd = &f->hdr;
	double ex = hd->spacing_x * (hd->width - 1), ey = hd->spacing_y * (hd->height - 1);
	double x0 = hd->origin_x + 0.30 * ex + 0.37 * hd->spacing_x, y0 = hd->origin_y - 0.70 * ey + 0.61 * hd->spacing_y;
	double dx = 0.10 * ex / frames, dy = 0.10 * ey / frames; /* north-east, a tenth of the map */
	double z = hd->height_min + 0.8 * (hd->height_max - hd->height_min) + 100.0;
	double reach = sqrt(ex * ex + ey * ey) + 10 * (hd->height_max - hd->height_min);
	for (uint32_t i = 0; i < frames; i++) {
		double x = x0 + dx * i, y = y0 + dy * i;
		views[i] = (struct relief_view){
			.eye = { x, y, z },
			.target = { x + 0.2 * ex, y + 0.2 * ey, z - 0.06 * sqrt(ex * ex + ey * ey) },
			.fovy = 55.0 * M_PI / 180.0, .width = w, .height = h,
			.znear = 1.0, .zfar = 2 * reach, .tau = 1.0, /* reversed Z keeps depth precise far away */
		};
	}
}

int bench_lod(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "json", no_argument, NULL, 'J' }, { "frames", required_argument, NULL, 'n' },
		{ "size", required_argument, NULL, 's' }, { "taus", required_argument, NULL, 'T' },
		{ "targets", required_argument, NULL, 'P' }, { "device", required_argument, NULL, 'd' },
		{ "help", no_argument, NULL, 'h' }, { 0 },
	};
	bool json = false;
	uint32_t frames = 8, w = 480, h = 270;
	double taus[8] = { 0.5, 1, 2, 4, 8 }, targets[8] = { 0.5, 1, 2, 4, 8 };
	int ntau = 5, ntarget = 5;
	const char *device = NULL;
	int ch;
	opterr = 0;
	while ((ch = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
		switch (ch) {
		case 'J': json = true; break;
		case 'n':
			if (!cli_parse_u32("bench lod", "--frames", optarg, 2, 1000, &frames))
				return EXIT_USAGE;
			break;
		case 's':
			if (!cli_parse_size("bench lod", "--size", optarg, &w, &h))
				return EXIT_USAGE;
			break;
		case 'T':
		case 'P':
			if (parse_list(optarg, ch == 'T' ? taus : targets, 8, ch == 'T' ? &ntau : &ntarget) < 0) {
				fprintf(stderr, "relief bench lod: %s: up to 8 positive numbers, comma-separated\n",
				        ch == 'T' ? "--taus" : "--targets");
				return EXIT_USAGE;
			}
			break;
		case 'd': device = optarg; break;
		case 'h':
			printf("usage: relief bench lod FILE.relief [--json] [--frames N] [--size WxH] [--taus a,b,..]\n"
			       "                        [--targets a,b,..] [--device DEV]\n"
			       "A fixed flight (default 8 frames at 480x270) with relief's LOD at each tau (default\n"
			       "0.5,1,2,4,8 px) and the baselines full-grid, distance (target triangle widths, default\n"
			       "0.5,1,2,4,8 px) and chunked (each tau): GPU ms per frame (median, p95), triangles,\n"
			       "patches, max and RMS screen-space error against the full-resolution surface, popping.\n");
			return 0;
		default: return cli_option_error("bench lod", ch, argv);
		}
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
	struct run r = { .f = f, .frames = frames };
	float *finest = NULL;
	int status = 1, ret;
	struct relief_vk_options vo = { .device = device, .log = &cli_log };
	struct relief_patch_cache_options co = { .budget_bytes = 1ull << 30 };
	r.views = calloc(frames, sizeof(*r.views));
	r.ref_err = malloc(sizeof(float) * frames * w * h);
	for (size_t k = 0; r.ref_err && k < (size_t)frames * w * h; k++)
		r.ref_err[k] = NAN;
	relief_level_extent(&f->hdr, f->hdr.levels - 1, &r.fw, &r.fh);
	finest = malloc(sizeof(float) * r.fw * r.fh);
	if (!r.views || !r.ref_err || !finest || (ret = relief_decode_level(f, f->hdr.levels - 1, 0, finest, NULL)) < 0) {
		fprintf(stderr, "relief bench lod: %s: cannot decode the finest level\n", path);
		goto out;
	}
	r.finest = finest;
	if ((ret = relief_vk_create(&vo, &r.vk)) < 0 || (ret = relief_vk_target_init(r.vk, &r.target, w, h)) < 0 ||
	    (ret = relief_patch_cache_create(r.vk, f, &co, &cli_log, &r.cache)) < 0 ||
	    (ret = relief_terrain_create(r.vk, f, r.cache, &r.target, &r.terrain)) < 0) {
		fprintf(stderr, "relief bench lod: GPU setup failed: %s\n", strerror(-ret));
		goto out;
	}
	for (uint32_t l = 0; l < f->hdr.levels; l++) {
		for (uint32_t id = relief_level_first_id(l); id < relief_level_first_id(l + 1); id++)
			relief_patch_cache_request(r.cache, id, 0);
		if ((ret = relief_patch_cache_flush(r.cache, 1)) < 0) {
			fprintf(stderr, "relief bench lod: the whole terrain does not fit the cache\n");
			goto out;
		}
	}
	flight(f, frames, w, h, r.views);

	struct config cfg[1 + 8 * 3];
	int n = 0;
	cfg[n++] = (struct config){ "full-grid", 0, { .fine = RELIEF_FINE_FULL, .select_tau = 1e-4 }, .reference = true };
	for (int i = 0; i < ntau; i++)
		cfg[n++] = (struct config){ "relief", taus[i], { .fine = RELIEF_FINE_ERRORS, .select_tau = taus[i] }, false };
	for (int i = 0; i < ntarget; i++)
		cfg[n++] = (struct config){ "distance", targets[i],
		                            { .fine = RELIEF_FINE_DISTANCE, .target_px = (float)targets[i], .select_tau = 1e-4 }, false };
	for (int i = 0; i < ntau; i++)
		cfg[n++] = (struct config){ "chunked", taus[i], { .fine = RELIEF_FINE_FULL, .select_tau = taus[i] }, false };
	if (!json) {
		const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
		printf("relief bench lod: %s, flight of %u frames at %ux%u on %s (%s), cache warm, GPU time from "
		       "timestamps\n", base, frames, w, h, r.vk->props.deviceName,
		       relief_vk_device_type_name(r.vk->props.deviceType));
		printf("%-10s %7s %10s %10s %9s %11s %8s %10s %9s %10s %10s %9s\n", "method", "tau/px", "ms_median", "ms_p95",
		       "select_ms", "triangles", "patches", "max_err", "p99.9", "rms_err", "popping", "excluded");
	}
	for (int i = 0; i < n; i++) {
		struct result res = { 0 };
		if ((ret = measure(&r, &cfg[i], &res)) < 0) {
			fprintf(stderr, "relief bench lod: %s: %s\n", cfg[i].method, strerror(-ret));
			goto out;
		}
		if (json)
			printf("{\"method\":\"%s\",\"tau_px\":%g,\"gpu_ms_median\":%.3f,\"gpu_ms_p95\":%.3f,"
			       "\"select_ms_median\":%.4f,\"triangles\":%.0f,\"patches\":%.1f,\"max_err_px\":%.4f,\"p999_err_px\":%.2f,"
			       "\"rms_err_px\":%.4f,\"popping_px\":%.4f,\"pixels\":%llu,\"excluded_pixels\":%llu,\"frames\":%u,\"width\":%u,\"height\":%u,"
			       "\"device\":\"%s\"}\n",
			       cfg[i].method, cfg[i].param, res.ms_median, res.ms_p95, res.select_ms, res.triangles,
			       res.patches, res.max_err, res.p999_err, res.rms_err, res.popping, (unsigned long long)res.pixels,
			       (unsigned long long)res.excluded, frames, w, h, r.vk->props.deviceName);
		else
			printf("%-10s %7g %10.2f %10.2f %9.3f %11.0f %8.1f %10.3f %9.2f %10.3f %10.3f %9llu\n", cfg[i].method,
			       cfg[i].param, res.ms_median, res.ms_p95, res.select_ms, res.triangles, res.patches, res.max_err,
			       res.p999_err, res.rms_err, res.popping, (unsigned long long)res.excluded);
		fflush(stdout);
	}
	status = 0;
out:
	relief_terrain_destroy(r.terrain);
	relief_patch_cache_destroy(r.cache);
	if (r.vk)
		relief_vk_target_finish(r.vk, &r.target);
	relief_vk_destroy(r.vk);
	free(finest);
	free(r.views);
	free(r.ref_err);
	relief_file_close(f);
	return status;
}
