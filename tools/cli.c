#include <errno.h>
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

bool cli_parse_u32(const char *cmd, const char *opt, const char *s, uint32_t min, uint32_t max, uint32_t *out)
{
	char *end;
	errno = 0;
	unsigned long long v = strtoull(s, &end, 10);
	if (errno || end == s || *end || s[0] == '-' || v < min || v > max) {
		fprintf(stderr, "relief %s: %s: '%s' is not a whole number in [%u, %u]\n", cmd, opt, s, min, max);
		return false;
	}
	*out = (uint32_t)v;
	return true;
}

bool cli_parse_size(const char *cmd, const char *opt, const char *s, uint32_t *w, uint32_t *h)
{
	unsigned a, b;
	char tail;
	if (sscanf(s, "%ux%u%c", &a, &b, &tail) != 2 || a < 1 || b < 1 || a > 16384 || b > 16384) {
		fprintf(stderr, "relief %s: %s: '%s' is not WIDTHxHEIGHT with both in [1, 16384]\n", cmd, opt, s);
		return false;
	}
	*w = a;
	*h = b;
	return true;
}

bool cli_parse_vec3(const char *cmd, const char *opt, const char *s, double out[3])
{
	char buf[256];
	if (strlen(s) >= sizeof(buf)) {
		fprintf(stderr, "relief %s: %s: argument too long\n", cmd, opt);
		return false;
	}
	strcpy(buf, s);
	char *save = NULL, *tok = strtok_r(buf, ",", &save);
	for (int i = 0; i < 3; i++, tok = strtok_r(NULL, ",", &save)) {
		if (!tok || !cli_parse_double(cmd, opt, tok, &out[i])) {
			if (!tok)
				fprintf(stderr, "relief %s: %s: '%s' is not X,Y,Z\n", cmd, opt, s);
			return false;
		}
	}
	if (tok) {
		fprintf(stderr, "relief %s: %s: '%s' has more than three numbers\n", cmd, opt, s);
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
