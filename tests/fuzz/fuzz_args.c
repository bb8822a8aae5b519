/* The command-line argument parsers of `relief` (tools/cli.c): whole numbers, numbers,
 * WIDTHxHEIGHT (a viewport's, or a raster's up to 2^22), X,Y,Z and comma-separated lists.
 * The first byte picks the parser ('u', 'd', 's', 'r', 'v', 'l'; anything else: every
 * one), the rest is the argument. What a parser accepts must be what its contract says: in
 * range, finite, and for lists exactly one value per comma-separated field (no field
 * dropped or merged). Refusals print a line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "fuzz.h"

/* Fields of s separated by commas, or 0 if one is empty. */
static uint32_t fields(const char *s)
{
	uint32_t n = 1;
	size_t len = 0;
	for (const char *p = s;; p++) {
		if (*p == ',' || !*p) {
			if (len == 0)
				return 0;
			if (!*p)
				return n;
			n++;
			len = 0;
		} else {
			len++;
		}
	}
}

/* s without leading zeros ("0" stays): the canonical digits of a whole number. */
static const char *skip_zeros(const char *s)
{
	while (s[0] == '0' && s[1] >= '0' && s[1] <= '9')
		s++;
	return s;
}

static void check_u32(const char *s)
{
	uint32_t v;
	if (!cli_parse_u32("fuzz", "--u", s, 3, 70000, &v))
		return;
	char back[16];
	snprintf(back, sizeof(back), "%u", v);
	if (v < 3 || v > 70000 || strcmp(back, skip_zeros(s)) != 0)
		abort();
}

static void check_double(const char *s)
{
	double v;
	if (cli_parse_double("fuzz", "--d", s, &v) && !isfinite(v))
		abort();
}

/* A viewport (cli_parse_size(), max 0) or a raster's dimensions (cli_parse_dims() up to max). */
static void check_size(const char *s, uint32_t max)
{
	uint32_t w, h;
	if (!(max ? cli_parse_dims("fuzz", "--s", s, max, &w, &h) : cli_parse_size("fuzz", "--s", s, &w, &h)))
		return;
	uint32_t most = max ? max : 16384;
	if (w < 1 || h < 1 || w > most || h > most)
		abort();
	const char *x = strchr(s, 'x');
	char a[16], b[16];
	snprintf(a, sizeof(a), "%u", w);
	snprintf(b, sizeof(b), "%u", h);
	size_t la = strlen(skip_zeros(s)) - strlen(x); /* width's digits without leading zeros */
	if (la != strlen(a) || strncmp(skip_zeros(s), a, la) != 0 || strcmp(skip_zeros(x + 1), b) != 0)
		abort();
}

static void check_vec3(const char *s)
{
	double v[3];
	if (!cli_parse_vec3("fuzz", "--v", s, v))
		return;
	if (fields(s) != 3 || !isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]))
		abort();
}

static void check_list(const char *s)
{
	double v[4];
	uint32_t n;
	if (!cli_parse_list("fuzz", "--l", s, -2.5, 1e3, v, 4, &n))
		return;
	if (n < 1 || n > 4 || fields(s) != n)
		abort();
	for (uint32_t i = 0; i < n; i++)
		if (!(v[i] >= -2.5 && v[i] <= 1e3))
			abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size == 0 || size > 4096)
		return 0;
	char *s = malloc(size); /* the argument after the selector, NUL-terminated */
	memcpy(s, data + 1, size - 1);
	s[size - 1] = '\0';
	if (strlen(s) != size - 1) { /* an argv string has no NUL inside */
		free(s);
		return 0;
	}
	switch (data[0]) {
	case 'u': check_u32(s); break;
	case 'd': check_double(s); break;
	case 's': check_size(s, 0); break;
	case 'r': check_size(s, 1u << 22); break;
	case 'v': check_vec3(s); break;
	case 'l': check_list(s); break;
	default:
		check_u32(s);
		check_double(s);
		check_size(s, 0);
		check_size(s, 1u << 22);
		check_vec3(s);
		check_list(s);
	}
	free(s);
	return 0;
}
