#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <ini.h>

#include "config.h"

struct parse_state {
	struct reliefd_config *c;
	char *err;
	size_t err_size;
	int line;
	bool failed;
};

void reliefd_config_defaults(struct reliefd_config *c)
{
	memset(c, 0, sizeof(*c));
	c->validation = false;
	c->budget_mib = 256;
	c->decode_workers = 1;
}

/* A decimal whole number in [lo, hi], nothing else on the line. */
static bool parse_u32(const char *v, uint32_t lo, uint32_t hi, uint32_t *out)
{
	char *end;
	errno = 0;
	unsigned long n = strtoul(v, &end, 10);
	if (errno || end == v || *end || v[0] == '-' || n < lo || n > hi)
		return false;
	*out = (uint32_t)n;
	return true;
}

static bool parse_bool(const char *v, bool *out)
{
	if (!strcmp(v, "true") || !strcmp(v, "yes") || !strcmp(v, "1") || !strcmp(v, "on"))
		*out = true;
	else if (!strcmp(v, "false") || !strcmp(v, "no") || !strcmp(v, "0") || !strcmp(v, "off"))
		*out = false;
	else
		return false;
	return true;
}

static int handler(void *user, const char *section, const char *name, const char *value
#if INI_HANDLER_LINENO
                   , int lineno
#endif
)
{
	struct parse_state *st = user;
	if (st->failed)
		return 0;
	const char *why = NULL;
	if (strcmp(section, "gpu") != 0) {
		why = "unknown section";
	} else if (!strcmp(name, "device")) {
		if (strlen(value) >= sizeof(st->c->device))
			why = "value too long";
		else
			strcpy(st->c->device, value);
	} else if (!strcmp(name, "validation")) {
		if (!parse_bool(value, &st->c->validation))
			why = "expected true or false";
	} else if (!strcmp(name, "budget_mib")) {
		if (!parse_u32(value, 16, 1048576, &st->c->budget_mib))
			why = "expected a whole number of MiB in [16, 1048576]";
	} else if (!strcmp(name, "decode_workers")) {
		if (!parse_u32(value, 1, RELIEFD_MAX_DECODE_WORKERS, &st->c->decode_workers))
			why = "expected a whole number of threads in [1, 8]";
	} else {
		why = "unknown key";
	}
	if (why) {
		snprintf(st->err, st->err_size, "[%s] %s: %s", section, name, why);
		st->failed = true;
		return 0;
	}
	return 1;
}

static int finish(struct parse_state *st, int r)
{
	if (r == 0 && !st->failed)
		return 0;
	if (!st->failed)
		snprintf(st->err, st->err_size, "line %d: not an INI line", r);
	else if (r > 0) {
		char detail[256];
		snprintf(detail, sizeof(detail), "%s", st->err);
		snprintf(st->err, st->err_size, "line %d: %s", r, detail);
	}
	return -EINVAL;
}

int reliefd_config_parse_string(struct reliefd_config *c, const char *text, char *err, size_t err_size)
{
	struct reliefd_config tmp = *c;
	struct parse_state st = { .c = &tmp, .err = err, .err_size = err_size };
	int ret = finish(&st, ini_parse_string(text, handler, &st));
	if (ret == 0)
		*c = tmp;
	return ret;
}

int reliefd_config_load(struct reliefd_config *c, const char *path, char *err, size_t err_size)
{
	FILE *f = fopen(path, "re");
	if (!f) {
		int e = errno;
		snprintf(err, err_size, "%s: %s", path, strerror(e));
		return -e;
	}
	struct stat sb;
	if (fstat(fileno(f), &sb) < 0 || !S_ISREG(sb.st_mode)) {
		snprintf(err, err_size, "%s: not a regular file", path);
		fclose(f);
		return -EINVAL;
	}
	struct reliefd_config tmp = *c;
	struct parse_state st = { .c = &tmp, .err = err, .err_size = err_size };
	int ret = finish(&st, ini_parse_file(f, handler, &st));
	if (ret == 0 && ferror(f)) { /* inih stops at a read error as at the end */
		snprintf(err, err_size, "%s: read error", path);
		ret = -EIO;
	}
	fclose(f);
	if (ret == 0)
		*c = tmp;
	return ret;
}
