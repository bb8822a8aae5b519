/* relief bench codec FILE...: bytes and speed of the codec against the tolerance, with two
 * baselines built from standard tools in the same run:
 *   zstd-lossless   zstd -19 of the source's raw 16-bit samples (16-bit sources only);
 *   quant-zstd      q = round(h / (2 tolerance)) at full resolution, zstd -19 (the same
 *                   L-inf bound at full resolution, but no pyramid and no random access).
 * Sizes count whole outputs (relief: the complete .relief file, every level, index, masks
 * and block errors). MSamples/s count the full-resolution raster (W x H) per second, on one
 * thread; relief's decode rebuilds every level of the pyramid to get there. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zstd.h>

#include "bench.h"
#include "bench_util.h"
#include "cli.h"
#include "decode.h"
#include "import_opts.h"
#include "pack.h"
#include "parallel.h"

struct result {
	const char *file, *method;
	double tolerance, max_error, encode_s, decode_s;
	size_t bytes;
	double patch_msps; /* relief only: patch samples decoded per second */
};

struct ctx {
	const struct relief_dem *dem;
	uint64_t valid;
	unsigned runs;
	bool json;
};

static void report(const struct ctx *c, const struct result *r)
{
	double samples = (double)c->dem->width * c->dem->height;
	double raw = 2.0 * samples;
	double enc = samples / r->encode_s / 1e6, dec = samples / r->decode_s / 1e6;
	if (c->json) {
		printf("{\"file\":");
		cli_json_string(stdout, r->file);
		printf(",\"method\":\"%s\",\"tolerance_m\":%g,\"bytes\":%zu,\"ratio\":%.4f,"
		       "\"bits_per_sample\":%.4f,\"max_error_m\":%.6g,\"encode_msps\":%.3f,\"decode_msps\":%.3f,"
		       "\"patch_decode_msps\":%.3f,\"runs\":%u,\"samples\":%.0f,\"valid_samples\":%llu",
		       r->method, r->tolerance, r->bytes, raw / r->bytes, 8.0 * r->bytes / c->valid, r->max_error, enc, dec,
		       r->patch_msps, c->runs, samples, (unsigned long long)c->valid);
		bench_json_machine(NULL);
	} else {
		printf("%-22s %-14s %8g %10zu %7.2f %7.3f %10.4g %9.2f %9.2f\n", r->file, r->method, r->tolerance,
		       r->bytes, raw / r->bytes, 8.0 * r->bytes / c->valid, r->max_error, enc, dec);
	}
	fflush(stdout);
}

static double max_error(const struct relief_dem *d, const float *h)
{
	double worst = 0;
	for (size_t i = 0; i < (size_t)d->width * d->height; i++)
		if (d->valid[i])
			worst = fmax(worst, fabs((double)d->heights[i] - h[i]));
	return worst;
}

static int bench_relief(struct ctx *c, struct result *r)
{
	const struct relief_dem *d = c->dem;
	double enc[16], dec[16];
	uint8_t *img = NULL;
	size_t size = 0;
	struct relief_pack_options po = { .patch = 129, .ratio = 2, .tolerance = r->tolerance, .threads = 1 };
	for (unsigned i = 0; i < c->runs; i++) {
		free(img);
		double t = bench_now();
		int ret = relief_pack_memory(d, &po, &img, &size, NULL);
		enc[i] = bench_now() - t;
		if (ret < 0)
			return ret;
	}
	char err[256];
	struct relief_file *f;
	int ret = relief_file_open_memory(img, size, &f, err, sizeof(err));
	if (ret < 0) {
		free(img);
		return ret;
	}
	int32_t *blocks = NULL;
	for (unsigned i = 0; i < c->runs && ret == 0; i++) {
		free(blocks);
		double t = bench_now();
		ret = relief_decode_level_blocks(f, f->hdr.levels - 1, 1, &blocks);
		dec[i] = bench_now() - t;
	}
	float *h = malloc(sizeof(float) * d->width * d->height);
	if (ret == 0 && !h)
		ret = -ENOMEM;
	if (ret == 0)
		ret = relief_decode_level(f, f->hdr.levels - 1, 0, h, NULL);
	if (ret == 0) {
		r->max_error = max_error(d, h);
		r->bytes = size;
		r->encode_s = bench_median(enc, c->runs);
		r->decode_s = bench_median(dec, c->runs);
		/* Decoded patches only: an empty patch (no valid sample) has no stream. */
		double patch_samples = (double)bench_decoded_patches(f) * f->hdr.patch_size * f->hdr.patch_size;
		r->patch_msps = patch_samples / r->decode_s / 1e6;
	}
	free(h);
	free(blocks);
	relief_file_close(f);
	free(img);
	return ret;
}

/* zstd -19 of `in`; decode back into `out` (same size). */
static int bench_zstd(struct ctx *c, const void *in, size_t in_size, void *out, struct result *r)
{
	size_t cap = ZSTD_compressBound(in_size);
	void *z = malloc(cap);
	if (!z)
		return -ENOMEM;
	double enc[16], dec[16];
	size_t zsize = 0;
	for (unsigned i = 0; i < c->runs; i++) {
		double t = bench_now();
		zsize = ZSTD_compress(z, cap, in, in_size, 19);
		enc[i] = bench_now() - t;
		if (ZSTD_isError(zsize)) {
			free(z);
			return -EIO;
		}
	}
	for (unsigned i = 0; i < c->runs; i++) {
		double t = bench_now();
		size_t n = ZSTD_decompress(out, in_size, z, zsize);
		dec[i] = bench_now() - t;
		if (ZSTD_isError(n) || n != in_size) {
			free(z);
			return -EIO;
		}
	}
	free(z);
	r->bytes = zsize;
	r->encode_s = bench_median(enc, c->runs);
	r->decode_s = bench_median(dec, c->runs);
	return 0;
}

static int bench_quant_zstd(struct ctx *c, struct result *r)
{
	const struct relief_dem *d = c->dem;
	size_t n = (size_t)d->width * d->height;
	double inv = 1.0 / (2.0 * r->tolerance);
	int32_t *q = malloc(sizeof(int32_t) * n), *back = malloc(sizeof(int32_t) * n);
	float *h = malloc(sizeof(float) * n);
	int ret = -ENOMEM;
	if (!q || !back || !h)
		goto out;
	bool narrow = true;
	for (size_t i = 0; i < n; i++) {
		q[i] = d->valid[i] ? (int32_t)llround(d->heights[i] * inv) : 0;
		narrow = narrow && q[i] >= INT16_MIN && q[i] <= INT16_MAX;
	}
	/* int16 when the quantised range fits, as a user would store it; else int32. */
	size_t width = narrow ? 2 : 4;
	if (narrow) {
		int16_t *q16 = (int16_t *)q;
		for (size_t i = 0; i < n; i++)
			q16[i] = (int16_t)q[i];
	}
	if ((ret = bench_zstd(c, q, n * width, back, r)) < 0)
		goto out;
	for (size_t i = 0; i < n; i++)
		h[i] = (float)(2.0 * r->tolerance * (narrow ? ((int16_t *)back)[i] : back[i]));
	r->max_error = max_error(d, h);
out:
	free(q);
	free(back);
	free(h);
	return ret;
}

static int bench_lossless(struct ctx *c, struct result *r)
{
	const struct relief_dem *d = c->dem;
	size_t n = (size_t)d->width * d->height;
	int16_t *raw = malloc(2 * n), *back = malloc(2 * n);
	int ret = -ENOMEM;
	if (raw && back) {
		for (size_t i = 0; i < n; i++)
			raw[i] = (int16_t)d->raw16[i];
		ret = bench_zstd(c, raw, 2 * n, back, r);
		if (ret == 0 && memcmp(raw, back, 2 * n) != 0)
			ret = -EIO;
		r->max_error = 0.0; /* the source samples come back bit for bit */
	}
	free(raw);
	free(back);
	return ret;
}

int bench_codec(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "json", no_argument, NULL, 'J' },
		{ "runs", required_argument, NULL, 'n' },
		{ "tolerances", required_argument, NULL, 'T' },
		{ "help", no_argument, NULL, 'h' },
		IMPORT_LONG_OPTIONS,
		{ 0 },
	};
	struct dem_import_options cli = { 0 };
	struct ctx c = { .runs = 3 };
	double tols[16] = { 0.1, 0.25, 0.5, 1, 2, 4 };
	uint32_t ntol = 6;
	int ch;
	opterr = 0;
	while ((ch = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
		switch (ch) {
		case 'J': c.json = true; break;
		case 'n':
			if (!cli_parse_u32("bench codec", "--runs", optarg, 1, 15, &c.runs))
				return EXIT_USAGE;
			break;
		case 'T':
			if (!cli_parse_list("bench codec", "--tolerances", optarg, 1e-4, 1e4, tols, 16, &ntol))
				return EXIT_USAGE;
			break;
		case 'h':
			printf("usage: relief bench codec FILE... [--json] [--runs N] [--tolerances a,b,...]\n"
			       "For each file and tolerance (default 0.1,0.25,0.5,1,2,4 m): relief's size, ratio over\n"
			       "16-bit samples, bits per valid sample, measured max error and encode/decode\n"
			       "MSamples/s (one thread, median of N runs, default 3), against zstd -19 of the raw\n"
			       "16-bit samples and quantise-to-tolerance + zstd -19. Import options apply to every\n"
			       "file; INPUT.relief-import sidecars fill in the rest.\n%s", IMPORT_OPTIONS_HELP);
			return 0;
		case ':':
		case '?':
			return cli_option_error("bench codec", ch, argv);
		default:
			if (!import_option("bench codec", ch, optarg, &cli))
				return EXIT_USAGE;
		}
	}
	if (optind >= argc) {
		fprintf(stderr, "relief bench codec: expected at least one FILE\n");
		return EXIT_USAGE;
	}
	if (!c.json) {
		printf("relief bench codec: %s, %u cores, %u run(s) per timing (median), one thread\n",
		       bench_cpu_name(), relief_cpu_count(), c.runs);
		printf("%-22s %-14s %8s %10s %7s %7s %10s %9s %9s\n", "file", "method", "tol_m", "bytes", "ratio",
		       "bits/s", "max_err_m", "enc_MS/s", "dec_MS/s");
	}
	int status = 0;
	for (int i = optind; i < argc; i++) {
		struct dem_import_options io = cli;
		if (import_sidecar_merge("bench codec", argv[i], &io) < 0)
			return EXIT_USAGE;
		struct relief_dem dem;
		char err[512];
		if (dem_import(argv[i], &io, &dem, err, sizeof(err)) < 0) {
			fprintf(stderr, "relief bench codec: %s\n", err);
			status = 1;
			continue;
		}
		dem_report_dropped("bench codec", argv[i], &dem);
		if (!dem_pack_fits("bench codec", argv[i], &dem, 129)) {
			relief_dem_finish(&dem);
			status = 1;
			continue;
		}
		c.dem = &dem;
		c.valid = 0;
		for (size_t k = 0; k < (size_t)dem.width * dem.height; k++)
			c.valid += dem.valid[k];
		const char *base = strrchr(argv[i], '/') ? strrchr(argv[i], '/') + 1 : argv[i];
		if (dem.raw16) {
			struct result r = { .file = base, .method = "zstd-lossless" };
			if (bench_lossless(&c, &r) == 0)
				report(&c, &r);
			else
				status = 1;
		}
		for (size_t t = 0; t < ntol; t++) {
			struct result r = { .file = base, .method = "relief", .tolerance = tols[t] };
			int ret = bench_relief(&c, &r);
			if (ret < 0) {
				fprintf(stderr, "relief bench codec: %s at %g m: %s\n", base, tols[t], strerror(-ret));
				status = 1;
			} else {
				report(&c, &r);
			}
			struct result z = { .file = base, .method = "quant-zstd", .tolerance = tols[t] };
			if (bench_quant_zstd(&c, &z) == 0)
				report(&c, &z);
			else
				status = 1;
		}
		relief_dem_finish(&dem);
	}
	return status;
}
