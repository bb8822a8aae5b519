#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "track.h"

#define FIELDS 7
static const char *const field_names[FIELDS] = { "t", "x", "y", "z", "heading", "pitch", "roll" };

static int fail(char *err, size_t errlen, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(err, errlen, fmt, ap);
	va_end(ap);
	return -EINVAL;
}

static bool is_separator(char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r'; }

/* One line [s, e): 0 with *n_out numbers in v (0 for a blank or comment line), or -EINVAL. */
static int parse_line(const char *s, const char *e, size_t line, double v[FIELDS], int *n_out, char *err,
                      size_t errlen)
{
	const char *hash = memchr(s, '#', (size_t)(e - s));
	if (hash)
		e = hash;
	/* Spaces and tabs only separate; a comma ends a field, so two commas with nothing
	 * but blanks between them, or one before the first or after the last number, leave a
	 * field empty (an error, not a field dropped). */
	int n = 0, commas = 0;
	while (s < e) {
		if (is_separator(*s)) {
			if (*s == ',' && (n == 0 || ++commas > 1))
				return fail(err, errlen, "line %zu: field %d is empty (two commas, or one before it)", line, n + 1);
			s++;
			continue;
		}
		commas = 0;
		const char *tok = s;
		while (s < e && !is_separator(*s))
			s++;
		char buf[64];
		size_t len = (size_t)(s - tok);
		if (n == FIELDS)
			return fail(err, errlen, "line %zu: more than %d numbers (t x y z heading pitch roll)", line, FIELDS);
		if (len >= sizeof(buf))
			return fail(err, errlen, "line %zu: %s: a number of %zu characters", line, field_names[n], len);
		memcpy(buf, tok, len);
		buf[len] = '\0';
		char *end;
		errno = 0;
		double d = strtod(buf, &end);
		if (end == buf || *end != '\0')
			return fail(err, errlen, "line %zu: %s: '%s' is not a number", line, field_names[n], buf);
		if (!isfinite(d) || errno == ERANGE)
			return fail(err, errlen, "line %zu: %s: '%s' is not a finite number", line, field_names[n], buf);
		v[n++] = d;
	}
	if (commas)
		return fail(err, errlen, "line %zu: field %d is empty (a comma after the last number)", line, n + 1);
	if (n != 0 && n != FIELDS)
		return fail(err, errlen, "line %zu: %d numbers, expected %d (t x y z heading pitch roll)", line, n, FIELDS);
	*n_out = n;
	return 0;
}

int track_parse(const char *text, size_t len, struct track *out, char *err, size_t errlen)
{
	struct track t = { 0 };
	size_t cap = 0, line = 0;
	const char *s = text, *end = text + len;
	int ret = 0;
	while (s < end && ret == 0) {
		const char *nl = memchr(s, '\n', (size_t)(end - s));
		const char *e = nl ? nl : end;
		line++;
		double v[FIELDS];
		int n = 0;
		if (memchr(s, '\0', (size_t)(e - s)))
			ret = fail(err, errlen, "line %zu: a NUL byte (not a text file?)", line);
		else
			ret = parse_line(s, e, line, v, &n, err, errlen);
		s = nl ? nl + 1 : end;
		if (ret < 0 || n == 0)
			continue;
		if (t.n == TRACK_MAX_KEYS) {
			ret = fail(err, errlen, "line %zu: more than %u keys", line, TRACK_MAX_KEYS);
			break;
		}
		if (t.n > 0 && !(v[0] > t.keys[t.n - 1].t)) {
			ret = fail(err, errlen, "line %zu: time %g does not increase (the key before is at %g)", line, v[0],
			           t.keys[t.n - 1].t);
			break;
		}
		if (!(v[5] >= -90.0 && v[5] <= 90.0)) {
			ret = fail(err, errlen, "line %zu: pitch %g is outside [-90, 90] degrees", line, v[5]);
			break;
		}
		for (int i = 1; i <= 3 && ret == 0; i++)
			if (!(fabs(v[i]) <= TRACK_MAX_COORD))
				ret = fail(err, errlen, "line %zu: %s %g m is beyond %g m", line, field_names[i], v[i],
				           TRACK_MAX_COORD);
		if (ret < 0)
			break;
		if (t.n == cap) {
			size_t ncap = cap ? 2 * cap : 64;
			struct track_key *k = realloc(t.keys, ncap * sizeof(*k));
			if (!k) {
				ret = -ENOMEM;
				snprintf(err, errlen, "out of memory at line %zu", line);
				break;
			}
			t.keys = k;
			cap = ncap;
		}
		t.keys[t.n++] = (struct track_key){ v[0], v[1], v[2], v[3], v[4], v[5], v[6] };
	}
	if (ret == 0 && t.n == 0)
		ret = fail(err, errlen, "no keys (expected lines of t x y z heading pitch roll)");
	if (ret < 0) {
		free(t.keys);
		return ret;
	}
	*out = t;
	return 0;
}

int track_load(const char *path, struct track *out, char *err, size_t errlen)
{
	FILE *f = fopen(path, "rbe");
	if (!f) {
		int e = errno;
		snprintf(err, errlen, "cannot open: %s", strerror(e));
		return -e;
	}
	char *buf = malloc(TRACK_MAX_BYTES + 1);
	errno = 0;
	size_t len = buf ? fread(buf, 1, TRACK_MAX_BYTES + 1, f) : 0;
	int ret = 0;
	if (!buf) {
		ret = -ENOMEM;
		snprintf(err, errlen, "out of memory");
	} else if (ferror(f)) {
		ret = errno ? -errno : -EIO;
		snprintf(err, errlen, "cannot read: %s", strerror(-ret));
	} else if (len > TRACK_MAX_BYTES) {
		ret = fail(err, errlen, "larger than %u MiB", TRACK_MAX_BYTES >> 20);
	} else {
		ret = track_parse(buf, len, out, err, errlen);
	}
	free(buf);
	fclose(f);
	return ret;
}

void track_finish(struct track *t)
{
	if (!t)
		return;
	free(t->keys);
	t->keys = NULL;
	t->n = 0;
}

/* a + s (b - a) the shorter way round, degrees. */
static double lerp_angle(double a, double b, double s)
{
	double d = fmod(b - a, 360.0);
	if (d > 180.0)
		d -= 360.0;
	else if (d < -180.0)
		d += 360.0;
	return a + s * d;
}

void track_at(const struct track *t, double time, struct track_key *out)
{
	const struct track_key *k = t->keys;
	if (t->n == 1 || !(time > k[0].t)) {
		*out = k[0];
		return;
	}
	if (time >= k[t->n - 1].t) {
		*out = k[t->n - 1];
		return;
	}
	size_t lo = 0, hi = t->n - 1; /* k[lo].t < time < k[hi].t */
	while (hi - lo > 1) {
		size_t mid = lo + (hi - lo) / 2;
		if (k[mid].t <= time)
			lo = mid;
		else
			hi = mid;
	}
	const struct track_key *a = &k[lo], *b = &k[hi];
	double s = (time - a->t) / (b->t - a->t);
	*out = (struct track_key){
		.t = time,
		.x = a->x + s * (b->x - a->x),
		.y = a->y + s * (b->y - a->y),
		.z = a->z + s * (b->z - a->z),
		.heading = lerp_angle(a->heading, b->heading, s),
		.pitch = a->pitch + s * (b->pitch - a->pitch),
		.roll = lerp_angle(a->roll, b->roll, s),
	};
}

void track_key_view(const struct track_key *k, struct relief_view *v)
{
	const double deg = M_PI / 180.0, limit = 90.0 - 1e-4;
	double h = k->heading * deg, p = fmax(-limit, fmin(limit, k->pitch)) * deg;
	/* 1 km ahead: far enough that rounding of the difference is nothing at any coordinates. */
	double fx = sin(h) * cos(p), fy = cos(h) * cos(p), fz = sin(p);
	v->eye = (struct relief_vec3){ k->x, k->y, k->z };
	v->target = (struct relief_vec3){ k->x + 1000.0 * fx, k->y + 1000.0 * fy, k->z + 1000.0 * fz };
	v->roll = k->roll * deg;
}

void track_channel_view(const struct relief_view *centre, double yaw, struct relief_view *out)
{
	*out = *centre;
	struct relief_vec3 f, r, u, f0, r0, u0;
	if (yaw == 0.0 || !relief_view_axes(centre, &f, &r, &u))
		return;
	double c = cos(yaw), s = sin(yaw);
	struct relief_vec3 fc = { c * f.x + s * r.x, c * f.y + s * r.y, c * f.z + s * r.z };
	double dist = relief_vec3_length(relief_vec3_sub(centre->target, centre->eye));
	out->target = (struct relief_vec3){ centre->eye.x + dist * fc.x, centre->eye.y + dist * fc.y,
	                                    centre->eye.z + dist * fc.z };
	/* The roll that keeps the picture's up at u: relief_view_axes() turns its roll-0 up u0
	 * towards its right r0 by the roll angle. */
	out->roll = 0.0;
	if (relief_view_axes(out, &f0, &r0, &u0))
		out->roll = atan2(relief_vec3_dot(u, r0), relief_vec3_dot(u, u0));
}
