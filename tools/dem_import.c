#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include "dem_import.h"
#include "format.h"
#include "pack.h"

__attribute__((format(printf, 3, 4)))
static int fail(char *err, size_t n, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(err, n, fmt, ap);
	va_end(ap);
	return -EINVAL;
}

static void quiet_handler(CPLErr cls, CPLErrorNum num, const char *msg)
{
	/* GDAL's messages are read back with CPLGetLastErrorMsg() where they matter. */
}

static char *xml_escape(const char *s)
{
	size_t n = 0;
	for (const char *p = s; *p; p++)
		n += (*p == '&' || *p == '<' || *p == '>' || *p == '"') ? 6 : 1;
	char *o = malloc(n + 1), *q = o;
	if (!o)
		return NULL;
	for (const char *p = s; *p; p++) {
		const char *r = *p == '&' ? "&amp;" : *p == '<' ? "&lt;" : *p == '>' ? "&gt;" : *p == '"' ? "&quot;" : NULL;
		if (r) {
			strcpy(q, r);
			q += strlen(r);
		} else {
			*q++ = *p;
		}
	}
	*q = '\0';
	return o;
}

static GDALDatasetH open_raw(const char *path, const struct dem_import_options *o, char *err, size_t n)
{
	size_t bytes;
	const char *type;
	if (!strcmp(o->raw_type, "int16")) {
		bytes = 2;
		type = "Int16";
	} else if (!strcmp(o->raw_type, "float32")) {
		bytes = 4;
		type = "Float32";
	} else {
		fail(err, n, "--raw-type '%s': expected int16 or float32", o->raw_type);
		return NULL;
	}
	struct stat st;
	if (stat(path, &st) < 0) {
		fail(err, n, "%s: %s", path, strerror(errno));
		return NULL;
	}
	uint64_t want = (uint64_t)o->raw_width * o->raw_height * bytes;
	if ((uint64_t)st.st_size != want) {
		fail(err, n, "%s is %lld bytes, but %ux%u %s samples need %llu", path, (long long)st.st_size,
		     o->raw_width, o->raw_height, o->raw_type, (unsigned long long)want);
		return NULL;
	}
	char *abs = realpath(path, NULL), *esc = abs ? xml_escape(abs) : NULL;
	free(abs);
	if (!esc) {
		fail(err, n, "%s: cannot resolve path", path);
		return NULL;
	}
	size_t len = strlen(esc) + 512;
	char *xml = malloc(len);
	if (!xml) {
		free(esc);
		return NULL;
	}
	snprintf(xml, len,
	         "<VRTDataset rasterXSize=\"%u\" rasterYSize=\"%u\"><VRTRasterBand dataType=\"%s\" band=\"1\" "
	         "subClass=\"VRTRawRasterBand\"><SourceFilename relativeToVRT=\"0\">%s</SourceFilename>"
	         "<ImageOffset>0</ImageOffset><PixelOffset>%zu</PixelOffset><LineOffset>%llu</LineOffset>"
	         "<ByteOrder>%s</ByteOrder></VRTRasterBand></VRTDataset>",
	         o->raw_width, o->raw_height, type, esc, bytes, (unsigned long long)o->raw_width * bytes,
	         o->raw_big_endian ? "MSB" : "LSB");
	GDALDatasetH ds = GDALOpen(xml, GA_ReadOnly);
	if (!ds)
		fail(err, n, "%s: GDAL cannot read it as raw %s: %s", path, o->raw_type, CPLGetLastErrorMsg());
	free(xml);
	free(esc);
	return ds;
}

/* Whether path starts with the .relief magic (a packed file given where a raster belongs). */
static bool is_relief_file(const char *path)
{
	char magic[sizeof(RELIEF_MAGIC) - 1];
	FILE *f = fopen(path, "rbe");
	bool yes = f && fread(magic, 1, sizeof(magic), f) == sizeof(magic) && !memcmp(magic, RELIEF_MAGIC, sizeof(magic));
	if (f)
		fclose(f);
	return yes;
}

/* Geographic raster: local equirectangular projection centred on the raster (docs). */
static int georef_geographic(const double gt[6], uint32_t w, uint32_t h, struct relief_dem *d, char *err, size_t n)
{
	double lon0 = gt[0] + gt[1] * w / 2.0, lat0 = gt[3] + gt[5] * h / 2.0;
	if (!(fabs(lat0) < 85.0))
		return fail(err, n, "geographic raster centred at latitude %.3f: too close to a pole for the local "
		            "equirectangular projection", lat0);
	const double rad = M_PI / 180.0, R = DEM_EARTH_RADIUS, c = cos(lat0 * rad);
	d->spacing_x = R * c * fabs(gt[1]) * rad;
	d->spacing_y = R * fabs(gt[5]) * rad;
	d->origin_x = R * c * (gt[0] + 0.5 * gt[1] - lon0) * rad;
	d->origin_y = R * (gt[3] + 0.5 * gt[5] - lat0) * rad;
	char proj[256];
	snprintf(proj, sizeof(proj), "+proj=eqc +lat_ts=%.10f +lat_0=%.10f +lon_0=%.10f +x_0=0 +y_0=0 +R=%.1f "
	         "+units=m +no_defs", lat0, lat0, lon0, R);
	/* Stored as the PROJ string: exact for this projection and a fifth of its WKT. */
	OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
	bool ok = OSRImportFromProj4(srs, proj) == OGRERR_NONE;
	OSRDestroySpatialReference(srs);
	if (!ok)
		return fail(err, n, "cannot build the local projection %s", proj);
	d->crs_wkt = strdup(proj);
	return d->crs_wkt ? 0 : -ENOMEM;
}

static int georef(GDALDatasetH ds, const struct dem_import_options *o, struct relief_dem *d, bool *flip_rows,
                  char *err, size_t n)
{
	double gt[6];
	bool has_gt = GDALGetGeoTransform(ds, gt) == CE_None &&
	              !(gt[0] == 0 && gt[1] == 1 && gt[2] == 0 && gt[3] == 0 && gt[4] == 0 && gt[5] == 1);
	for (int i = 0; i < 6 && has_gt; i++)
		if (!isfinite(gt[i]))
			return fail(err, n, "geotransform term %d is %g: not a finite number", i, gt[i]);
	OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
	*flip_rows = false;
	if (!has_gt) {
		if (!o->has_spacing)
			return fail(err, n, "the raster has no georeferencing: give --spacing METRES");
		if (!(o->spacing > 0) || !isfinite(o->spacing))
			return fail(err, n, "--spacing %g: must be a positive number of metres", o->spacing);
		d->spacing_x = d->spacing_y = o->spacing;
		d->origin_x = 0.0; /* south-west sample at (0, 0) */
		d->origin_y = (d->height - 1) * o->spacing;
		return 0;
	}
	if (o->has_spacing)
		return fail(err, n, "--spacing conflicts with the raster's own georeferencing");
	if (gt[2] != 0 || gt[4] != 0)
		return fail(err, n, "rotated or sheared rasters are not supported (geotransform terms %g, %g)", gt[2], gt[4]);
	if (!(gt[1] > 0) || gt[5] == 0)
		return fail(err, n, "unsupported pixel size (%g, %g): columns must run east", gt[1], gt[5]);
	if (gt[5] > 0) { /* south-up: read rows in reverse */
		*flip_rows = true;
		gt[3] += gt[5] * d->height;
		gt[5] = -gt[5];
	}
	if (srs && OSRIsGeographic(srs))
		return georef_geographic(gt, d->width, d->height, d, err, n);
	double unit = srs ? OSRGetLinearUnits(srs, NULL) : 1.0;
	if (!(unit > 0))
		unit = 1.0;
	d->spacing_x = gt[1] * unit;
	d->spacing_y = -gt[5] * unit;
	d->origin_x = (gt[0] + 0.5 * gt[1]) * unit;
	d->origin_y = (gt[3] + 0.5 * gt[5]) * unit;
	if (srs) {
		char *wkt = NULL;
		if (OSRExportToWkt(srs, &wkt) == OGRERR_NONE && wkt) {
			d->crs_wkt = strdup(wkt);
			CPLFree(wkt);
		}
	}
	return 0;
}

int dem_import_dataset(void *dataset, const char *path, const struct dem_import_options *o, struct relief_dem *out,
                       char *err, size_t n)
{
	GDALDatasetH ds = dataset;
	struct relief_dem d = { .source_units = o->units };
	int ret = 0;
	double *buf = NULL;
	uint8_t *gmask = NULL;
	int W = GDALGetRasterXSize(ds), H = GDALGetRasterYSize(ds), bands = GDALGetRasterCount(ds);
	if (W < 2 || H < 2 || W > 1 << 20 || H > 1 << 20 || (uint64_t)W * H > (1ull << 32)) {
		ret = fail(err, n, "%s: raster size %dx%d outside 2..1048576 per side and 2^32 samples", path, W, H);
		goto out;
	}
	if (bands < 1 || (o->encoding == DEM_ENCODING_TERRAIN_RGB && bands < 3)) {
		ret = fail(err, n, "%s: %d band(s); %s", path, bands,
		           o->encoding == DEM_ENCODING_TERRAIN_RGB ? "Terrain-RGB needs 3 (R, G, B)" : "need at least one");
		goto out;
	}
	if (o->encoding == DEM_ENCODING_TERRAIN_RGB && (o->has_scale || o->has_offset)) {
		ret = fail(err, n, "--scale and --offset do not apply to --encoding terrain-rgb");
		goto out;
	}
	d.width = (uint32_t)W;
	d.height = (uint32_t)H;
	size_t count = (size_t)W * H;
	d.heights = malloc(sizeof(float) * count);
	d.valid = calloc(count, 1);
	buf = malloc(sizeof(double) * count * (o->encoding == DEM_ENCODING_TERRAIN_RGB ? 3 : 1));
	gmask = malloc(count);
	if (!d.heights || !d.valid || !buf || !gmask) {
		ret = -ENOMEM;
		snprintf(err, n, "out of memory for %dx%d samples", W, H);
		goto out;
	}
	bool flip = false;
	if ((ret = georef(ds, o, &d, &flip, err, n)) < 0)
		goto out;
	/* What a .relief file may hold (format.h), for every sample, not only the origin, so
	 * that positions, extents and their differences stay finite and precise. */
	double far_x = d.origin_x + d.spacing_x * (W - 1), far_y = d.origin_y - d.spacing_y * (H - 1);
	if (!(d.spacing_x >= RELIEF_SPACING_MIN && d.spacing_x <= RELIEF_SPACING_MAX &&
	      d.spacing_y >= RELIEF_SPACING_MIN && d.spacing_y <= RELIEF_SPACING_MAX)) {
		ret = fail(err, n, "%s: sample spacing %g x %g m (from its geotransform or --spacing): outside [%g, %g] m",
		           path, d.spacing_x, d.spacing_y, RELIEF_SPACING_MIN, RELIEF_SPACING_MAX);
		goto out;
	}
	if (!(fabs(d.origin_x) <= RELIEF_MAX_COORD && fabs(d.origin_y) <= RELIEF_MAX_COORD &&
	      fabs(far_x) <= RELIEF_MAX_COORD && fabs(far_y) <= RELIEF_MAX_COORD)) {
		ret = fail(err, n, "%s: the raster spans x %g .. %g, y %g .. %g m (from its geotransform or --spacing): "
		           "beyond +-%g m", path, d.origin_x, far_x, far_y, d.origin_y, RELIEF_MAX_COORD);
		goto out;
	}

	GDALRasterBandH band = GDALGetRasterBand(ds, 1);
	int nb = o->encoding == DEM_ENCODING_TERRAIN_RGB ? 3 : 1;
	for (int b = 0; b < nb; b++)
		if (GDALRasterIO(GDALGetRasterBand(ds, b + 1), GF_Read, 0, 0, W, H, buf + (size_t)b * count, W, H,
		                 GDT_Float64, 0, 0) != CE_None) {
			ret = fail(err, n, "%s: read failed: %s", path, CPLGetLastErrorMsg());
			goto out;
		}
	/* GDAL's mask covers NoData values, alpha bands and per-dataset masks. */
	int mflags = GDALGetMaskFlags(band);
	bool use_gmask = !(mflags & GMF_ALL_VALID) && !o->has_nodata && o->encoding == DEM_ENCODING_HEIGHT;
	if (use_gmask && GDALRasterIO(GDALGetMaskBand(band), GF_Read, 0, 0, W, H, gmask, W, H, GDT_Byte, 0, 0) != CE_None) {
		ret = fail(err, n, "%s: reading the no-data mask failed: %s", path, CPLGetLastErrorMsg());
		goto out;
	}
	int has_scale = 0, has_offset = 0;
	double scale = o->has_scale ? o->scale : GDALGetRasterScale(band, &has_scale);
	double offset = o->has_offset ? o->offset : GDALGetRasterOffset(band, &has_offset);
	const double unit = o->units == RELIEF_UNITS_FEET ? 0.3048 : 1.0;
	GDALDataType type = GDALGetRasterDataType(band);
	bool raw16 = o->encoding == DEM_ENCODING_HEIGHT && (type == GDT_Int16 || type == GDT_UInt16);
	if (raw16 && !(d.raw16 = malloc(sizeof(int32_t) * count))) {
		ret = -ENOMEM;
		goto out;
	}
	uint64_t valid = 0;
	for (size_t y = 0; y < (size_t)H; y++) {
		size_t sy = flip ? (size_t)H - 1 - y : y;
		for (size_t x = 0; x < (size_t)W; x++) {
			size_t i = y * W + x, s = sy * W + x;
			double v = buf[s], h;
			bool ok;
			if (o->encoding == DEM_ENCODING_TERRAIN_RGB) {
				h = -10000.0 + (buf[s] * 65536.0 + buf[count + s] * 256.0 + buf[2 * count + s]) * 0.1;
				ok = true;
			} else {
				h = (v * scale + offset) * unit;
				ok = use_gmask ? gmask[s] != 0 : !(o->has_nodata && (v == o->nodata || (isnan(v) && isnan(o->nodata))));
			}
			if (ok && !(isfinite(h) && fabs(h) <= RELIEF_MAX_HEIGHT)) {
				if (d.dropped++ == 0) {
					d.dropped_col = (uint32_t)x;
					d.dropped_row = (uint32_t)sy;
				}
				ok = false;
			}
			d.valid[i] = ok;
			d.heights[i] = ok ? (float)h : 0.0f;
			if (raw16)
				d.raw16[i] = (int32_t)v;
			valid += ok;
		}
	}
	if (!valid) {
		if (d.dropped)
			ret = fail(err, n, "%s: every sample is no-data (%llu not finite or beyond %g m)", path,
			           (unsigned long long)d.dropped, RELIEF_MAX_HEIGHT);
		else
			ret = fail(err, n, "%s: every sample is no-data", path);
		ret = -ENODATA;
		goto out;
	}
	*out = d;
	memset(&d, 0, sizeof(d));
out:
	relief_dem_finish(&d);
	free(buf);
	free(gmask);
	return ret;
}

void dem_report_dropped(const char *cmd, const char *path, const struct relief_dem *d)
{
	if (d->dropped)
		fprintf(stderr, "relief %s: %s: %llu sample(s) not finite or beyond %g m (one at column %u, row %u) "
		        "stored as no-data\n", cmd, path, (unsigned long long)d->dropped, RELIEF_MAX_HEIGHT, d->dropped_col,
		        d->dropped_row);
}

/* What packing raster d at `patch` samples a side holds at peak, in bytes: the quantised
 * levels' windows around the data (about 6 bytes per finest window sample), the raster's
 * arrays (about 12 per sample), the per-patch records of the whole tree (about 100 per
 * patch) and 64 MB for the program, as measured, rounded up (docs/format.md, "Known
 * limits"); with the parts it comes from. */
struct pack_need {
	double side;         /* the level grid's side */
	double window[2];    /* the finest level's quantised window (pack.c, pack_windows()) */
	double quantised;    /* samples in every level's window (relief_pack_quantised_samples()) */
	double patches;      /* in the tree, EMPTY ones included */
	double entries;      /* with an index entry (the packer's per-patch records) */
	double per_sample;   /* bytes per raster sample */
	double bytes;
};

static struct pack_need pack_need(const struct relief_dem *d, uint32_t patch)
{
	struct pack_need n;
	uint32_t levels = relief_layout_levels_for(patch, d->width, d->height); /* < 64 */
	n.side = ldexp((double)(patch - 1), (int)levels - 1) + 1;
	const double dims[2] = { d->width, d->height };
	for (int a = 0; a < 2; a++)
		n.window[a] = fmin(n.side, ceil(dims[a] / (patch - 1)) * (patch - 1) + 3);
	n.patches = (ldexp(1.0, 2 * (int)levels) - 1) / 3;
	n.entries = n.patches;
	n.quantised = 4.0 / 3.0 * n.window[0] * n.window[1];
	struct relief_layout lay;
	if (levels <= RELIEF_MAX_LEVELS && relief_layout_init(&lay, patch, levels, 2, 1.0) == 0) {
		/* deeper trees are refused by the packer anyway */
		struct relief_header h = { .version = RELIEF_FORMAT_VERSION, .patch_size = patch, .levels = levels,
		                           .width = d->width, .height = d->height };
		relief_index_windows(&h);
		n.entries = h.index_records;
		n.quantised = (double)relief_pack_quantised_samples(&lay, d->width, d->height);
	}
	/* Calibrated (December 2026): a 1048576 x 2 strip 0.79 GB measured, 8193^2 1.16 GB.
	 * With no-data the packer also holds the fill and its rings (common/fill.h): 6 more. */
	const size_t samples = (size_t)d->width * d->height;
	n.per_sample = d->valid && memchr(d->valid, 0, samples) ? 18.0 : 12.0;
	n.bytes = 5.0 * n.quantised + n.per_sample * dims[0] * dims[1] + 100.0 * n.entries + 64e6;
	return n;
}

void dem_pack_explain(const char *cmd, const char *path, const struct relief_dem *d, uint32_t patch, const char *why,
                      double have, const char *who)
{
	struct pack_need n = pack_need(d, patch);
	char where[96] = "";
	if (have > 0)
		snprintf(where, sizeof(where), " where %s %.1f GB", who, have / 1e9);
	fprintf(stderr,
	        "relief %s: %s: %s: this %u x %u raster makes a quadtree of %.0f patches (%.0f of them over the "
	        "raster) over a %.0f x %.0f grid, whose levels quantise %.0f samples around the data (the finest "
	        "%.0f x %.0f), and packing that holds about %.1f GB (5 bytes per quantised sample, %.0f per raster "
	        "sample, 100 per patch over the raster)%s; see docs/format.md, \"Known limits\"\n",
	        cmd, path, why, d->width, d->height, n.patches, n.entries, n.side, n.side, n.quantised, n.window[0],
	        n.window[1], n.bytes / 1e9, n.per_sample, where);
}

bool dem_pack_fits(const char *cmd, const char *path, const struct relief_dem *d, uint32_t patch)
{
	double need = pack_need(d, patch).bytes, have = INFINITY;
	const char *who = "this machine has";
	long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
	if (pages > 0 && page > 0)
		have = (double)pages * (double)page;
	struct rlimit rl; /* an address-space limit (ulimit -v) below that binds first */
	if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && (double)rl.rlim_cur < have) {
		have = (double)rl.rlim_cur;
		who = "this process may use";
	}
	if (need <= have)
		return true;
	dem_pack_explain(cmd, path, d, patch, "too large to pack here", have, who);
	return false;
}

int dem_import(const char *path, const struct dem_import_options *o, struct relief_dem *out, char *err, size_t n)
{
	GDALAllRegister();
	CPLPushErrorHandler(quiet_handler);
	CPLErrorReset();
	int ret = 0;
	GDALDatasetH ds = NULL;
	if (o->raw_type) {
		ds = open_raw(path, o, err, n);
		if (!ds)
			ret = -EINVAL;
	} else {
		struct stat st;
		if (stat(path, &st) < 0) {
			ret = -errno;
			snprintf(err, n, "%s: %s", path, strerror(errno));
		} else if (!(ds = GDALOpenEx(path, GDAL_OF_RASTER | GDAL_OF_READONLY, NULL, NULL, NULL))) {
			const char *why = CPLGetLastErrorMsg();
			if (is_relief_file(path))
				why = "it is a .relief file: give the elevation raster it was packed from";
			ret = fail(err, n, "%s: not a raster GDAL can read%s%s%s", path, *why ? " (" : "", why, *why ? ")" : "");
		}
	}
	if (ds) {
		ret = dem_import_dataset(ds, path, o, out, err, n);
		GDALClose(ds);
	}
	CPLPopErrorHandler();
	return ret;
}
