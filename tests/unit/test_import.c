/* DEM import through GDAL: every supported encoding, georeferencing rules, units, no-data,
 * and the errors for bad inputs. Inputs other than the bundled DEMs are written here with
 * GDAL or by hand into a temporary folder. */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <string.h>
#include <unistd.h>

#include <gdal.h>
#include <ogr_srs_api.h>

#include "../data_load.h"
#include "format.h"

static char dir[] = "/tmp/relief-import-XXXXXX";

static int setup(void **state)
{
	assert_non_null(mkdtemp(dir));
	GDALAllRegister();
	return 0;
}

static int teardown(void **state)
{
	char cmd[128];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	return system(cmd) == 0 ? 0 : -1;
}

static const char *tmp(const char *name)
{
	static char buf[2][256];
	static int slot;
	slot ^= 1;
	snprintf(buf[slot], sizeof(buf[slot]), "%s/%s", dir, name);
	return buf[slot];
}

static int import(const char *path, const struct dem_import_options *o, struct relief_dem *d, char *err)
{
	err[0] = '\0';
	return dem_import(path, o, d, err, 512);
}

static void test_puget_png(void **state)
{
	struct relief_dem d;
	test_dem_load(DEM_PUGET, &d);
	assert_int_equal(d.width, 1025);
	assert_int_equal(d.height, 1025);
	size_t zeros = 0;
	float mx = 0;
	for (size_t i = 0; i < 1025 * 1025; i++) {
		assert_true(d.valid[i]); /* sea level is a height, not no-data */
		zeros += d.heights[i] == 0.0f;
		mx = fmaxf(mx, d.heights[i]);
	}
	assert_int_equal(zeros, 39421);
	assert_true(fabsf(mx - 4379.8f) < 1e-3f);
	assert_non_null(d.raw16);
	/* Unreferenced: the south-west sample sits at (0, 0). */
	assert_true(d.origin_x == 0.0 && d.origin_y == 1024 * 160.0);
	assert_true(d.spacing_x == 160.0 && d.spacing_y == 160.0);
	assert_true(d.crs_wkt == NULL);
	relief_dem_finish(&d);
}

static void test_alps_normalised(void **state)
{
	struct relief_dem d;
	test_dem_load(DEM_ALPS, &d);
	float mn = 1e9f, mx = -1e9f;
	for (size_t i = 0; i < (size_t)d.width * d.height; i++) {
		mn = fminf(mn, d.heights[i]);
		mx = fmaxf(mx, d.heights[i]);
	}
	assert_true(mn >= 453.9f && mx <= 4810.1f && mx > 4700.0f);
	relief_dem_finish(&d);
}

/* Geographic: local equirectangular projection; 30 arc-second pixels at ~49.8 N. */
static void test_luxembourg_geographic(void **state)
{
	struct relief_dem d;
	test_dem_load(DEM_LUX, &d);
	const double arc = 30.0 / 3600.0 * M_PI / 180.0 * DEM_EARTH_RADIUS; /* 926.6 m */
	assert_true(fabs(d.spacing_y - arc) < 0.1);
	assert_true(d.spacing_x > 0.62 * arc && d.spacing_x < 0.66 * arc); /* cos(49.8) = 0.645 */
	assert_non_null(strstr(d.crs_wkt, "+proj=eqc"));
	/* Centred: the middle of the raster is near (0, 0). */
	assert_true(fabs(d.origin_x + (d.width - 1) / 2.0 * d.spacing_x) < d.spacing_x);
	assert_true(fabs(d.origin_y - (d.height - 1) / 2.0 * d.spacing_y) < d.spacing_y);
	relief_dem_finish(&d);
}

static void write_file(const char *path, const void *data, size_t n)
{
	FILE *f = fopen(path, "wb");
	assert_non_null(f);
	assert_int_equal(fwrite(data, 1, n, f), n);
	fclose(f);
}

static void test_raw(void **state)
{
	struct relief_dem png;
	test_dem_load(DEM_PUGET, &png);
	size_t n = 1025 * 1025;
	int16_t *le = malloc(2 * n);
	uint8_t *be = malloc(2 * n);
	float *f32 = malloc(4 * n);
	for (size_t i = 0; i < n; i++) {
		le[i] = (int16_t)png.raw16[i];
		be[2 * i] = (uint8_t)((uint16_t)le[i] >> 8);
		be[2 * i + 1] = (uint8_t)le[i];
		f32[i] = png.heights[i];
	}
	write_file(tmp("le.raw"), le, 2 * n);
	write_file(tmp("be.raw"), be, 2 * n);
	write_file(tmp("f.raw"), f32, 4 * n);
	struct dem_import_options o = { .raw_width = 1025, .raw_height = 1025, .raw_type = "int16",
	                                 .has_scale = true, .scale = 0.1, .has_spacing = true, .spacing = 160 };
	/* The PNG is UInt16 (up to 43798): as int16 the tallest samples wrap, as they would
	 * for a user who exported them that way. */
	float *want = malloc(4 * n);
	for (size_t i = 0; i < n; i++)
		want[i] = (float)(le[i] * 0.1);
	struct relief_dem d;
	char err[512];
	assert_int_equal(import(tmp("le.raw"), &o, &d, err), 0);
	assert_memory_equal(d.heights, want, 4 * n);
	relief_dem_finish(&d);
	o.raw_big_endian = true;
	assert_int_equal(import(tmp("be.raw"), &o, &d, err), 0);
	assert_memory_equal(d.heights, want, 4 * n);
	relief_dem_finish(&d);
	free(want);
	struct dem_import_options of = { .raw_width = 1025, .raw_height = 1025, .raw_type = "float32",
	                                  .has_spacing = true, .spacing = 160 };
	assert_int_equal(import(tmp("f.raw"), &of, &d, err), 0);
	assert_memory_equal(d.heights, png.heights, 4 * n);
	assert_null(d.raw16);
	relief_dem_finish(&d);
	/* A size that does not match the file is refused with both numbers. */
	o.raw_width = 1024;
	assert_int_equal(import(tmp("le.raw"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "2101250 bytes"));
	free(le);
	free(be);
	free(f32);
	relief_dem_finish(&png);
}

/* Writes a dataset through GDAL's MEM driver then CreateCopy into `driver`. */
static void gdal_write(const char *driver, const char *path, int w, int h, int bands, GDALDataType type,
                       const void *data, const double *gt, const char *srs_input, const double *nodata)
{
	GDALDatasetH mem = GDALCreate(GDALGetDriverByName("MEM"), "", w, h, bands, type, NULL);
	int sz = GDALGetDataTypeSizeBytes(type);
	for (int b = 0; b < bands; b++) {
		GDALRasterBandH band = GDALGetRasterBand(mem, b + 1);
		assert_int_equal(GDALRasterIO(band, GF_Write, 0, 0, w, h, (uint8_t *)data + (size_t)b * w * h * sz, w, h,
		                              type, 0, 0), CE_None);
		if (nodata)
			GDALSetRasterNoDataValue(band, *nodata);
	}
	if (gt)
		GDALSetGeoTransform(mem, (double *)gt);
	if (srs_input) {
		OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
		assert_int_equal(OSRSetFromUserInput(srs, srs_input), OGRERR_NONE);
		GDALSetSpatialRef(mem, srs);
		OSRDestroySpatialReference(srs);
	}
	GDALDatasetH out = GDALCreateCopy(GDALGetDriverByName(driver), path, mem, FALSE, NULL, NULL, NULL);
	assert_non_null(out);
	GDALClose(out);
	GDALClose(mem);
}

/* Heights that cannot be heights (not finite, or beyond RELIEF_MAX_HEIGHT after scale and
 * units) are no-data, and counted with one of their positions so that the packer can say
 * so; the limit itself is a height; a declared NaN no-data is not counted. */
static void test_impossible_heights(void **state)
{
	enum { W = 8, H = 4 };
	float v[W * H];
	for (int i = 0; i < W * H; i++)
		v[i] = 100.0f + (float)i;
	v[0 * W + 1] = NAN;
	v[0 * W + 2] = INFINITY;
	v[1 * W + 3] = 1e30f;
	v[1 * W + 4] = -1000001.0f;
	v[2 * W + 5] = 1e6f;  /* the limit: kept */
	v[2 * W + 6] = -1e6f; /* kept */
	write_file(tmp("bad.raw"), v, sizeof(v));
	struct dem_import_options o = { .raw_width = W, .raw_height = H, .raw_type = "float32",
	                                 .has_spacing = true, .spacing = 30 };
	struct relief_dem d;
	char err[512];
	assert_int_equal(import(tmp("bad.raw"), &o, &d, err), 0);
	assert_int_equal(d.dropped, 4);
	assert_int_equal(d.dropped_col, 1);
	assert_int_equal(d.dropped_row, 0);
	for (int i = 0; i < W * H; i++) {
		bool bad = i == 1 || i == 2 || i == W + 3 || i == W + 4;
		assert_int_equal(d.valid[i], !bad);
		if (!bad)
			assert_true(d.heights[i] == v[i]);
	}
	relief_dem_finish(&d);
	/* NaN declared as no-data: only the other three are counted. */
	o.has_nodata = true;
	o.nodata = NAN;
	assert_int_equal(import(tmp("bad.raw"), &o, &d, err), 0);
	assert_int_equal(d.dropped, 3);
	assert_int_equal(d.dropped_col, 2);
	relief_dem_finish(&d);
	/* The same in a GeoTIFF whose NoData is NaN (GDAL's mask). */
	const double nan_nodata = NAN, gt[6] = { 500000, 30, 0, 5000000, 0, -30 };
	gdal_write("GTiff", tmp("bad.tif"), W, H, 1, GDT_Float32, v, gt, "EPSG:32633", &nan_nodata);
	struct dem_import_options ot = { 0 };
	assert_int_equal(import(tmp("bad.tif"), &ot, &d, err), 0);
	assert_int_equal(d.dropped, 3);
	relief_dem_finish(&d);
	/* The limit applies to the scaled height: 20,000 x 100 m is beyond it. */
	int16_t q[W * H];
	for (int i = 0; i < W * H; i++)
		q[i] = (int16_t)(i == 9 ? 20000 : 10 * i);
	write_file(tmp("scaled.raw"), q, sizeof(q));
	struct dem_import_options os = { .raw_width = W, .raw_height = H, .raw_type = "int16", .has_scale = true,
	                                  .scale = 100, .has_spacing = true, .spacing = 30 };
	assert_int_equal(import(tmp("scaled.raw"), &os, &d, err), 0);
	assert_int_equal(d.dropped, 1);
	assert_int_equal(d.dropped_col, 1);
	assert_int_equal(d.dropped_row, 1);
	assert_false(d.valid[9]);
	relief_dem_finish(&d);
	/* Nothing left: refused, saying why. */
	for (int i = 0; i < W * H; i++)
		v[i] = i % 2 ? NAN : 3e6f;
	write_file(tmp("none.raw"), v, sizeof(v));
	o.has_nodata = false;
	assert_int_equal(import(tmp("none.raw"), &o, &d, err), -ENODATA);
	assert_non_null(strstr(err, "every sample is no-data (32 not finite or beyond 1e+06 m)"));
}


static void test_terrain_rgb(void **state)
{
	enum { W = 40, H = 30 };
	uint8_t rgb[3][H][W];
	double want[H][W];
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++) {
			want[y][x] = -50.0 + 10.0 * x + 0.1 * y; /* below sea level too */
			uint32_t v = (uint32_t)llround((want[y][x] + 10000.0) * 10.0);
			rgb[0][y][x] = (uint8_t)(v >> 16);
			rgb[1][y][x] = (uint8_t)(v >> 8);
			rgb[2][y][x] = (uint8_t)v;
		}
	gdal_write("PNG", tmp("rgb.png"), W, H, 3, GDT_Byte, rgb, NULL, NULL, NULL);
	struct dem_import_options o = { .encoding = DEM_ENCODING_TERRAIN_RGB, .has_spacing = true, .spacing = 30 };
	struct relief_dem d;
	char err[512];
	assert_int_equal(import(tmp("rgb.png"), &o, &d, err), 0);
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++)
			assert_true(fabs(d.heights[y * W + x] - want[y][x]) < 1e-3);
	relief_dem_finish(&d);
	o.has_scale = true;
	o.scale = 2;
	assert_int_equal(import(tmp("rgb.png"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "terrain-rgb"));
	/* A grey PNG is not Terrain-RGB. */
	o.has_scale = false;
	assert_int_equal(import(test_data("ps_height_1k.png"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "3"));
}

/* SRTM .hgt: big-endian int16, 1201 x 1201, named after its south-west corner. */
static void test_hgt(void **state)
{
	enum { N = 1201 };
	uint8_t *buf = malloc(2 * N * N);
	size_t holes = 0;
	for (int y = 0; y < N; y++)
		for (int x = 0; x < N; x++) {
			int16_t v = (int16_t)(200 + x / 4 + y / 8);
			if ((x - 600) * (x - 600) + (y - 300) * (y - 300) < 400) {
				v = -32768;
				holes++;
			}
			buf[2 * (y * N + x)] = (uint8_t)((uint16_t)v >> 8);
			buf[2 * (y * N + x) + 1] = (uint8_t)v;
		}
	write_file(tmp("N45E006.hgt"), buf, 2 * N * N);
	free(buf);
	struct dem_import_options o = { 0 };
	struct relief_dem d;
	char err[512];
	assert_int_equal(import(tmp("N45E006.hgt"), &o, &d, err), 0);
	size_t invalid = 0;
	for (size_t i = 0; i < (size_t)N * N; i++)
		invalid += !d.valid[i];
	assert_int_equal(invalid, holes);
	assert_true(fabs(d.heights[0] - 200.0f) < 1e-6);
	const double arc3 = 3.0 / 3600.0 * M_PI / 180.0 * DEM_EARTH_RADIUS; /* 92.66 m */
	assert_true(fabs(d.spacing_y - arc3) < 0.01);
	assert_true(fabs(d.spacing_x - arc3 * cos(45.5 * M_PI / 180.0)) < 0.05);
	relief_dem_finish(&d);
}

/* Projected CRS: coordinates stay (UTM northings in the millions), pixel centres. South-up
 * rasters are flipped to north-up. Feet become metres. */
static void test_projected_and_units(void **state)
{
	enum { W = 8, H = 6 };
	int16_t v[H][W];
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++)
			v[y][x] = (int16_t)(100 * y + x);
	double gt[6] = { 500000.0, 30.0, 0, 5000000.0, 0, -30.0 };
	gdal_write("GTiff", tmp("utm.tif"), W, H, 1, GDT_Int16, v, gt, "EPSG:32632", NULL);
	struct dem_import_options o = { .units = RELIEF_UNITS_FEET };
	struct relief_dem d;
	char err[512];
	assert_int_equal(import(tmp("utm.tif"), &o, &d, err), 0);
	assert_true(d.origin_x == 500015.0 && d.origin_y == 4999985.0);
	assert_true(d.spacing_x == 30.0 && d.spacing_y == 30.0);
	assert_true(fabs(d.heights[1 * W + 2] - 102 * 0.3048) < 1e-4);
	assert_non_null(strstr(d.crs_wkt, "32632"));
	relief_dem_finish(&d);
	double gt_up[6] = { 500000.0, 30.0, 0, 4999820.0, 0, 30.0 }; /* row 0 is the southern row */
	gdal_write("GTiff", tmp("southup.tif"), W, H, 1, GDT_Int16, v, gt_up, "EPSG:32632", NULL);
	o.units = RELIEF_UNITS_METRES;
	assert_int_equal(import(tmp("southup.tif"), &o, &d, err), 0);
	assert_true(d.origin_y == 4999985.0);
	assert_true(d.heights[0] == 500.0f); /* the last source row is now the first */
	relief_dem_finish(&d);
	/* Georeferenced input refuses --spacing. */
	o.has_spacing = true;
	o.spacing = 10;
	assert_int_equal(import(tmp("utm.tif"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "--spacing"));
}

static void test_errors_name_the_problem(void **state)
{
	struct dem_import_options o = { 0 };
	struct relief_dem d;
	char err[512];
	assert_true(import(test_data("ps_height_1k.png"), &o, &d, err) < 0);
	assert_non_null(strstr(err, "--spacing"));
	assert_int_equal(import(tmp("missing.tif"), &o, &d, err), -ENOENT);
	assert_non_null(strstr(err, "missing.tif"));
	write_file(tmp("junk.tif"), "not a tiff at all", 17);
	assert_int_equal(import(tmp("junk.tif"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "junk.tif"));
	write_file(tmp("packed.png"), "RELIEF\x1a\n\x04\0\0\0", 12); /* a .relief header's start */
	assert_int_equal(import(tmp("packed.png"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "it is a .relief file"));
	/* All no-data. */
	int16_t v[4][4];
	for (int i = 0; i < 16; i++)
		v[i / 4][i % 4] = -9999;
	double nd = -9999, gt[6] = { 0, 1, 0, 4, 0, -1 };
	gdal_write("GTiff", tmp("empty.tif"), 4, 4, 1, GDT_Int16, v, gt, "EPSG:32632", &nd);
	assert_int_equal(import(tmp("empty.tif"), &o, &d, err), -ENODATA);
	assert_non_null(strstr(err, "no-data"));
	/* --nodata on the command line. */
	v[1][1] = 7;
	gdal_write("GTiff", tmp("some.tif"), 4, 4, 1, GDT_Int16, v, gt, "EPSG:32632", NULL);
	o.has_nodata = true;
	o.nodata = -9999;
	assert_int_equal(import(tmp("some.tif"), &o, &d, err), 0);
	size_t valid = 0;
	for (int i = 0; i < 16; i++)
		valid += d.valid[i];
	assert_int_equal(valid, 1);
	relief_dem_finish(&d);
	o.has_nodata = false;
	/* A geotransform with a term that is not finite, a spacing the format cannot hold, or
	 * samples beyond RELIEF_MAX_COORD is refused by name (the first case was imported with
	 * a NaN origin, the 1e-9 m spacing packed into a file the reader refuses). */
	const struct {
		double gt[6];
		const char *why;
	} bad[] = {
		{ { NAN, 1, 0, 4, 0, -1 }, "geotransform term 0 is nan" },
		{ { 0, 1, 0, 4, 0, NAN }, "geotransform term 5 is nan" },
		/* GeoTIFF stores a tie point and a pixel scale: which term reads back non-finite is
		 * the driver's business. */
		{ { 0, INFINITY, 0, 4, 0, -1 }, "not a finite number" },
		{ { 0, 1, 0, -INFINITY, 0, -1 }, "not a finite number" },
		{ { 0, 1e300, 0, 4, 0, -1 }, "sample spacing 1e+300 x 1 m" },
		{ { 0, 1e-9, 0, 4, 0, -1e-9 }, "outside [1e-06, 1e+07] m" },
		{ { -2e9, 1, 0, 4, 0, -1 }, "beyond +-1e+09 m" },
		{ { 999999000, 1e6, 0, 4, 0, -1 }, "beyond +-1e+09 m" }, /* the origin within, the east edge not */
	};
	for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
		gdal_write("GTiff", tmp("badgt.tif"), 4, 4, 1, GDT_Int16, v, bad[k].gt, "EPSG:32632", NULL);
		assert_int_equal(import(tmp("badgt.tif"), &o, &d, err), -EINVAL);
		if (!strstr(err, bad[k].why))
			fail_msg("case %zu: '%s' does not say '%s'", k, err, bad[k].why);
	}
	o.has_spacing = true; /* and --spacing on an unreferenced raster */
	o.spacing = 1e300;
	assert_int_equal(import(test_data("ps_height_1k.png"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "outside [1e-06, 1e+07] m"));
	o.spacing = 2e6; /* 1025 samples of 2,000 km */
	assert_int_equal(import(test_data("ps_height_1k.png"), &o, &d, err), -EINVAL);
	assert_non_null(strstr(err, "beyond +-1e+09 m"));
}

/* A wide raster (8192 x 600) north-up and south-up, with one no-data sample: every sample
 * where it belongs, rows flipped for south-up. (Written to check a reader that took the
 * raster in strips of rows; that reader was not kept: it lowered the import's memory but
 * not `relief pack`'s peak, which the packer sets, and raised it by 18 MB through GDAL's
 * block cache on a 4000 x 4000 raw raster.) */
static void test_wide_raster_rows(void **state)
{
	enum { W = 8192, H = 600 };
	int16_t *v = malloc(sizeof(int16_t) * W * H);
	for (int i = 0; i < W * H; i++)
		v[i] = (int16_t)((i % W) * 7 % 1000 + (i / W) * 3);
	v[550 * W + 17] = -9999;
	for (int south_up = 0; south_up < 2; south_up++) {
		GDALDatasetH mem = GDALCreate(GDALGetDriverByName("MEM"), "", W, H, 1, GDT_Int16, NULL);
		GDALRasterBandH band = GDALGetRasterBand(mem, 1);
		assert_int_equal(GDALRasterIO(band, GF_Write, 0, 0, W, H, v, W, H, GDT_Int16, 0, 0), CE_None);
		GDALSetRasterNoDataValue(band, -9999);
		double gt[6] = { 500000, 30, 0, south_up ? 5000000 : 5000000 + 30.0 * H, 0, south_up ? 30 : -30 };
		GDALSetGeoTransform(mem, gt);
		struct dem_import_options o = { 0 };
		struct relief_dem d;
		char err[512];
		assert_int_equal(dem_import_dataset(mem, "strips", &o, &d, err, sizeof(err)), 0);
		GDALClose(mem);
		for (int y = 0; y < H; y++) /* output rows run north to south */
			for (int x = 0; x < W; x++) {
				int sy = south_up ? H - 1 - y : y, i = y * W + x;
				bool hole = sy == 550 && x == 17;
				if (d.valid[i] != !hole || (!hole && d.heights[i] != (float)v[sy * W + x]))
					fail_msg("south-up %d: sample %d,%d: valid %d height %g, source %d", south_up, x, y, d.valid[i],
					         d.heights[i], v[sy * W + x]);
			}
		assert_true(d.origin_y == 5000000 + 30.0 * H - 15);
		relief_dem_finish(&d);
	}
	free(v);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_puget_png),
		cmocka_unit_test(test_alps_normalised),
		cmocka_unit_test(test_luxembourg_geographic),
		cmocka_unit_test(test_raw),
		cmocka_unit_test(test_impossible_heights),
		cmocka_unit_test(test_terrain_rgb),
		cmocka_unit_test(test_hgt),
		cmocka_unit_test(test_projected_and_units),
		cmocka_unit_test(test_errors_name_the_problem),
		cmocka_unit_test(test_wide_raster_rows),
	};
	return cmocka_run_group_tests(tests, setup, teardown);
}
