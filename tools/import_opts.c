#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ini.h>

#include "cli.h"
#include "format.h"
#include "import_opts.h"

bool import_option(const char *cmd, int c, const char *arg, struct dem_import_options *o)
{
	switch (c) {
	case OPT_ENCODING:
		o->has_encoding = true;
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
		o->has_units = true;
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
		if (!strcmp(arg, "nan")) { /* float rasters often mark no-data with NaN */
			o->nodata = NAN;
			return true;
		}
		return cli_parse_double(cmd, "--nodata", arg, &o->nodata);
	case OPT_RAW_SIZE:
		/* A raster, not a viewport: as large as a .relief file holds at 129-sample
		 * patches (16 levels, 4,194,305 samples a side), memory permitting. */
		return cli_parse_dims(cmd, "--raw-size", arg, 1u << 22, &o->raw_width, &o->raw_height);
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

struct sidecar {
	const char *cmd;
	struct dem_import_options o;
};

static int sidecar_handler(void *user, const char *section, const char *name, const char *value)
{
	static const struct { const char *key; int code; } keys[] = {
		{ "encoding", OPT_ENCODING }, { "scale", OPT_SCALE }, { "offset", OPT_OFFSET },
		{ "spacing", OPT_SPACING }, { "units", OPT_UNITS }, { "nodata", OPT_NODATA },
	};
	struct sidecar *sc = user;
	if (strcmp(section, "import") == 0)
		for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); i++)
			if (strcmp(name, keys[i].key) == 0)
				return import_option(sc->cmd, keys[i].code, value, &sc->o) ? 1 : 0;
	return 0;
}

int import_sidecar_parse(const char *cmd, const char *text, struct dem_import_options *out, int *line)
{
	struct sidecar sc = { .cmd = cmd };
	*line = ini_parse_string(text, sidecar_handler, &sc);
	if (*line != 0)
		return -EINVAL;
	*out = sc.o;
	return 0;
}

int import_sidecar_merge(const char *cmd, const char *input, struct dem_import_options *o)
{
	size_t n = strlen(input) + sizeof(IMPORT_SIDECAR_SUFFIX);
	char *path = malloc(n);
	if (!path)
		return -ENOMEM;
	snprintf(path, n, "%s" IMPORT_SIDECAR_SUFFIX, input);
	FILE *f = fopen(path, "re");
	if (!f) {
		int e = errno;
		free(path);
		return e == ENOENT ? 0 : -e;
	}
	char text[4096];
	size_t len = fread(text, 1, sizeof(text) - 1, f);
	bool too_long = !feof(f);
	fclose(f);
	text[len] = '\0';
	if (too_long || memchr(text, 0, len)) {
		fprintf(stderr, "relief %s: %s: not a sidecar (binary or over %zu bytes)\n", cmd, path, sizeof(text) - 1);
		free(path);
		return -EINVAL;
	}
	struct dem_import_options side = { 0 };
	int line = 0;
	if (import_sidecar_parse(cmd, text, &side, &line) < 0) {
		fprintf(stderr, "relief %s: %s: line %d: unknown section or key, or invalid value\n", cmd, path, line);
		free(path);
		return -EINVAL;
	}
	free(path);
	const struct dem_import_options *s = &side;
	if (!o->has_encoding && s->has_encoding) { o->encoding = s->encoding; o->has_encoding = true; }
	if (!o->has_units && s->has_units) { o->units = s->units; o->has_units = true; }
	if (!o->has_scale && s->has_scale) { o->scale = s->scale; o->has_scale = true; }
	if (!o->has_offset && s->has_offset) { o->offset = s->offset; o->has_offset = true; }
	if (!o->has_spacing && s->has_spacing) { o->spacing = s->spacing; o->has_spacing = true; }
	if (!o->has_nodata && s->has_nodata) { o->nodata = s->nodata; o->has_nodata = true; }
	return 0;
}
