/* relief pack INPUT OUT.relief --tolerance METRES: import, build, compress, write. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "format.h"
#include "import_opts.h"
#include "pack.h"

static void pack_usage(FILE *f)
{
	fprintf(f,
		"usage: relief pack INPUT OUT.relief --tolerance METRES [options]\n"
		"Builds the patch quadtree of INPUT and compresses it with a guaranteed maximum error.\n"
		"  -t, --tolerance M    largest height error at full resolution, metres (required)\n"
		"      --patch N        patch size 65, 129 or 257 samples (default 129)\n"
		"      --ratio K        tolerance growth per coarser level, 2 or 3 (default 2)\n"
		"      --threads N      worker threads (default: every core)\n"
		"      --format-version V  file format to write: 9 (default) or 8, for older readers\n"
		"  -q, --quiet          no progress bar and no summary\n"
		IMPORT_OPTIONS_HELP
		"Import options not given are read from INPUT.relief-import if it exists ([import] section).\n");
}

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + ts.tv_nsec * 1e-9;
}

struct progress {
	double start, last;
	double bytes_per_patch; /* input float heights per patch */
};

static void progress_bar(void *data, uint32_t done, uint32_t total, uint64_t bytes)
{
	struct progress *p = data;
	double t = now();
	if (done < total && t - p->last < 0.1)
		return;
	p->last = t;
	double el = t - p->start, rate = el > 0 ? done * p->bytes_per_patch / el / 1e6 : 0;
	double eta = done ? el * (total - done) / done : 0;
	int width = 30, fill = (int)((double)width * done / total);
	fprintf(stderr, "\rpack [%.*s%*s] %u/%u patches  %.1f MB/s  ETA %.0fs ", fill,
	        "##############################", width - fill, "", done, total, rate, eta);
	if (done == total)
		fputc('\n', stderr);
}

int cmd_pack(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "tolerance", required_argument, NULL, 't' },
		{ "patch", required_argument, NULL, 'p' },
		{ "ratio", required_argument, NULL, 'r' },
		{ "threads", required_argument, NULL, 'j' },
		{ "format-version", required_argument, NULL, 'V' },
		{ "quiet", no_argument, NULL, 'q' },
		{ "help", no_argument, NULL, 'h' },
		IMPORT_LONG_OPTIONS,
		{ 0 },
	};
	struct dem_import_options io = { 0 };
	struct relief_pack_options po = { .patch = 129, .ratio = 2 };
	bool have_tol = false, quiet = false;
	int c;
	opterr = 0;
	optind = 1;
	while ((c = getopt_long(argc, argv, ":t:qh", opts, NULL)) != -1) {
		switch (c) {
		case 't':
			if (!cli_parse_double("pack", "--tolerance", optarg, &po.tolerance))
				return EXIT_USAGE;
			if (!(po.tolerance >= 1e-4 && po.tolerance <= 1e4)) {
				fprintf(stderr, "relief pack: --tolerance: %g m is outside [0.0001, 10000]\n", po.tolerance);
				return EXIT_USAGE;
			}
			have_tol = true;
			break;
		case 'p':
			if (!cli_parse_u32("pack", "--patch", optarg, 65, 257, &po.patch))
				return EXIT_USAGE;
			if (po.patch != 65 && po.patch != 129 && po.patch != 257) {
				fprintf(stderr, "relief pack: --patch: %u is not 65, 129 or 257\n", po.patch);
				return EXIT_USAGE;
			}
			break;
		case 'r':
			if (!cli_parse_u32("pack", "--ratio", optarg, 2, 3, &po.ratio))
				return EXIT_USAGE;
			break;
		case 'j':
			if (!cli_parse_u32("pack", "--threads", optarg, 1, 1024, &po.threads))
				return EXIT_USAGE;
			break;
		case 'V':
			if (!cli_parse_u32("pack", "--format-version", optarg, 8, RELIEF_FORMAT_VERSION, &po.version))
				return EXIT_USAGE;
			break;
		case 'q': quiet = true; break;
		case 'h': pack_usage(stdout); return 0;
		case ':':
		case '?':
			return cli_option_error("pack", c, argv);
		default:
			if (!import_option("pack", c, optarg, &io))
				return EXIT_USAGE;
		}
	}
	if (argc - optind != 2) {
		fprintf(stderr, "relief pack: expected INPUT and OUT.relief (see 'relief pack --help')\n");
		return EXIT_USAGE;
	}
	if (!have_tol) {
		fprintf(stderr, "relief pack: --tolerance METRES is required\n");
		return EXIT_USAGE;
	}
	if (!import_options_check("pack", &io))
		return EXIT_USAGE;
	const char *in = argv[optind], *out = argv[optind + 1];
	char sidecar[4096];
	snprintf(sidecar, sizeof(sidecar), "%s" IMPORT_SIDECAR_SUFFIX, in);
	const char *ins[] = { in, sidecar };
	if (!cli_outputs_ok("pack", &out, 1, ins, 2))
		return EXIT_USAGE;
	if (import_sidecar_merge("pack", in, &io) < 0)
		return EXIT_USAGE;

	char err[512];
	struct relief_dem dem;
	double t0 = now();
	int ret = dem_import(in, &io, &dem, err, sizeof(err));
	if (ret < 0) {
		fprintf(stderr, "relief pack: %s\n", err);
		return 1;
	}
	dem_report_dropped("pack", in, &dem);
	if (!dem_pack_fits("pack", in, &dem, po.patch)) {
		relief_dem_finish(&dem);
		return 1;
	}
	struct progress prog = { .start = now(), .bytes_per_patch = 4.0 * po.patch * po.patch };
	if (!quiet && isatty(STDERR_FILENO)) {
		po.progress = progress_bar;
		po.progress_data = &prog;
	}
	uint8_t *img = NULL;
	size_t size = 0;
	struct relief_pack_stats st;
	ret = relief_pack_memory(&dem, &po, &img, &size, &st);
	if (ret == -ENOMEM) {
		/* The estimate missed: say what it was (docs/format.md, "Known limits"). */
		dem_pack_explain("pack", in, &dem, po.patch, "out of memory", 0, NULL);
		relief_dem_finish(&dem);
		return 1;
	}
	if (ret < 0) {
		const char *why = ret == -ENODATA ? "no valid sample" :
		                  ret == -ERANGE ? "heights too large for this tolerance (|h| / (2 tolerance) must stay below 2^24)" :
		                  strerror(-ret);
		fprintf(stderr, "relief pack: %s: %s\n", in, why);
		relief_dem_finish(&dem);
		return 1;
	}
	if ((ret = relief_pack_write(out, img, size)) < 0) {
		fprintf(stderr, "relief pack: cannot write %s: %s\n", out, strerror(-ret));
		free(img);
		relief_dem_finish(&dem);
		return 1;
	}
	if (!quiet) {
		uint64_t valid = 0;
		for (size_t i = 0; i < (size_t)dem.width * dem.height; i++)
			valid += dem.valid[i];
		printf("relief pack: %s -> %s: %ux%u samples (%llu valid), %u levels, %u patches (%u empty, %u masked)\n",
		       in, out, dem.width, dem.height, (unsigned long long)valid, st.levels, st.patches,
		       st.empty_patches, st.masked_patches);
		printf("  %zu bytes, %.3f bits per valid sample, ratio %.2f:1 over 16-bit samples, %.2f s\n", size,
		       8.0 * size / valid, 2.0 * dem.width * dem.height / size, now() - t0);
		for (uint32_t l = 0; l < st.levels; l++)
			printf("  level %u: tolerance %.4g m, measured max error %.4g m\n", l,
			       po.tolerance * pow(po.ratio, st.levels - 1 - l), st.max_error[l]);
	}
	free(img);
	relief_dem_finish(&dem);
	return 0;
}
