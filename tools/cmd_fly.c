/* relief fly FILE.relief [--track FILE] ...: an image generator's loop, in-process. A camera
 * (or several side by side: channels) flies along a track through one patch cache that
 * starts cold. Each frame takes only what the decoder has finished
 * (relief_patch_cache_update() never waits) and draws at once; where a patch is still on
 * its way, its resident parent is drawn. Reports what frames cost and how often, and for
 * how long, they showed less detail than the view asked for. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "cli.h"
#include "format.h"
#include "lod.h"
#include "patch_cache.h"
#include "renderer.h"
#include "terrain.h"
#include "track.h"
#include "vk.h"

#define MAX_CHANNELS 8
#define MAX_FRAMES 1000000u

static void fly_usage(FILE *f)
{
	fprintf(f,
		"usage: relief fly FILE.relief [options]\n"
		"Flies a camera along a track through a cold GPU patch cache: every frame draws at once\n"
		"with what is resident (a missing patch's parent stands in) and the frames are reported.\n"
		"  --track FILE       keys 't x y z heading pitch roll' (seconds, world metres, degrees;\n"
		"                     heading clockwise from north, pitch up, roll right bank), one per\n"
		"                     line, '#' comments; default: 20 s straight and low across the middle\n"
		"  --seconds S        fly this long from the track's start (default: the whole track)\n"
		"  --fps HZ           simulation frame rate (default 60)\n"
		"  --channels N       N views side by side, each a field of view wide, 1-%d (default 1)\n"
		"  --size WxH         per channel (default 640x360)\n"
		"  --fov DEG          vertical field of view (default 50)\n"
		"  --tau PX           screen-space error threshold in pixels (default 1)\n"
		"  --morph            geomorph changes of level (a blend, not a pop; finer levels: more triangles)\n"
		"  --budget MIB       GPU memory for the patch cache (default 256)\n"
		"  --workers N        entropy-decoding threads (default 1)\n"
		"  --out DIR          write every frame: DIR/frame-NNNNN[-cK].png\n"
		"  --json             one JSON record instead of the text summary\n"
		"      --device DEV   Vulkan device: name substring, deviceUUID or render node\n"
		"      --validation   enable the Khronos validation layer\n",
		MAX_CHANNELS);
}

/* 20 s at 250 m/s, north-east across the middle, looking ahead and down (the flight of
 * relief bench lod, flown continuously). */
static int default_track(const struct relief_header *h, struct track *t)
{
	double ex = h->spacing_x * (h->width - 1), ey = h->spacing_y * (h->height - 1);
	double x0 = h->origin_x + 0.30 * ex, y0 = h->origin_y - 0.70 * ey;
	double heading = atan2(ex, ey), z = h->height_min + 0.8 * (h->height_max - h->height_min) + 100.0;
	const double speed = 250.0, seconds = 20.0, pitch = -16.7;
	t->keys = malloc(2 * sizeof(*t->keys));
	if (!t->keys)
		return -ENOMEM;
	t->n = 2;
	t->keys[0] = (struct track_key){ 0, x0, y0, z, heading * 180.0 / M_PI, pitch, 0 };
	t->keys[1] = (struct track_key){ seconds, x0 + speed * seconds * sin(heading), y0 + speed * seconds * cos(heading),
	                                 z, heading * 180.0 / M_PI, pitch, 0 };
	return 0;
}

struct fly_stats {
	double *wall_ms, *update_ms, *gpu_ms, *busy_ms, *triangles;
	uint32_t incomplete, first_complete, last_incomplete;
	double first_complete_ms; /* wall time from the first frame's start to the end of that frame */
	uint32_t last_levels[RELIEF_MAX_LEVELS]; /* patches drawn per level in the last frame, all channels */
};

/* Adds the levels of the patches view tv drew in its last frame to levels[]. */
static int count_levels(const struct relief_file *f, struct relief_terrain_view *tv, uint32_t *levels)
{
	uint32_t *ids = malloc(sizeof(uint32_t) * f->hdr.index_records); /* drawn patches have entries */
	if (!ids)
		return -ENOMEM;
	int n = relief_terrain_view_drawn(tv, ids, f->hdr.index_records);
	for (int k = 0; k < n; k++) {
		uint32_t l, px, py;
		if (relief_patch_coords(&f->layout, ids[k], &l, &px, &py))
			levels[l]++;
	}
	free(ids);
	return n < 0 ? n : 0;
}

int cmd_fly(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "track", required_argument, NULL, 'T' },   { "seconds", required_argument, NULL, 'S' },
		{ "fps", required_argument, NULL, 'F' },     { "channels", required_argument, NULL, 'C' },
		{ "size", required_argument, NULL, 's' },    { "fov", required_argument, NULL, 'f' },
		{ "tau", required_argument, NULL, 't' },     { "budget", required_argument, NULL, 'b' },
		{ "workers", required_argument, NULL, 'w' }, { "out", required_argument, NULL, 'o' },
		{ "json", no_argument, NULL, 'J' },          { "device", required_argument, NULL, 'd' },
		{ "validation", no_argument, NULL, 'V' },    { "help", no_argument, NULL, 'h' },
		{ "morph", no_argument, NULL, 'M' },         { 0 },
	};
	const char *track_path = NULL, *out_dir = NULL, *device = NULL;
	double seconds = -1, fps = 60, fov = 50, tau = 1;
	uint32_t channels = 1, width = 640, height = 360, budget = 256, workers = 1;
	bool json = false, validation = false, morph = false;
	int c;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
		switch (c) {
		case 'T': track_path = optarg; break;
		case 'S':
			if (!cli_parse_double("fly", "--seconds", optarg, &seconds))
				return EXIT_USAGE;
			break;
		case 'F':
			if (!cli_parse_double("fly", "--fps", optarg, &fps))
				return EXIT_USAGE;
			break;
		case 'C':
			if (!cli_parse_u32("fly", "--channels", optarg, 1, MAX_CHANNELS, &channels))
				return EXIT_USAGE;
			break;
		case 's':
			if (!cli_parse_size("fly", "--size", optarg, &width, &height))
				return EXIT_USAGE;
			break;
		case 'f':
			if (!cli_parse_double("fly", "--fov", optarg, &fov))
				return EXIT_USAGE;
			break;
		case 't':
			if (!cli_parse_double("fly", "--tau", optarg, &tau))
				return EXIT_USAGE;
			break;
		case 'b':
			if (!cli_parse_u32("fly", "--budget", optarg, 1, 1048576, &budget))
				return EXIT_USAGE;
			break;
		case 'w':
			if (!cli_parse_u32("fly", "--workers", optarg, 1, RELIEF_PATCH_CACHE_MAX_WORKERS, &workers))
				return EXIT_USAGE;
			break;
		case 'o': out_dir = optarg; break;
		case 'J': json = true; break;
		case 'M': morph = true; break;
		case 'd': device = optarg; break;
		case 'V': validation = true; break;
		case 'h': fly_usage(stdout); return 0;
		default: return cli_option_error("fly", c, argv);
		}
	}
	if (argc - optind != 1) {
		fprintf(stderr, "relief fly: expected one FILE.relief (see 'relief fly --help')\n");
		return EXIT_USAGE;
	}
	if (!(fps >= 1 && fps <= 1000)) {
		fprintf(stderr, "relief fly: --fps: %g is not within [1, 1000] frames per second\n", fps);
		return EXIT_USAGE;
	}
	if (seconds != -1 && !(seconds >= 0)) {
		fprintf(stderr, "relief fly: --seconds: %g is negative\n", seconds);
		return EXIT_USAGE;
	}
	const char *path = argv[optind];
	char err[512];
	struct track track = { 0 };
	if (track_path && track_load(track_path, &track, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief fly: %s: %s\n", track_path, err);
		return EXIT_USAGE;
	}
	struct relief_file *f;
	if (relief_file_open(path, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief fly: %s: %s\n", path, err);
		track_finish(&track);
		return 1;
	}
	const struct relief_header *h = &f->hdr;
	int status = 1, ret = 0;
	if (!track_path && (ret = default_track(h, &track)) < 0) {
		fprintf(stderr, "relief fly: %s\n", strerror(-ret));
		relief_file_close(f);
		return 1;
	}
	double t0 = track.keys[0].t, length = track.keys[track.n - 1].t - t0;
	if (seconds < 0 || seconds > length)
		seconds = length;
	double nf = floor(seconds * fps) + 1;
	if (nf > MAX_FRAMES) {
		fprintf(stderr, "relief fly: %.0f frames; at most %u (shorten --seconds or lower --fps)\n", nf, MAX_FRAMES);
		track_finish(&track);
		relief_file_close(f);
		return EXIT_USAGE;
	}
	const uint32_t frames = (uint32_t)nf;
	/* Far plane beyond the whole terrain seen from anywhere on the track: the distance to the
	 * terrain's centre is convex along each straight segment, so the keys bound it. */
	double ex = h->spacing_x * (h->width - 1), ey = h->spacing_y * (h->height - 1), ez = h->height_max - h->height_min;
	double cx = h->origin_x + 0.5 * ex, cy = h->origin_y - 0.5 * ey, cz = 0.5 * (h->height_min + h->height_max);
	double reach = sqrt(ex * ex + ey * ey + ez * ez), farthest = 0;
	for (size_t i = 0; i < track.n; i++) {
		const struct track_key *q = &track.keys[i];
		farthest = fmax(farthest, sqrt((q->x - cx) * (q->x - cx) + (q->y - cy) * (q->y - cy) + (q->z - cz) * (q->z - cz)));
	}
	struct relief_view base = {
		.fovy = fov * M_PI / 180.0, .width = width, .height = height, .tau = tau, .morph = morph,
	};
	/* Check the camera parameters once, on the first pose, before any GPU work. */
	struct track_key k;
	track_at(&track, t0, &k);
	track_key_view(&k, &base);
	base.znear = 1.0;
	base.zfar = 2.0 * (farthest + reach) + 1000.0; /* reversed Z keeps depth precise far away */
	const char *why;
	if (relief_view_check(&base, &why) < 0) {
		fprintf(stderr, "relief fly: bad camera: %s\n", why);
		track_finish(&track);
		relief_file_close(f);
		return EXIT_USAGE;
	}
	const double hfov = 2.0 * atan(tan(0.5 * base.fovy) * width / height);

	struct relief_vk_options vo = { .device = device, .validation = validation, .log = &cli_log };
	struct tool_renderer g = { 0 };
	struct relief_terrain_view *tv[MAX_CHANNELS] = { 0 };
	/* Channel 0 draws into the renderer's target, the others into their own, so that every
	 * channel's frame is in flight at once (relief_terrain_draw_submit()). */
	struct relief_vk_target extra[MAX_CHANNELS - 1] = { 0 };
	struct relief_vk_target *target[MAX_CHANNELS] = { 0 };
	struct relief_patch_cache_options co = { .budget_bytes = (uint64_t)budget << 20, .workers = workers };
	struct fly_stats s = {
		.wall_ms = malloc(sizeof(double) * frames), .update_ms = malloc(sizeof(double) * frames),
		.gpu_ms = malloc(sizeof(double) * frames),
		.busy_ms = malloc(sizeof(double) * frames), .triangles = malloc(sizeof(double) * frames),
		.first_complete = UINT32_MAX, .last_incomplete = UINT32_MAX, .first_complete_ms = -1,
	};
	char *png = out_dir ? malloc(strlen(out_dir) + 64) : NULL;
	if (!s.wall_ms || !s.update_ms || !s.gpu_ms || !s.busy_ms || !s.triangles || (out_dir && !png)) {
		fprintf(stderr, "relief fly: out of memory\n");
		goto out;
	}
	if ((ret = tool_renderer_init(&g, &vo, f, &co, width, height)) < 0) {
		fprintf(stderr, "relief fly: GPU setup failed: %s\n", strerror(-ret));
		goto out;
	}
	for (uint32_t ch = 0; ch < channels; ch++) {
		target[ch] = ch ? &extra[ch - 1] : &g.target;
		if ((ch && (ret = relief_vk_target_init(g.vk, target[ch], width, height)) < 0) ||
		    (ret = relief_terrain_view_create(g.terrain, &tv[ch])) < 0) {
			fprintf(stderr, "relief fly: GPU setup failed: %s\n", strerror(-ret));
			goto out;
		}
	}
	double start = 0, png_total = 0; /* wall clock of the first frame; time spent writing PNGs */
	uint32_t culled_draws = 0;      /* draws with back faces culled (relief_terrain_stats.face_culled) */
	for (uint32_t i = 0; i < frames; i++) {
		uint64_t frame = i + 1;
		track_at(&track, t0 + i / fps, &k);
		struct relief_view centre = base;
		track_key_view(&k, &centre);
		double w0 = bench_now(), png_s = 0;
		if (i == 0)
			start = w0;
		if ((ret = relief_patch_cache_update(g.cache, frame)) < 0) {
			fprintf(stderr, "relief fly: frame %u: patch cache: %s\n", i, strerror(-ret));
			goto out;
		}
		double w1 = bench_now(), gpu = 0, tri = 0;
		uint32_t requests = 0;
		for (uint32_t ch = 0; ch < channels; ch++) {
			struct relief_view v;
			track_channel_view(&centre, (ch - 0.5 * (channels - 1)) * hfov, &v);
			if ((ret = relief_terrain_draw_submit(g.terrain, tv[ch], &v, target[ch], frame, NULL)) < 0) {
				fprintf(stderr, "relief fly: frame %u, channel %u: drawing failed: %s\n", i, ch, strerror(-ret));
				goto out;
			}
		}
		for (uint32_t ch = 0; ch < channels; ch++) {
			struct relief_terrain_stats st;
			if ((ret = relief_terrain_view_wait(g.terrain, tv[ch], &st)) < 0) {
				fprintf(stderr, "relief fly: frame %u, channel %u: drawing failed: %s\n", i, ch, strerror(-ret));
				goto out;
			}
			gpu += st.gpu_ns / 1e6;
			tri += (double)st.triangles;
			culled_draws += st.face_culled;
			if (i + 1 == frames && (ret = count_levels(f, tv[ch], s.last_levels)) < 0) {
				fprintf(stderr, "relief fly: %s\n", strerror(-ret));
				goto out;
			}
			requests += st.requests;
			if (out_dir) {
				double p0 = bench_now();
				sprintf(png, channels > 1 ? "%s/frame-%05u-c%u.png" : "%s/frame-%05u.png", out_dir, i, ch);
				if ((ret = cli_make_parent_dir(png)) < 0 ||
				    (ret = png_write_rgba(png, target[ch]->color_readback.map, width, height)) < 0) {
					fprintf(stderr, "relief fly: cannot write %s: %s\n", png, strerror(-ret));
					goto out;
				}
				png_s += bench_now() - p0;
			}
		}
		s.wall_ms[i] = (bench_now() - w0 - png_s) * 1e3;
		s.update_ms[i] = (w1 - w0) * 1e3;
		/* The round's span on the device (the channels' sum counts overlapping work twice on
		 * a GPU); no timestamps on this queue: 0, as the channels' own times, and the
		 * summary says the times are missing. */
		uint64_t span_ns = 0;
		if ((ret = relief_terrain_views_span_ns(g.terrain, tv, channels, &span_ns)) < 0 && ret != -ENODATA) {
			fprintf(stderr, "relief fly: frame %u: %s\n", i, strerror(-ret));
			goto out;
		}
		s.gpu_ms[i] = span_ns / 1e6;
		s.busy_ms[i] = gpu;
		s.triangles[i] = tri;
		if (requests) {
			s.incomplete++;
			s.last_incomplete = i;
		} else if (s.first_complete == UINT32_MAX) {
			s.first_complete = i;
			s.first_complete_ms = (bench_now() - start - png_total - png_s) * 1e3;
		}
		png_total += png_s;
	}
	struct relief_patch_cache_stats cs;
	relief_patch_cache_stats(g.cache, &cs);
	uint64_t view_bytes = 0;
	for (uint32_t ch = 0; ch < channels; ch++)
		view_bytes += relief_terrain_view_bytes(tv[ch]);
	double wall_med = bench_median(s.wall_ms, frames), wall_p95 = bench_quantile(s.wall_ms, frames, 0.95);
	double wall_max = s.wall_ms[frames - 1];
	double upd_med = bench_median(s.update_ms, frames), upd_max = s.update_ms[frames - 1];
	double gpu_med = bench_median(s.gpu_ms, frames), gpu_p95 = bench_quantile(s.gpu_ms, frames, 0.95);
	double busy_med = bench_median(s.busy_ms, frames);
	double tri_med = bench_median(s.triangles, frames);
	/* A device without pipeline statistics counts no triangles: said so, not printed as 0. */
	char tri_json[32] = "null", tri_text[64] = CLI_TRIANGLES_UNCOUNTED;
	if (g.vk->has.pipeline_statistics) {
		snprintf(tri_json, sizeof(tri_json), "%.0f", tri_med);
		snprintf(tri_text, sizeof(tri_text), "triangles median %.0f", tri_med);
	}
	/* Likewise GPU times on a queue without timestamps. */
	char gpu_json[96] = "\"gpu_ms_median\":null,\"gpu_ms_p95\":null,\"gpu_busy_ms_median\":null";
	char gpu_text[160] = CLI_GPU_UNTIMED;
	if (g.vk->timestamp_valid_bits) {
		snprintf(gpu_json, sizeof(gpu_json), "\"gpu_ms_median\":%.3f,\"gpu_ms_p95\":%.3f,\"gpu_busy_ms_median\":%.3f",
		         gpu_med, gpu_p95, busy_med);
		int len = snprintf(gpu_text, sizeof(gpu_text), "GPU ms per frame   median %.2f  p95 %.2f", gpu_med, gpu_p95);
		if (channels > 1)
			snprintf(gpu_text + len, sizeof(gpu_text) - (size_t)len,
			         " (first channel's start to last one's end; the channels' own times add up to %.2f)",
			         busy_med);
	}
	long first = s.first_complete == UINT32_MAX ? -1 : (long)s.first_complete;
	long last = s.last_incomplete == UINT32_MAX ? -1 : (long)s.last_incomplete;
	if (json) {
		printf("{\"file\":");
		cli_json_string(stdout, path);
		printf(",\"frames\":%u,\"channels\":%u,\"width\":%u,\"height\":%u,\"tau_px\":%g,\"fps\":%g,\"seconds\":%g,"
		       "\"wall_ms_median\":%.3f,\"wall_ms_p95\":%.3f,\"wall_ms_max\":%.3f,\"update_ms_median\":%.4f,"
		       "\"update_ms_max\":%.4f,%s,"
		       "\"triangles_median\":%s,"
		       "\"frames_incomplete\":%u,\"first_complete_frame\":%ld,\"first_complete_ms\":%.1f,"
		       "\"last_incomplete_frame\":%ld,"
		       "\"decoded\":%llu,\"evicted\":%llu,\"bad\":%llu,\"layers_used\":%u,\"layers\":%u,\"budget_mib\":%u,"
		       "\"workers\":%u,\"morph\":%s,\"face_culled_draws\":%u,\"pool_bytes\":%llu,\"table_bytes\":%llu,"
		       "\"terrain_bytes\":%llu,\"view_bytes\":%llu",
		       frames, channels, width, height, tau, fps, seconds, wall_med, wall_p95, wall_max, upd_med, upd_max,
		       gpu_json, tri_json, s.incomplete, first, s.first_complete_ms, last, (unsigned long long)cs.decoded,
		       (unsigned long long)cs.evicted, (unsigned long long)cs.bad, cs.used, cs.layers, budget, workers,
		       morph ? "true" : "false", culled_draws, (unsigned long long)cs.bytes, (unsigned long long)cs.table_bytes,
		       (unsigned long long)relief_terrain_bytes(g.terrain), (unsigned long long)view_bytes);
		printf(",\"patches_by_level_last_frame\":[");
		for (uint32_t l = 0; l < f->hdr.levels; l++)
			printf("%s%u", l ? "," : "", s.last_levels[l]);
		printf("]");
		bench_json_machine(g.vk);
	} else {
		printf("relief fly: %s, %u frames of %u channel(s) at %ux%u, tau %g px%s, %.2f s of track at %g Hz, on %s\n",
		       path, frames, channels, width, height, tau, morph ? " morphed" : "", seconds, fps,
		       g.vk->props.deviceName);
		printf("  frame wall ms      median %.2f  p95 %.2f  max %.2f (drawing %u channel(s) and waiting for them)\n",
		       wall_med, wall_p95, wall_max, channels);
		printf("  cache update ms    median %.3f  max %.3f (never waits for a decode)\n", upd_med, upd_max);
		printf("  %s; %s; back faces culled in %u of %u draws (camera above the surface)\n", gpu_text, tri_text,
		       culled_draws, frames * channels);
		printf("  detail             %u of %u frames drew a parent for a missing patch; ", s.incomplete, frames);
		if (first < 0)
			printf("no frame complete (the budget or the track's length), ");
		else
			printf("first complete frame %ld (%.0f ms of wall time from the start), ", first, s.first_complete_ms);
		if (last < 0)
			printf("none incomplete\n");
		else
			printf("last incomplete %ld\n", last);
		printf("  cache              %llu patches decoded, %llu evicted, %llu bad; %u of %u layers used (%u MiB budget, "
		       "%u worker(s))\n", (unsigned long long)cs.decoded, (unsigned long long)cs.evicted,
		       (unsigned long long)cs.bad, cs.used, cs.layers, budget, workers);
		printf("  GPU buffers        pools %.1f MiB (within the budget), tables %.1f KiB, terrain %.1f KiB, %u view(s) "
		       "%.1f KiB (per-patch ones sized by %u index entries)\n", cs.bytes / 1048576.0, cs.table_bytes / 1024.0,
		       relief_terrain_bytes(g.terrain) / 1024.0, channels, view_bytes / 1024.0, f->hdr.index_records);
		printf("  last frame         patches drawn per level 0..%u:", f->hdr.levels - 1);
		for (uint32_t l = 0; l < f->hdr.levels; l++)
			printf(" %u", s.last_levels[l]);
		printf("\n");
	}
	status = g.vk->validation && atomic_load(&g.vk->validation_messages) ? 1 : 0;
out:
	for (uint32_t ch = 0; ch < channels; ch++) {
		relief_terrain_view_destroy(tv[ch]); /* waits for a frame still in flight */
		if (ch && g.vk)
			relief_vk_target_finish(g.vk, target[ch]);
	}
	tool_renderer_finish(&g);
	free(png);
	free(s.wall_ms);
	free(s.update_ms);
	free(s.gpu_ms);
	free(s.busy_ms);
	free(s.triangles);
	track_finish(&track);
	relief_file_close(f);
	return status;
}
