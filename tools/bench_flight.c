/* The benchmark flight and popping over the whole of it (bench_flight.h). */
#include "bench_flight.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "format.h"
#include "terrain.h"

struct relief_view bench_flight_view(const struct relief_file *f, uint32_t w, uint32_t h, uint32_t keys, double t)
{
	const struct relief_header *hd = &f->hdr;
	double ex = hd->spacing_x * (hd->width - 1), ey = hd->spacing_y * (hd->height - 1);
	double x0 = hd->origin_x + 0.30 * ex + 0.37 * hd->spacing_x, y0 = hd->origin_y - 0.70 * ey + 0.61 * hd->spacing_y;
	double dx = 0.10 * ex / keys, dy = 0.10 * ey / keys; /* north-east, a tenth of the map */
	double z = hd->height_min + 0.8 * (hd->height_max - hd->height_min) + 100.0;
	double reach = sqrt(ex * ex + ey * ey) + 10 * (hd->height_max - hd->height_min);
	double x = x0 + dx * t, y = y0 + dy * t;
	return (struct relief_view){
		.eye = { x, y, z },
		.target = { x + 0.2 * ex, y + 0.2 * ey, z - 0.06 * sqrt(ex * ex + ey * ey) },
		.fovy = 55.0 * M_PI / 180.0, .width = w, .height = h,
		.znear = 1.0, .zfar = 2 * reach, .tau = 1.0, /* reversed Z keeps depth precise far away */
	};
}

double bench_flight_step(const struct relief_file *f, uint32_t keys)
{
	const struct relief_header *hd = &f->hdr;
	double dx = 0.10 * hd->spacing_x * (hd->width - 1) / keys, dy = 0.10 * hd->spacing_y * (hd->height - 1) / keys;
	return BENCH_FLIGHT_SPEED / BENCH_FRAME_RATE / sqrt(dx * dx + dy * dy);
}

uint32_t bench_flight_frames(const struct relief_file *f)
{
	return (uint32_t)floor(1.0 / bench_flight_step(f, 1)) + 1;
}

struct relief_view bench_flight_frame_view(const struct relief_file *f, const struct relief_view *like, uint32_t j)
{
	struct relief_view v = bench_flight_view(f, like->width, like->height, 1, j * bench_flight_step(f, 1));
	v.tau = like->tau;
	v.morph = like->morph;
	v.loose_transitions = like->loose_transitions;
	return v;
}

static int id_cmp(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return x < y ? -1 : x > y;
}

/* Frames [from, to), as bench_flight_replay(); with ids (two arrays of patch_count), each
 * frame's drawn patches compared with the last one's into changed[]. */
static int replay(const struct relief_file *f, struct relief_terrain *t, struct relief_terrain_view *tv,
                  const struct relief_view *like, const struct relief_draw_options *opts, uint32_t from, uint32_t to,
                  uint32_t *ids, uint8_t *changed)
{
	struct relief_draw_options o = *opts;
	o.lod_only = true;
	const uint32_t cap = f->hdr.patch_count;
	int n_prev = -1;
	for (uint32_t j = from; j < to; j++) {
		struct relief_view v = bench_flight_frame_view(f, like, j);
		int ret = relief_terrain_draw(t, tv, &v, NULL, j, &o, NULL);
		if (ret == 0 && j == 0) /* a new view's first frame settles its hysteresis */
			ret = relief_terrain_draw(t, tv, &v, NULL, j, &o, NULL);
		if (ret < 0)
			return ret;
		if (!ids)
			continue;
		uint32_t *now = ids + (size_t)(j & 1) * cap, *last = ids + (size_t)((j & 1) ^ 1) * cap;
		int n = relief_terrain_view_drawn(tv, now, cap);
		if (n < 0)
			return n;
		qsort(now, (size_t)n, sizeof(*now), id_cmp);
		if (j > from)
			changed[j - 1] = n != n_prev || memcmp(now, last, sizeof(*now) * (size_t)n) != 0;
		n_prev = n;
	}
	return 0;
}

int bench_flight_replay(const struct relief_file *f, struct relief_terrain *t, struct relief_terrain_view *tv,
                       const struct relief_view *like, const struct relief_draw_options *opts, uint32_t from,
                       uint32_t to)
{
	return replay(f, t, tv, like, opts, from, to, NULL, NULL);
}

int bench_flight_events(const struct relief_file *f, struct relief_terrain *t, struct relief_terrain_view *tv,
                       const struct relief_view *like, const struct relief_draw_options *opts, uint8_t *changed)
{
	uint32_t *ids = malloc(sizeof(*ids) * 2 * (size_t)f->hdr.patch_count);
	if (!ids)
		return -ENOMEM;
	int ret = replay(f, t, tv, like, opts, 0, bench_flight_frames(f), ids, changed);
	free(ids);
	return ret;
}

/* Pair k of `sample` spread evenly over `pairs`: each the middle of its share. */
static uint32_t sample_pair(uint32_t pairs, uint32_t sample, uint32_t k)
{
	return (uint32_t)(((uint64_t)2 * k + 1) * pairs / (2 * (uint64_t)sample));
}

int bench_flight_choose(uint32_t pairs, const uint8_t *const *changed, uint32_t n, uint32_t sample, uint32_t *at,
                       uint8_t *sampled, uint32_t cap)
{
	uint32_t count = 0, next = 0; /* next: the sample's next pair */
	if (sample > pairs)
		sample = pairs;
	for (uint32_t p = 0; p < pairs; p++) {
		bool in_sample = next < sample && sample_pair(pairs, sample, next) == p;
		bool event = false;
		for (uint32_t m = 0; m < n && !event; m++)
			event = changed[m][p] != 0;
		if (!in_sample && !event)
			continue;
		if (count == cap)
			return -E2BIG;
		at[count] = p;
		sampled[count++] = in_sample;
		next += in_sample;
	}
	return (int)count;
}

struct bench_flight_mean bench_flight_mean(uint32_t pairs, const uint8_t *changed, const uint32_t *at,
                                         const uint8_t *sampled, uint32_t chosen, const double *v)
{
	struct bench_flight_mean m = { 0 };
	double events_sum = 0, sum = 0, sum2 = 0;
	uint32_t events_seen = 0, drawn = 0; /* events and samples with terrain in view */
	for (uint32_t p = 0; p < pairs; p++)
		m.events += changed[p] != 0;
	for (uint32_t k = 0; k < chosen; k++) {
		bool event = changed[at[k]] != 0;
		if (!event && !sampled[k])
			continue; /* another method's event: not in this one's sample */
		m.sampled += !event;
		if (isnan(v[k]))
			continue;
		if (event) {
			events_sum += v[k];
			events_seen++;
		} else {
			sum += v[k];
			sum2 += v[k] * v[k];
			drawn++;
		}
	}
	/* The other pairs, in the share the sample shows terrain in. */
	const double rest = m.sampled ? (double)(pairs - m.events) * drawn / m.sampled : 0;
	const double mean_rest = drawn ? sum / drawn : 0, total = events_seen + rest;
	if (total <= 0) {
		m.mean = m.se = NAN;
		return m;
	}
	m.mean = (events_sum + rest * mean_rest) / total;
	if (drawn > 1) {
		const double var = fmax(0.0, (sum2 - drawn * mean_rest * mean_rest) / (drawn - 1));
		const double fpc = rest > drawn ? 1.0 - drawn / rest : 0.0; /* the finite population's */
		m.se = rest / total * sqrt(var / drawn * fpc);
	} else
		m.se = NAN;
	return m;
}
