#include <errno.h>
#include <float.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"

static enum relief_log_level log_level = RELIEF_LOG_WARN;
struct relief_logger cli_log = { relief_log_stderr, &log_level };

void cli_log_set_level(enum relief_log_level level)
{
	log_level = level;
}

bool cli_parse_double(const char *cmd, const char *opt, const char *s, double *out)
{
	char *end;
	errno = 0;
	double v = strtod(s, &end);
	if (errno || end == s || *end || !isfinite(v)) {
		fprintf(stderr, "relief %s: %s: '%s' is not a finite number\n", cmd, opt, s);
		return false;
	}
	*out = v;
	return true;
}

/* One whole number of [min, max] in s[0, len): digits only (no sign, no space). */
static bool parse_u32_span(const char *s, size_t len, uint32_t min, uint32_t max, uint32_t *out)
{
	if (len == 0 || len > 10)
		return false;
	uint64_t v = 0;
	for (size_t i = 0; i < len; i++) {
		if (s[i] < '0' || s[i] > '9')
			return false;
		v = v * 10 + (uint64_t)(s[i] - '0');
	}
	if (v < min || v > max)
		return false;
	*out = (uint32_t)v;
	return true;
}

bool cli_parse_u32(const char *cmd, const char *opt, const char *s, uint32_t min, uint32_t max, uint32_t *out)
{
	if (!parse_u32_span(s, strlen(s), min, max, out)) {
		fprintf(stderr, "relief %s: %s: '%s' is not a whole number in [%u, %u]\n", cmd, opt, s, min, max);
		return false;
	}
	return true;
}

bool cli_parse_dims(const char *cmd, const char *opt, const char *s, uint32_t max, uint32_t *w, uint32_t *h)
{
	const char *x = strchr(s, 'x');
	if (!x || !parse_u32_span(s, (size_t)(x - s), 1, max, w) || !parse_u32_span(x + 1, strlen(x + 1), 1, max, h)) {
		fprintf(stderr, "relief %s: %s: '%s' is not WIDTHxHEIGHT with both in [1, %u]\n", cmd, opt, s, max);
		return false;
	}
	return true;
}

bool cli_parse_size(const char *cmd, const char *opt, const char *s, uint32_t *w, uint32_t *h)
{
	return cli_parse_dims(cmd, opt, s, 16384, w, h);
}

bool cli_parse_list(const char *cmd, const char *opt, const char *s, double min, double max, double *out,
                    uint32_t cap, uint32_t *n)
{
	*n = 0;
	for (const char *p = s;; p++) {
		const char *comma = strchr(p, ',');
		size_t len = comma ? (size_t)(comma - p) : strlen(p);
		char tok[64];
		if (len == 0) {
			fprintf(stderr, "relief %s: %s: '%s': value %u is empty\n", cmd, opt, s, *n + 1);
			return false;
		}
		if (*n == cap) {
			fprintf(stderr, "relief %s: %s: '%s' has more than %u values\n", cmd, opt, s, cap);
			return false;
		}
		if (len >= sizeof(tok)) {
			fprintf(stderr, "relief %s: %s: '%s': value %u is too long for a number\n", cmd, opt, s, *n + 1);
			return false;
		}
		memcpy(tok, p, len);
		tok[len] = '\0';
		if (!cli_parse_double(cmd, opt, tok, &out[*n]))
			return false;
		if (!(out[*n] >= min && out[*n] <= max)) {
			fprintf(stderr, "relief %s: %s: %s is outside [%g, %g]\n", cmd, opt, tok, min, max);
			return false;
		}
		(*n)++;
		if (!comma)
			return true;
		p = comma;
	}
}

bool cli_parse_vec3(const char *cmd, const char *opt, const char *s, double out[3])
{
	uint32_t n;
	if (!cli_parse_list(cmd, opt, s, -DBL_MAX, DBL_MAX, out, 3, &n))
		return false;
	if (n != 3) {
		fprintf(stderr, "relief %s: %s: '%s' is not X,Y,Z\n", cmd, opt, s);
		return false;
	}
	return true;
}

int cli_make_parent_dir(const char *path)
{
	const char *slash = strrchr(path, '/');
	if (!slash || slash == path)
		return 0;
	char dir[4096];
	size_t n = (size_t)(slash - path);
	if (n >= sizeof(dir))
		return -ENAMETOOLONG;
	memcpy(dir, path, n);
	dir[n] = '\0';
	if (mkdir(dir, 0777) < 0 && errno != EEXIST)
		return -errno;
	return 0;
}

int cli_option_error(const char *cmd, int c, char **argv)
{
	if (c == ':')
		fprintf(stderr, "relief %s: %s needs a value\n", cmd, argv[optind - 1]);
	else
		fprintf(stderr, "relief %s: unknown option '%s' (see 'relief %s --help')\n", cmd, argv[optind - 1], cmd);
	return EXIT_USAGE;
}

void cli_json_string(FILE *f, const char *s)
{
	fputc('"', f);
	for (; *s; s++) {
		unsigned char c = (unsigned char)*s;
		if (c == '"' || c == '\\')
			fprintf(f, "\\%c", c);
		else if (c < 0x20)
			fprintf(f, "\\u%04x", c);
		else
			fputc(c, f);
	}
	fputc('"', f);
}
