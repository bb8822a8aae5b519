/* relief bench decode FILE.relief: GPU decoding through the patch cache against the CPU
 * reference decoder, on the same patches, in one run.
 *
 * Samples are decoded patch samples (P^2 per non-empty patch, every level). Timings are
 * medians over --runs runs:
 *   cpu_ref   one thread: fetch, entropy-decode and reconstruct every patch (tree walk);
 *   entropy   one thread: fetch and entropy-decode only (the CPU share of the GPU path);
 *   normals   one thread: the packed normal maps of every decoded patch (common/normals.c);
 *   strips    one thread: their transition strip bounds (common/strip_bound.c): with
 *             normals, what a CPU decoder would add to fill the pool the renderer reads
 *             (ratio_same_outputs: cpu_ref + normals + strips over gpu);
 *   gpu       wall time from the first request to the last patch resident in the cache:
 *             the worker thread entropy-decodes while the GPU reconstructs, in batches;
 *             gpu_busy_ms is the GPU's own time from timestamps at each batch's start and
 *             end, as a streaming cache takes them;
 *   passes    the same GPU path again with timestamps between the passes too
 *             (relief_patch_cache_options.pass_timing; lavapipe flushes at each, so these
 *             runs are slower and kept apart): its busy time (gpu_profiled_busy_ms) split
 *             into the decode pass (with the block error copies), the normals pass and the
 *             transition strip bounds' pass;
 *   alone     the GPU path with every patch's symbols ready first (device_alone_run()):
 *             the device's own work with the worker idle (on a CPU device the two
 *             otherwise share the cores), and the reference over it; its passes split
 *             by as many runs again with the pass timestamps; and the process's CPU time
 *             over it (every thread), which, with the entropy stage's time, bounds the
 *             ratio on a CPU device: the path cannot take less wall time than the two
 *             spread evenly over the cores (ratio_bound_cores). */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench.h"
#include "bench_util.h"
#include "cli.h"
#include "decode.h"
#include "format.h"
#include "normals.h"
#include "parallel.h"
#include "patch_cache.h"
#include "strip_bound.h"
#include "vk.h"

static int gpu_run(struct relief_vk *vk, struct relief_file *f, uint32_t workers, bool pass_timing, double *wall,
                   struct relief_patch_cache_stats *st)
{
	struct relief_patch_cache_options o = { .budget_bytes = 1ull << 30, .workers = workers, .pass_timing = pass_timing };
	struct relief_patch_cache *c;
	int ret = relief_patch_cache_create(vk, f, &o, &cli_log, &c);
	if (ret < 0)
		return ret;
	/* Every patch at once, coarse first (a child is accepted while its parent is on its
	 * way): the worker decodes deeper levels while the device reconstructs shallower ones. */
	double t = bench_now();
	for (uint32_t e = 0; e < f->hdr.index_records && ret >= 0; e++) { /* id order; the rest are EMPTY */
		const uint32_t id = relief_index_patch(&f->hdr, e);
		int r = relief_patch_cache_request(c, id, (float)id);
		if (r < 0 && r != -ENOENT && r != -EIO)
			ret = r;
	}
	if (ret >= 0)
		ret = relief_patch_cache_flush(c, 1);
	*wall = bench_now() - t;
	relief_patch_cache_stats(c, st);
	relief_patch_cache_destroy(c);
	return ret < 0 ? ret : 0;
}

/* Waits until at least n patches' symbols are ready in cache c (entropy-decoded, not yet in
 * a batch), polling every millisecond: 0, or -ETIMEDOUT after 10 s (a stuck worker). */
static int wait_for_symbols(struct relief_patch_cache *c, uint32_t n)
{
	for (int ms = 0;; ms++) {
		struct relief_patch_cache_stats s;
		relief_patch_cache_stats(c, &s);
		if (s.waiting >= n)
			return 0;
		if (ms == 10000)
			return -ETIMEDOUT;
		nanosleep(&(struct timespec){ 0, 1000000 }, NULL);
	}
}

/* The device alone: every patch's symbols ready before the first batch, so the worker is
 * idle while the device works. On a CPU device (lavapipe) the two otherwise share the
 * cores, and this is what the device's own work costs without the worker beside it; on a
 * GPU it is the reconstruction's latency with nothing to wait for. Patches go in chunks of
 * at most ALONE_CHUNK staging slots, in id order (coarse first: a chunk's parents are
 * resident), each chunk's entropy stage finished before its batches are timed; *wall sums
 * the chunks' flushes, and st gets the cache's stats (gpu_ns: the device's busy time over
 * every chunk), *cpu the process's CPU time over the timed flushes (every thread: on a CPU
 * device the driver's threads doing the device's work, with the cache's own recording and
 * waiting; the workers are idle then). The chunks bound the staging memory the run holds
 * at once. */
#define ALONE_CHUNK 64u

static int device_alone_run(struct relief_vk *vk, struct relief_file *f, uint32_t patches, uint32_t workers,
                            bool pass_timing, double *wall, double *cpu, struct relief_patch_cache_stats *st)
{
	const uint32_t slots = patches < ALONE_CHUNK ? patches : ALONE_CHUNK;
	struct relief_patch_cache_options o = { .budget_bytes = 1ull << 30, .staging_slots = slots ? slots : 1,
		                                .workers = workers, .pass_timing = pass_timing };
	struct relief_patch_cache *c;
	int ret = relief_patch_cache_create(vk, f, &o, &cli_log, &c);
	if (ret < 0)
		return ret;
	*wall = *cpu = 0;
	uint32_t e = 0;
	while (ret >= 0 && e < f->hdr.index_records) {
		uint32_t asked = 0;
		for (; e < f->hdr.index_records && asked < slots && ret >= 0; e++) {
			const uint32_t id = relief_index_patch(&f->hdr, e);
			int r = relief_patch_cache_request(c, id, (float)id);
			if (r == 0)
				asked++;
			else if (r != -ENOENT && r != -EIO && r != -EAGAIN)
				ret = r; /* EAGAIN: its parent is no longer on its way (evicted, or dropped after
				          * a bad ancestor), and was asked for instead */
		}
		if (ret >= 0)
			ret = wait_for_symbols(c, asked); /* the chunk's entropy stage, untimed */
		double t = bench_now(), u = bench_cpu_time();
		if (ret >= 0)
			ret = relief_patch_cache_flush(c, 1);
		*wall += bench_now() - t;
		*cpu += bench_cpu_time() - u;
	}
	relief_patch_cache_stats(c, st);
	relief_patch_cache_destroy(c);
	return ret < 0 ? ret : 0;
}

/* What a CPU decoder would also pay to fill the pool the renderer reads, for every decoded
 * patch: the packed normal map (common/normals.c, the normals pass's twin) with its
 * validity from the patch's mask, and the transition strip bounds (common/strip_bound.c,
 * the strips pass's twin), each timed apart. The blocks are decoded first, untimed, and
 * come in entry order (relief_decode_level_blocks()): a level's index window may be
 * smaller than its grid of patches. The block errors and ranges are stored in the file and
 * copied on either path; uploads are not counted. */
static int cpu_outputs_run(const struct relief_file *f, double *normals_secs, double *strips_secs)
{
	const struct relief_layout *lay = &f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E;
	const size_t ne = relief_block_errors_per_patch(P);
	uint8_t *mask = malloc((size_t)P * P);
	uint32_t *out = malloc(sizeof(uint32_t) * P * P);
	float *eps = malloc(sizeof(float) * ne);
	float *strips = malloc(sizeof(float) * (size_t)lay->blocks * lay->blocks * 4 * RELIEF_STRIP_FLOATS);
	int ret = mask && out && eps && strips ? 0 : -ENOMEM;
	*normals_secs = *strips_secs = 0;
	for (uint32_t l = 0; l < lay->levels && ret == 0; l++) {
		int32_t *blocks;
		if ((ret = relief_decode_level_blocks(f, l, 1, &blocks)) < 0)
			break;
		const float q2 = (float)(2.0 * lay->delta[l]);
		for (uint32_t i = 0; i < f->hdr.index_cols[l] * f->hdr.index_rows[l] && ret == 0; i++) {
			const uint32_t id = relief_index_patch(&f->hdr, f->hdr.index_first[l] + i);
			const int32_t *block = blocks + (size_t)i * E * E;
			struct relief_patch_record r;
			relief_file_record(f, id, &r);
			if (r.flags & RELIEF_PATCH_EMPTY)
				continue;
			double t = bench_now();
			if ((ret = relief_file_mask(f, id, mask)) < 0)
				break;
			relief_normals_pack(f, l, block, mask, out);
			*normals_secs += bench_now() - t;
			relief_file_block_errors(f, id, eps);
			t = bench_now();
			ret = relief_strip_bounds(block, P, q2, eps, l + 1 == lay->levels, relief_file_measured_draw_error(f, &r),
			                          strips);
			*strips_secs += bench_now() - t;
		}
		free(blocks);
	}
	free(mask);
	free(out);
	free(eps);
	free(strips);
	return ret;
}

/* Descent latency: the chain from the root to a finest-level patch (the one nearest the
 * centre that is not empty) requested at once, every stream entropy-decoded first; then
 * one update per "frame", the device idle between them, until the finest patch is
 * resident. Counts the updates (a batch's patches become resident at the update after
 * it completes). */
static int descent_run(struct relief_vk *vk, struct relief_file *f, uint32_t *updates)
{
	const uint32_t levels = f->hdr.levels, side = 1u << (levels - 1);
	uint32_t target = UINT32_MAX;
	uint64_t best = UINT64_MAX;
	for (uint32_t y = 0; y < side; y++)
		for (uint32_t x = 0; x < side; x++) {
			struct relief_patch_record rec;
			uint32_t id = relief_patch_id(levels - 1, x, y);
			relief_file_record(f, id, &rec);
			int64_t dx = 2 * (int64_t)x + 1 - side, dy = 2 * (int64_t)y + 1 - side;
			if (!(rec.flags & RELIEF_PATCH_EMPTY) && (uint64_t)(dx * dx + dy * dy) < best) {
				best = (uint64_t)(dx * dx + dy * dy);
				target = id;
			}
		}
	if (target == UINT32_MAX)
		return -ENOENT;
	struct relief_patch_cache_options o = { .budget_bytes = 64ull << 20 };
	struct relief_patch_cache *c;
	int ret = relief_patch_cache_create(vk, f, &o, &cli_log, &c);
	if (ret < 0)
		return ret;
	uint32_t l, px, py;
	relief_patch_coords(&f->layout, target, &l, &px, &py);
	for (uint32_t k = 0; k < levels && ret >= 0; k++)
		ret = relief_patch_cache_request(c, relief_patch_id(k, px >> (l - k), py >> (l - k)), (float)k);
	if (ret >= 0)
		(void)wait_for_symbols(c, levels); /* on a timeout the updates below time out too */
	*updates = 0;
	while (ret >= 0 && relief_patch_cache_state(c, target) != RELIEF_PATCH_RESIDENT) {
		if (++*updates > 4 * levels) {
			ret = -ETIMEDOUT;
			break;
		}
		ret = relief_patch_cache_update(c, *updates);
		vkDeviceWaitIdle(vk->device);
	}
	relief_patch_cache_destroy(c);
	return ret < 0 ? ret : 0;
}

int bench_decode(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "json", no_argument, NULL, 'J' },
		{ "runs", required_argument, NULL, 'n' },
		{ "device", required_argument, NULL, 'd' },
		{ "workers", required_argument, NULL, 'w' },
		{ "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	bool json = false;
	uint32_t runs = 3, workers = 1;
	const char *device = NULL;
	int ch;
	opterr = 0;
	while ((ch = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
		switch (ch) {
		case 'J': json = true; break;
		case 'n':
			if (!cli_parse_u32("bench decode", "--runs", optarg, 1, 15, &runs))
				return EXIT_USAGE;
			break;
		case 'd': device = optarg; break;
		case 'w':
			if (!cli_parse_u32("bench decode", "--workers", optarg, 1, RELIEF_PATCH_CACHE_MAX_WORKERS, &workers))
				return EXIT_USAGE;
			break;
		case 'h':
			printf("usage: relief bench decode FILE.relief [--json] [--runs N] [--workers N] [--device DEV]\n"
			       "GPU decoding through the patch cache against the CPU reference decoder on the same\n"
			       "patches: MSamples/s (decoded patch samples), the CPU entropy stage alone, GPU time\n"
			       "from timestamps, and GPU memory per resident patch. Median of N runs (default 3);\n"
			       "--workers: the cache's entropy-decoding threads (default 1). Also the descent\n"
			       "latency: updates (one per frame) until a root-to-finest chain is resident, and\n"
			       "the ratio at equal outputs: the reference plus the normal maps on the CPU, and\n"
			       "the device alone: the GPU path with every patch's symbols ready first, with the\n"
			       "process's CPU time over it and the ratio that this time and the entropy stage's\n"
			       "allow on this machine's cores (on a CPU device, where the device's work is CPU time).\n");
			return 0;
		case ':':
		default:
			return cli_option_error("bench decode", ch, argv);
		}
	}
	if (argc - optind != 1) {
		fprintf(stderr, "relief bench decode: expected one FILE.relief\n");
		return EXIT_USAGE;
	}
	const char *path = argv[optind];
	char err[512];
	struct relief_file *f;
	if (relief_file_open(path, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief bench decode: %s: %s\n", path, err);
		return 1;
	}
	const uint32_t P = f->hdr.patch_size;
	uint32_t patches = bench_decoded_patches(f);
	const double samples = (double)patches * P * P;
	double cpu[16], ent[16], nrm[16], str[16], gpu[16], gpu_busy[16], gpu_dec[16], gpu_nrm[16], gpu_str[16], worker[16];
	double prof_busy[16], prof_wall, prof_cpu, alone[16], alone_busy[16], alone_cpu[16], alone_dec[16],
		alone_nrm[16], alone_str[16];
	struct relief_patch_cache_stats st = { 0 };
	struct relief_vk_options vo = { .device = device, .log = &cli_log };
	struct relief_vk *vk = NULL;
	int status = 1, ret;
	if ((ret = relief_vk_create(&vo, &vk)) < 0) {
		fprintf(stderr, "relief bench decode: no Vulkan device: %s\n", strerror(-ret));
		goto out;
	}
	for (uint32_t i = 0; i < runs; i++) {
		int32_t *blocks;
		double t = bench_now();
		if ((ret = relief_decode_level_blocks(f, f->hdr.levels - 1, 1, &blocks)) < 0)
			goto fail;
		cpu[i] = bench_now() - t;
		free(blocks);
		struct relief_decoder dec;
		if ((ret = relief_decoder_init(&dec, f)) < 0)
			goto fail;
		t = bench_now();
		for (uint32_t e = 0; e < f->hdr.index_records && ret == 0; e++) {
			const uint32_t id = relief_index_patch(&f->hdr, e);
			struct relief_patch_record r;
			relief_file_record(f, id, &r);
			if (!(r.flags & RELIEF_PATCH_EMPTY))
				ret = relief_decoder_symbols(&dec, id);
		}
		ent[i] = bench_now() - t;
		relief_decoder_finish(&dec);
		if (ret < 0 || (ret = cpu_outputs_run(f, &nrm[i], &str[i])) < 0 || (ret = gpu_run(vk, f, workers, false, &gpu[i], &st)) < 0)
			goto fail;
		gpu_busy[i] = st.gpu_ns * 1e-9;
		worker[i] = st.entropy_ns * 1e-9;
		struct relief_patch_cache_stats ps;
		if ((ret = gpu_run(vk, f, workers, true, &prof_wall, &ps)) < 0)
			goto fail;
		prof_busy[i] = ps.gpu_ns * 1e-9;
		gpu_dec[i] = ps.gpu_decode_ns * 1e-9;
		gpu_nrm[i] = ps.gpu_normals_ns * 1e-9;
		gpu_str[i] = ps.gpu_strips_ns * 1e-9;
		struct relief_patch_cache_stats as;
		if ((ret = device_alone_run(vk, f, patches, workers, false, &alone[i], &alone_cpu[i], &as)) < 0 ||
		    (ret = device_alone_run(vk, f, patches, workers, true, &prof_wall, &prof_cpu, &ps)) < 0)
			goto fail;
		if (as.decoded != st.decoded || ps.decoded != st.decoded) { /* the same patches, or no comparison */
			fprintf(stderr, "relief bench decode: %s: the device-alone runs decoded %llu and %llu patches, the GPU path %llu\n",
			        path, (unsigned long long)as.decoded, (unsigned long long)ps.decoded,
			        (unsigned long long)st.decoded);
			goto out;
		}
		alone_busy[i] = as.gpu_ns * 1e-9;
		alone_dec[i] = ps.gpu_decode_ns * 1e-9;
		alone_nrm[i] = ps.gpu_normals_ns * 1e-9;
		alone_str[i] = ps.gpu_strips_ns * 1e-9;
	}
	uint32_t descent = 0;
	if ((ret = descent_run(vk, f, &descent)) < 0)
		goto fail;
	double c = bench_median(cpu, runs), e = bench_median(ent, runs), g = bench_median(gpu, runs);
	double cn = bench_median(nrm, runs), cs = bench_median(str, runs);
	double gb = bench_median(gpu_busy, runs), w = bench_median(worker, runs);
	double gd = bench_median(gpu_dec, runs), gn = bench_median(gpu_nrm, runs), gs = bench_median(gpu_str, runs);
	double pb = bench_median(prof_busy, runs);
	double ga = bench_median(alone, runs), gab = bench_median(alone_busy, runs), gac = bench_median(alone_cpu, runs);
	/* No scheduling of the path's work on these cores beats its CPU time spread evenly
	 * over them: the entropy stage (e, one thread) and everything else the device-alone
	 * run cost the process (gac). An upper bound of the ratio on a CPU device, given what
	 * the shaders cost there; on a GPU gac is the host's share only and the bound says
	 * little. */
	const uint32_t cores = bench_cores();
	const double bound = c * cores / (e + gac);
	double gad = bench_median(alone_dec, runs), gan = bench_median(alone_nrm, runs), gas = bench_median(alone_str, runs);
	const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
	if (json) {
		printf("{\"file\":");
		cli_json_string(stdout, base);
		printf(",\"patches\":%u,\"gpu_msps\":%.3f,\"cpu_ref_msps\":%.3f,\"entropy_msps\":%.3f,"
		       "\"ratio_gpu_over_cpu\":%.3f,\"bytes_per_patch\":%llu,\"gpu_patches_per_s\":%.1f,"
		       "\"gpu_wall_ms\":%.4f,\"gpu_busy_ms\":%.2f,\"gpu_profiled_busy_ms\":%.2f,\"gpu_decode_pass_ms\":%.2f,"
		       "\"gpu_normals_pass_ms\":%.2f,\"gpu_strips_pass_ms\":%.2f,\"worker_entropy_ms\":%.2f,\"batches\":%llu,"
		       "\"descent_updates\":%u,\"levels\":%u,\"workers\":%u,\"runs\":%u,"
		       "\"cpu_ref_ms\":%.4f,\"cpu_normals_ms\":%.4f,\"cpu_strips_ms\":%.4f,\"ratio_same_outputs\":%.3f,"
		       "\"gpu_alone_wall_ms\":%.4f,\"gpu_alone_busy_ms\":%.2f,\"ratio_cpu_over_gpu_alone\":%.3f,"
		       "\"gpu_alone_decode_pass_ms\":%.2f,\"gpu_alone_normals_pass_ms\":%.2f,\"gpu_alone_strips_pass_ms\":%.2f,"
		       "\"entropy_ms\":%.4f,\"gpu_alone_cpu_ms\":%.4f,\"cores\":%u,\"ratio_bound_cores\":%.3f",
		       patches, samples / g / 1e6, samples / c / 1e6, samples / e / 1e6, c / g,
		       (unsigned long long)st.bytes_per_layer, patches / g, g * 1e3, gb * 1e3, pb * 1e3, gd * 1e3, gn * 1e3,
		       gs * 1e3, w * 1e3, (unsigned long long)st.batches, descent, f->hdr.levels, workers, runs, c * 1e3, cn * 1e3,
		       cs * 1e3, (c + cn + cs) / g, ga * 1e3, gab * 1e3, c / ga, gad * 1e3, gan * 1e3, gas * 1e3, e * 1e3,
		       gac * 1e3, cores, bound);
		bench_json_machine(vk);
	} else {
		printf("relief bench decode: %s, %u non-empty patches of %u^2 samples, on %s (%s), CPU %s, %u run(s), "
		       "medians\n", base, patches, P, vk->props.deviceName, relief_vk_device_type_name(vk->props.deviceType),
		       bench_cpu_name(), runs);
		printf("  CPU reference (1 thread)     %8.2f ms  %7.2f MSamples/s\n", c * 1e3, samples / c / 1e6);
		printf("  CPU entropy stage only       %8.2f ms  %7.2f MSamples/s  (%.0f%% of the reference)\n", e * 1e3,
		       samples / e / 1e6, 100 * e / c);
		printf("  GPU path (%u worker(s) + GPU) %7.2f ms  %7.2f MSamples/s  %.0f patches/s  ratio GPU/CPU %.2f\n",
		       workers, g * 1e3, samples / g / 1e6, patches / g, c / g);
		printf("    GPU busy (timestamps)      %8.2f ms in %llu batches; worker entropy %.2f ms\n", gb * 1e3,
		       (unsigned long long)st.batches, w * 1e3);
		printf("    with pass timestamps       %8.2f ms busy: decode pass %.2f ms, normals pass %.2f ms, strips "
		       "pass %.2f ms\n",
		       pb * 1e3, gd * 1e3, gn * 1e3, gs * 1e3);
		printf("  GPU alone                    %8.2f ms  %.2f ms busy: every patch's symbols ready first, the worker "
		       "idle; the reference over it %.2f\n",
		       ga * 1e3, gab * 1e3, c / ga);
		printf("    with pass timestamps        decode pass %.2f ms, normals pass %.2f ms, strips pass %.2f ms\n",
		       gad * 1e3, gan * 1e3, gas * 1e3);
		printf("    process CPU time           %8.2f ms (all threads); with the entropy stage, spread over %u core(s): "
		       "the ratio GPU/CPU at most %.2f\n",
		       gac * 1e3, cores, bound);
		printf("  CPU normals (1 thread)       %8.2f ms  (the normals pass's twin)\n", cn * 1e3);
		printf("  CPU strip bounds (1 thread)  %8.2f ms  (the strips pass's twin; with the reference and the normals: "
		       "%.2f ms, ratio GPU/CPU at equal outputs %.2f)\n", cs * 1e3, (c + cn + cs) * 1e3, (c + cn + cs) / g);
		printf("  GPU memory per resident patch: %llu bytes (heights, normals, block records: errors, ranges, which have data)\n",
		       (unsigned long long)st.bytes_per_layer);
		printf("  descent: root to finest patch (%u levels) resident after %u updates\n", f->hdr.levels, descent);
	}
	status = 0;
	goto out;
fail:
	fprintf(stderr, "relief bench decode: %s: %s\n", path, strerror(-ret));
out:
	relief_vk_destroy(vk);
	relief_file_close(f);
	return status;
}
