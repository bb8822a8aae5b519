/* relief unpack's GeoTIFF, read back through GDAL: georeferencing at every level, the CRS,
 * NaN for no-data at the finest level, and heights within each level's tolerance. */
#include <math.h>
#include <string.h>
#include <unistd.h>

#include <gdal.h>
#include <ogr_srs_api.h>

#include "../data_load.h"

static void run(const char *cmd)
{
	int r = system(cmd);
	if (r != 0)
		fail_msg("'%s' exited with %d", cmd, r);
}

static void test_geotiff_roundtrip(void **state)
{
	char dir[] = "/tmp/relief-unpack-XXXXXX", cmd[1024];
	assert_non_null(mkdtemp(dir));
	snprintf(cmd, sizeof(cmd), "%s pack %s %s/l.relief -t 0.5 --patch 65 -q", RELIEF_BIN,
	         test_data("luxembourg_elev.tif"), dir);
	run(cmd);
	struct relief_dem dem;
	test_dem_load(DEM_LUX, &dem);
	GDALAllRegister();
	for (int level = 0; level < 2; level++) {
		snprintf(cmd, sizeof(cmd), "%s unpack %s/l.relief %s/l%d.tif --level %d", RELIEF_BIN, dir, dir, level,
		         level);
		run(cmd);
		snprintf(cmd, sizeof(cmd), "%s/l%d.tif", dir, level);
		GDALDatasetH ds = GDALOpen(cmd, GA_ReadOnly);
		assert_non_null(ds);
		int step = 1 << (1 - level);
		int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds);
		assert_int_equal(w, (95 - 1) / step + 1);
		assert_int_equal(h, (90 - 1) / step + 1);
		double gt[6];
		assert_int_equal(GDALGetGeoTransform(ds, gt), CE_None);
		/* Pixel centre of (0, 0) is the DEM's origin; pixels grow with the level's step. */
		assert_true(fabs(gt[0] + 0.5 * gt[1] - dem.origin_x) < 1e-6);
		assert_true(fabs(gt[3] + 0.5 * gt[5] - dem.origin_y) < 1e-6);
		assert_true(fabs(gt[1] - dem.spacing_x * step) < 1e-9);
		assert_true(fabs(gt[5] + dem.spacing_y * step) < 1e-9);
		OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
		assert_non_null(srs);
		assert_true(OSRIsProjected(srs));
		float *v = malloc(sizeof(float) * w * h);
		assert_int_equal(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 0, 0, w, h, v, w, h, GDT_Float32, 0, 0),
		                 CE_None);
		double delta = 0.5 * (level == 0 ? 2 : 1);
		for (int y = 0; y < h; y++)
			for (int x = 0; x < w; x++) {
				size_t o = (size_t)y * step * 95 + (size_t)x * step;
				if (!dem.valid[o]) {
					/* at the finest level no-data; above it data within half the level's
					 * spacing makes a sample valid (test_pack's test_nodata_stays_nodata) */
					if (level == 1)
						assert_true(isnan(v[y * w + x]));
					continue;
				}
				/* float32 output adds at most half an ulp of ~500 m */
				assert_true(fabs(v[y * w + x] - dem.heights[o]) <= delta + 3e-5);
			}
		free(v);
		GDALClose(ds);
	}
	relief_dem_finish(&dem);
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	run(cmd);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_geotiff_roundtrip),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
