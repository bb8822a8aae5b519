/* relief info FILE.relief [--json]: what a .relief file holds. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
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
	uint32_t nonempty[RELIEF_MAX_LEVELS] = { 0 }, bad_masks = 0;
	uint64_t bytes[RELIEF_MAX_LEVELS] = { 0 };
	/* Blocks with a valid sample: the ones a renderer tessellates (relief_mask_blocks()). */
	uint64_t data_blocks[RELIEF_MAX_LEVELS] = { 0 };
	/* The largest Err(P) (against the original) and drawn error E0(P) (against the finest
	 * decoded surface, what the selection projects) of each level's patches, metres. */
	float err_max[RELIEF_MAX_LEVELS] = { 0 }, drawn_max[RELIEF_MAX_LEVELS] = { 0 };
	const uint32_t n_blocks = f->layout.blocks * f->layout.blocks;
	uint8_t *mask = malloc((size_t)h->patch_size * h->patch_size), has_data[RELIEF_MAX_BLOCKS];
	if (!mask) {
		fprintf(stderr, "relief info: out of memory\n");
		relief_file_close(f);
		return 1;
	}
	for (uint32_t e = 0; e < h->index_records; e++) { /* patches without an entry are EMPTY */
		const uint32_t id = relief_index_patch(h, e);
		uint32_t l, px, py;
		relief_patch_coords(&f->layout, id, &l, &px, &py);
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		if (r.flags & RELIEF_PATCH_EMPTY)
			continue;
		nonempty[l]++;
		bytes[l] += r.size;
		err_max[l] = r.error > err_max[l] ? r.error : err_max[l];
		drawn_max[l] = r.draw_error > drawn_max[l] ? r.draw_error : drawn_max[l];
		if (!(r.flags & RELIEF_PATCH_MASKED)) {
			data_blocks[l] += n_blocks;
		} else if (relief_file_mask(f, id, mask) < 0) {
			bad_masks++;
		} else {
			relief_mask_blocks(mask, h->patch_size, has_data);
			for (uint32_t b = 0; b < n_blocks; b++)
				data_blocks[l] += has_data[b];
		}
	}
	free(mask);
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
		printf(",\"index_records\":%u,\"block_records\":%u,\"block_error_unit_m\":%.17g,\"metadata_bytes\":%llu",
		       h->index_records, h->block_patches, h->block_error_unit, (unsigned long long)h->data_offset);
		printf(",\"corrupt_masks\":%u,\"levels\":[", bad_masks);
		for (uint32_t l = 0; l < h->levels; l++)
			printf("%s{\"level\":%u,\"delta_m\":%.17g,\"patches\":%u,\"nonempty\":%u,\"bytes\":%llu,"
			       "\"blocks\":%llu,\"blocks_with_data\":%llu,\"err_max_m\":%.9g,\"drawn_err_max_m\":%.9g}",
			       l ? "," : "", l, h->delta[l], 1u << (2 * l), nonempty[l], (unsigned long long)bytes[l],
			       (unsigned long long)nonempty[l] * n_blocks, (unsigned long long)data_blocks[l], err_max[l],
			       drawn_max[l]);
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
		printf("  metadata   %llu bytes: %u index records, %u block records (patches without one are "
		       "empty), block errors in steps of 2^(1/16) from %.6g m\n",
		       (unsigned long long)h->data_offset, h->index_records, h->block_patches, h->block_error_unit);
		printf("  level  delta_m     patches  nonempty  blocks with data  max Err(P) m  max E0(P) m  bytes\n");
		for (uint32_t l = 0; l < h->levels; l++)
			printf("  %5u  %-10.6g  %7u  %8u  %6.1f%%           %-12.6g  %-11.6g  %llu\n", l, h->delta[l],
			       1u << (2 * l), nonempty[l],
			       nonempty[l] ? 100.0 * data_blocks[l] / ((double)nonempty[l] * n_blocks) : 0.0, err_max[l],
			       drawn_max[l], (unsigned long long)bytes[l]);
		if (h->version < 7)
			printf("  (format %u stores no E0(P): the bound from Err(P) is shown)\n", h->version);
		printf("  total      %.3f bits per valid sample\n", bps);
		if (bad_masks)
			printf("  corrupt    %u patch mask(s) fail their check (blocks with data not counted there)\n", bad_masks);
	}
	relief_file_close(f);
	return 0;
}
