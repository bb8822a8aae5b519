/* The importer's own logic after GDAL has opened a raster (tools/dem_import.c,
 * dem_import_dataset()): size, bands, geotransform, CRS, scale and offset, no-data, the
 * Terrain-RGB encoding, on small in-memory rasters whose every property comes from the
 * input. What it accepts must pack, and the packed file must open: an importer that
 * takes a raster the writer or the reader refuses is the defect this target looks for
 * (a NaN origin and a 1e-9 m spacing were once such rasters).
 *
 * Input: W = 2 + b0 % 15, H = 2 + b1 % 15, flags b2 (bit 0 geotransform, bits 1-2 CRS:
 * none, UTM 32N, WGS 84, NAD83 New York Long Island in US feet; bit 3 the band's no-data
 * value; bit 4 int16 instead of float32; bit 5 Terrain-RGB, three bands; bit 6 --scale
 * and --offset; bit 7 --spacing), then the doubles gt[6], nodata, scale, offset, spacing
 * (little-endian, missing bytes zero), then the samples band by band. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gdal.h>
#include <ogr_srs_api.h>

#include "dem_import.h"
#include "format.h"
#include "fuzz.h"
#include "pack.h"

struct reader {
	const uint8_t *p;
	size_t n;
};

static void take(struct reader *r, void *out, size_t size)
{
	size_t k = r->n < size ? r->n : size;
	memset(out, 0, size);
	memcpy(out, r->p, k);
	r->p += k;
	r->n -= k;
}

static double take_f64(struct reader *r)
{
	double v;
	take(r, &v, sizeof(v));
	return v;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static OGRSpatialReferenceH srs[4];
	if (!srs[1]) {
		GDALAllRegister();
		CPLPushErrorHandler(CPLQuietErrorHandler);
		const int epsg[4] = { 0, 32632, 4326, 2263 };
		for (int i = 1; i < 4; i++) {
			srs[i] = OSRNewSpatialReference(NULL);
			OSRSetAxisMappingStrategy(srs[i], OAMS_TRADITIONAL_GIS_ORDER);
			if (OSRImportFromEPSG(srs[i], epsg[i]) != OGRERR_NONE)
				abort(); /* the fuzz machine lacks PROJ's database */
		}
	}
	struct reader r = { data, size };
	uint8_t head[3];
	take(&r, head, sizeof(head));
	const int W = 2 + head[0] % 15, H = 2 + head[1] % 15, flags = head[2];
	const bool rgb = flags & 32, i16 = flags & 16;
	double gt[6];
	for (int i = 0; i < 6; i++)
		gt[i] = take_f64(&r);
	double nodata = take_f64(&r), scale = take_f64(&r), offset = take_f64(&r), spacing = take_f64(&r);

	const int bands = rgb ? 3 : 1;
	GDALDatasetH ds = GDALCreate(GDALGetDriverByName("MEM"), "", W, H, bands, i16 ? GDT_Int16 : GDT_Float32, NULL);
	if (!ds)
		abort();
	for (int b = 0; b < bands; b++) {
		size_t bytes = (size_t)W * H * (i16 ? 2 : 4);
		uint8_t *v = malloc(bytes);
		take(&r, v, bytes);
		if (GDALRasterIO(GDALGetRasterBand(ds, b + 1), GF_Write, 0, 0, W, H, v, W, H, i16 ? GDT_Int16 : GDT_Float32,
		                 0, 0) != CE_None)
			abort();
		free(v);
	}
	if (flags & 1)
		GDALSetGeoTransform(ds, gt);
	if ((flags >> 1) & 3)
		GDALSetSpatialRef(ds, srs[(flags >> 1) & 3]);
	if (flags & 8)
		GDALSetRasterNoDataValue(GDALGetRasterBand(ds, 1), nodata);

	/* Options as the command line would pass them (it refuses a scale of 0, a spacing
	 * that is not positive and anything not finite). */
	struct dem_import_options o = { .encoding = rgb ? DEM_ENCODING_TERRAIN_RGB : DEM_ENCODING_HEIGHT };
	if ((flags & 64) && !rgb && isfinite(scale) && scale != 0 && isfinite(offset)) {
		o.has_scale = o.has_offset = true;
		o.scale = scale;
		o.offset = offset;
	}
	if ((flags & 128) && isfinite(spacing) && spacing > 0) {
		o.has_spacing = true;
		o.spacing = spacing;
	}
	struct relief_dem d;
	char err[512];
	if (dem_import_dataset(ds, "fuzz", &o, &d, err, sizeof(err)) == 0) {
		if (d.width != (uint32_t)W || d.height != (uint32_t)H)
			abort();
		uint32_t valid = 0;
		for (size_t i = 0; i < (size_t)W * H; i++)
			if (d.valid[i]) {
				valid++;
				if (!isfinite(d.heights[i]) || fabsf(d.heights[i]) > RELIEF_MAX_HEIGHT)
					abort();
			}
		if (!valid || d.dropped > (uint64_t)W * H - valid)
			abort();
		/* A dropped sample named by its source position is no-data (rows may be flipped). */
		if (d.dropped && (d.dropped_col >= (uint32_t)W || d.dropped_row >= (uint32_t)H ||
		                  (d.valid[(size_t)d.dropped_row * W + d.dropped_col] &&
		                   d.valid[(size_t)(H - 1 - d.dropped_row) * W + d.dropped_col])))
			abort();
		struct relief_pack_options po = { .patch = 65, .ratio = 2, .tolerance = 1.0, .threads = 1 };
		uint8_t *img;
		size_t n;
		if (relief_pack_memory(&d, &po, &img, &n, NULL) != 0)
			abort(); /* imported, but the writer refuses it */
		struct relief_file *f;
		if (relief_file_open_memory(img, n, &f, err, sizeof(err)) != 0) {
			fprintf(stderr, "%s\n", err); /* written, but the reader refuses it */
			abort();
		}
		relief_file_close(f);
		free(img);
		relief_dem_finish(&d);
	}
	GDALClose(ds);
	return 0;
}
