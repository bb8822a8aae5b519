/* Loading the bundled real DEMs with the options documented in tests/data/README.md. */
#pragma once

#include <string.h>

#include "dem_import.h"
#include "test_util.h"

enum test_dem { DEM_PUGET, DEM_ALPS, DEM_LUX, DEM_COUNT };

static inline const char *test_dem_name(enum test_dem d)
{
	return d == DEM_PUGET ? "ps_height_1k.png" : d == DEM_ALPS ? "alps-montblanc.png" : "luxembourg_elev.tif";
}

static inline void test_dem_options(enum test_dem d, struct dem_import_options *o)
{
	memset(o, 0, sizeof(*o));
	if (d == DEM_PUGET) {
		o->has_scale = o->has_spacing = true;
		o->scale = 0.1;
		o->spacing = 160.0;
	} else if (d == DEM_ALPS) {
		o->has_scale = o->has_offset = o->has_spacing = true;
		o->scale = 4356.0 / 65535.0;
		o->offset = 454.0;
		o->spacing = 92.7;
	}
}

static inline void test_dem_load(enum test_dem d, struct relief_dem *dem)
{
	struct dem_import_options o;
	test_dem_options(d, &o);
	char err[512] = "";
	int ret = dem_import(test_data(test_dem_name(d)), &o, dem, err, sizeof(err));
	if (ret < 0)
		fail_msg("import %s: %s", test_dem_name(d), err);
}
