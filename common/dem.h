/* An elevation model in memory, as the importer produces it and the packer consumes it.
 * Heights are metres (converted from the source's units), row 0 is the northern row.
 * World coordinates: x east, y north, metres; sample (col, row) is at
 * (origin_x + col * spacing_x, origin_y - row * spacing_y). */
#pragma once

#include <stdint.h>

struct relief_dem {
	uint32_t width, height;
	float *heights;      /* width * height; undefined where !valid */
	uint8_t *valid;      /* width * height, 1 = a height, 0 = no-data */
	double origin_x, origin_y;
	double spacing_x, spacing_y;
	uint32_t source_units; /* enum relief_units */
	char *crs_wkt;         /* WKT or PROJ string (OSRSetFromUserInput syntax); NULL or "": none */
	int32_t *raw16;        /* NULL, or the source's 16-bit integer samples (for baselines) */
	/* Samples the source gave as heights that are not finite or beyond RELIEF_MAX_HEIGHT
	 * (format.h): stored as no-data. One of them, by column and row in the source. */
	uint64_t dropped;
	uint32_t dropped_col, dropped_row;
};

void relief_dem_finish(struct relief_dem *d);
