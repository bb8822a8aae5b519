/* Elevation import through GDAL: GeoTIFF, SRTM .hgt, 16-bit PNG, Mapbox Terrain-RGB PNG,
 * and raw int16/float32 (wrapped in a VRT). World coordinates follow docs/format.md:
 * metres, x east, y north; projected CRSs keep their coordinates (scaled to metres),
 * geographic CRSs get a local equirectangular projection, unreferenced rasters put their
 * south-west sample at (0, 0). */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dem.h"

enum dem_encoding {
	DEM_ENCODING_HEIGHT = 0,  /* band 1 is a height (after scale and offset) */
	DEM_ENCODING_TERRAIN_RGB, /* Mapbox: h = -10000 + (R 65536 + G 256 + B) / 10 */
};

struct dem_import_options {
	enum dem_encoding encoding;
	bool has_encoding, has_units;
	bool has_scale, has_offset, has_spacing, has_nodata;
	double scale, offset, spacing, nodata;
	uint32_t units; /* enum relief_units of the values (after scale/offset) */
	/* Raw input: width and height > 0 and a type ("int16" or "float32"). */
	uint32_t raw_width, raw_height;
	const char *raw_type;
	bool raw_big_endian;
};

/* 0, or a negative errno with a one-line reason in err. */
int dem_import(const char *path, const struct dem_import_options *o, struct relief_dem *out, char *err,
               size_t err_size);
/* Says on stderr, as "relief CMD: PATH: ...", how many samples the import dropped as no
 * data because they were not heights (relief_dem.dropped), if any. */
void dem_report_dropped(const char *cmd, const char *path, const struct relief_dem *d);
/* Says on stderr "relief CMD: PATH: WHY: ..." with the quadtree, the quantised window and
 * what packing raster d at `patch` samples a side holds at peak (about 6 bytes per
 * quantised sample, 12 per raster sample (18 with no-data) and 100 per patch of the tree, as measured:
 * docs/format.md, "Known limits"), and the memory `have` (bytes) when it is above 0, as
 * "where WHO N GB". */
void dem_pack_explain(const char *cmd, const char *path, const struct relief_dem *d, uint32_t patch, const char *why,
                      double have, const char *who);
/* Says why on stderr ("relief CMD: PATH: ...") and returns false when that estimate is
 * more than the machine's physical memory or the process's address-space limit, so that packing is refused at once instead of failing
 * after minutes or being killed when the memory runs out. */
bool dem_pack_fits(const char *cmd, const char *path, const struct relief_dem *d, uint32_t patch);
/* The same from a raster already open (a GDALDatasetH; the caller keeps and closes it;
 * `path` only names it in messages): size, bands, georeferencing, values, no-data. What
 * dem_import() does after opening, and what the import fuzz target drives directly. */
int dem_import_dataset(void *dataset, const char *path, const struct dem_import_options *o, struct relief_dem *out,
                       char *err, size_t err_size);
/* Mean Earth radius used by the local projection of geographic rasters (IUGG, metres). */
#define DEM_EARTH_RADIUS 6371008.8
