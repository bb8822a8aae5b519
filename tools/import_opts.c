#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "format.h"
#include "import_opts.h"

bool import_option(const char *cmd, int c, const char *arg, struct dem_import_options *o)
{
	switch (c) {
	case OPT_ENCODING:
		if (!strcmp(arg, "height"))
			o->encoding = DEM_ENCODING_HEIGHT;
		else if (!strcmp(arg, "terrain-rgb"))
			o->encoding = DEM_ENCODING_TERRAIN_RGB;
		else {
			fprintf(stderr, "relief %s: --encoding: '%s' is not height or terrain-rgb\n", cmd, arg);
			return false;
		}
		return true;
	case OPT_SCALE:
		o->has_scale = true;
		if (!cli_parse_double(cmd, "--scale", arg, &o->scale))
			return false;
		if (o->scale == 0) {
			fprintf(stderr, "relief %s: --scale: must not be 0\n", cmd);
			return false;
		}
		return true;
	case OPT_OFFSET:
		o->has_offset = true;
		return cli_parse_double(cmd, "--offset", arg, &o->offset);
	case OPT_SPACING:
		o->has_spacing = true;
		if (!cli_parse_double(cmd, "--spacing", arg, &o->spacing))
			return false;
		if (!(o->spacing > 0)) {
			fprintf(stderr, "relief %s: --spacing: must be a positive number of metres\n", cmd);
			return false;
		}
		return true;
	case OPT_UNITS:
		if (!strcmp(arg, "m"))
			o->units = RELIEF_UNITS_METRES;
		else if (!strcmp(arg, "ft"))
			o->units = RELIEF_UNITS_FEET;
		else {
			fprintf(stderr, "relief %s: --units: '%s' is not m or ft\n", cmd, arg);
			return false;
		}
		return true;
	case OPT_NODATA:
		o->has_nodata = true;
		return cli_parse_double(cmd, "--nodata", arg, &o->nodata);
	case OPT_RAW_SIZE:
		return cli_parse_size(cmd, "--raw-size", arg, &o->raw_width, &o->raw_height);
	case OPT_RAW_TYPE:
		if (strcmp(arg, "int16") && strcmp(arg, "float32")) {
			fprintf(stderr, "relief %s: --raw-type: '%s' is not int16 or float32\n", cmd, arg);
			return false;
		}
		o->raw_type = arg;
		return true;
	case OPT_RAW_ENDIAN:
		if (strcmp(arg, "little") && strcmp(arg, "big")) {
			fprintf(stderr, "relief %s: --raw-endian: '%s' is not little or big\n", cmd, arg);
			return false;
		}
		o->raw_big_endian = !strcmp(arg, "big");
		return true;
	}
	return false;
}

bool import_options_check(const char *cmd, const struct dem_import_options *o)
{
	if ((o->raw_width != 0) != (o->raw_type != NULL)) {
		fprintf(stderr, "relief %s: --raw-size and --raw-type go together\n", cmd);
		return false;
	}
	return true;
}
