/* The import options shared by `relief pack` and `relief bench codec`. */
#pragma once

#include <getopt.h>
#include <stdbool.h>

#include "dem_import.h"

enum {
	OPT_ENCODING = 0x100, OPT_SCALE, OPT_OFFSET, OPT_SPACING, OPT_UNITS, OPT_NODATA, OPT_RAW_SIZE,
	OPT_RAW_TYPE, OPT_RAW_ENDIAN,
	OPT_IMPORT_LAST,
};

#define IMPORT_LONG_OPTIONS                                             \
	{ "encoding", required_argument, NULL, OPT_ENCODING },          \
	{ "scale", required_argument, NULL, OPT_SCALE },                \
	{ "offset", required_argument, NULL, OPT_OFFSET },              \
	{ "spacing", required_argument, NULL, OPT_SPACING },            \
	{ "units", required_argument, NULL, OPT_UNITS },                \
	{ "nodata", required_argument, NULL, OPT_NODATA },              \
	{ "raw-size", required_argument, NULL, OPT_RAW_SIZE },          \
	{ "raw-type", required_argument, NULL, OPT_RAW_TYPE },          \
	{ "raw-endian", required_argument, NULL, OPT_RAW_ENDIAN }

#define IMPORT_OPTIONS_HELP                                                                       \
	"import options:\n"                                                                       \
	"      --encoding height|terrain-rgb  how pixel values encode heights (default height)\n"  \
	"      --scale S, --offset O    height = value * S + O (default: the file's, else 1 and 0)\n" \
	"      --units m|ft             units of those heights (default m); stored as metres\n"   \
	"      --spacing METRES         sample spacing for rasters without georeferencing\n"      \
	"      --nodata V|nan           value meaning no data (default: the file's NoData); heights\n" \
	"                               not finite or beyond 1e6 m are no-data too (counted)\n"   \
	"      --raw-size WxH --raw-type int16|float32 [--raw-endian little|big]\n"               \
	"                               read INPUT as headerless raw samples\n"

/* Handles one import option (c >= OPT_ENCODING). Returns false after printing an error. */
bool import_option(const char *cmd, int c, const char *arg, struct dem_import_options *o);
#define IMPORT_SIDECAR_SUFFIX ".relief-import"
/* Sidecar: INPUT.relief-import, an INI file with an [import] section whose keys are the
 * long option names above (encoding, scale, offset, spacing, units, nodata). Values the
 * command line did not set are taken from it. Returns 0 when there is no sidecar, -EINVAL
 * (after printing the line and key) when it is malformed. */
int import_sidecar_merge(const char *cmd, const char *input, struct dem_import_options *o);
/* Parses sidecar text into `out` (only the fields it sets). Returns 0, or -EINVAL with the
 * line number in *line. Used by import_sidecar_merge() and the fuzz target. */
int import_sidecar_parse(const char *cmd, const char *text, struct dem_import_options *out, int *line);
/* Checks option combinations after parsing. */
bool import_options_check(const char *cmd, const struct dem_import_options *o);
