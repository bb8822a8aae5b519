/* relief info FILE.relief [--json]: what a .relief file holds. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "format.h"

int cmd_info(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "json", no_argument, NULL, 'J' },
		{ "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	bool json = false;
	int c;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
		switch (c) {
		case 'J': json = true; break;
		case 'h':
			printf("usage: relief info FILE.relief [--json]\n"
			       "Prints the header, extent, levels with their tolerances, patch counts and sizes.\n");
			return 0;
		default:
			return cli_option_error("info", c, argv);
		}
	}
	if (argc - optind != 1) {
		fprintf(stderr, "relief info: expected one FILE.relief\n");
		return EXIT_USAGE;
	}
	const char *path = argv[optind];
	char err[512];
	struct relief_file *f;
	if (relief_file_open(path, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief info: %s: %s\n", path, err);
		return 1;
	}
	const struct relief_header *h = &f->hdr;
	double x0 = h->origin_x, x1 = h->origin_x + (h->width - 1) * h->spacing_x;
	double y1 = h->origin_y, y0 = h->origin_y - (h->height - 1) * h->spacing_y;
	uint32_t nonempty[RELIEF_MAX_LEVELS] = { 0 };
	uint64_t bytes[RELIEF_MAX_LEVELS] = { 0 };
	for (uint32_t id = 0; id < h->patch_count; id++) {
		uint32_t l, px, py;
		relief_patch_coords(&f->layout, id, &l, &px, &py);
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		if (!(r.flags & RELIEF_PATCH_EMPTY)) {
			nonempty[l]++;
			bytes[l] += r.size;
		}
	}
	double bps = 8.0 * h->file_size / h->valid_samples;
	if (json) {
		printf("{\"file\":");
		cli_json_string(stdout, path);
		printf(",\"version\":%u,\"bytes\":%llu,\"width\":%u,\"height\":%u,\"grid\":%u,\"patch\":%u,"
		       "\"ratio\":%u,\"tolerance_m\":%.17g,\"spacing_m\":[%.17g,%.17g],"
		       "\"extent\":{\"x\":[%.17g,%.17g],\"y\":[%.17g,%.17g]},\"height_m\":[%.17g,%.17g],"
		       "\"valid_samples\":%llu,\"bits_per_sample\":%.6f,\"source_units\":\"%s\",\"crs\":",
		       h->version, (unsigned long long)h->file_size, h->width, h->height, h->size, h->patch_size,
		       h->ratio, h->tolerance, h->spacing_x, h->spacing_y, x0, x1, y0, y1, h->height_min,
		       h->height_max, (unsigned long long)h->valid_samples, bps,
		       h->source_units == RELIEF_UNITS_FEET ? "ft" : "m");
		cli_json_string(stdout, f->crs);
		printf(",\"levels\":[");
		for (uint32_t l = 0; l < h->levels; l++)
			printf("%s{\"level\":%u,\"delta_m\":%.17g,\"patches\":%u,\"nonempty\":%u,\"bytes\":%llu}",
			       l ? "," : "", l, h->delta[l], 1u << (2 * l), nonempty[l], (unsigned long long)bytes[l]);
		printf("]}\n");
	} else {
		printf("%s: relief format %u, %llu bytes\n", path, h->version, (unsigned long long)h->file_size);
		printf("  raster     %u x %u samples in a %u x %u grid, spacing %.6g x %.6g m\n", h->width, h->height,
		       h->size, h->size, h->spacing_x, h->spacing_y);
		printf("  extent     x %.3f .. %.3f, y %.3f .. %.3f (world metres, x east, y north)\n", x0, x1, y0, y1);
		printf("  crs        %.70s%s\n", f->crs[0] ? f->crs : "none (unreferenced)", strlen(f->crs) > 70 ? "..." : "");
		printf("  heights    %.3f .. %.3f m (source units %s), %llu valid samples (%.1f%%)\n", h->height_min,
		       h->height_max, h->source_units == RELIEF_UNITS_FEET ? "ft" : "m",
		       (unsigned long long)h->valid_samples, 100.0 * h->valid_samples / ((double)h->width * h->height));
		printf("  patches    %u samples, %u x %u blocks of %u cells, tolerance %.6g m, ratio %u\n", h->patch_size,
		       f->layout.blocks, f->layout.blocks, h->block_cells, h->tolerance, h->ratio);
		printf("  level  delta_m     patches  nonempty  bytes\n");
		for (uint32_t l = 0; l < h->levels; l++)
			printf("  %5u  %-10.6g  %7u  %8u  %llu\n", l, h->delta[l], 1u << (2 * l), nonempty[l],
			       (unsigned long long)bytes[l]);
		printf("  total      %.3f bits per valid sample\n", bps);
	}
	relief_file_close(f);
	return 0;
}
