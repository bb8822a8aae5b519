#include <errno.h>
#include <stddef.h>
#include <stdlib.h>

#include "fill.h"

/* Sample states: EMPTY (no value yet), QUEUED (in the next ring), FILLED (valid, or given
 * its value by an earlier ring: the only state a ring reads). */
enum { EMPTY, QUEUED, FILLED };

struct ring {
	uint32_t *i; /* sample indices (w h <= 2^32, so an index fits) */
	size_t n, cap;
};

static int ring_push(struct ring *r, uint32_t i)
{
	if (r->n == r->cap) {
		size_t cap = r->cap ? 2 * r->cap : 1024;
		uint32_t *v = realloc(r->i, cap * sizeof(*v));
		if (!v)
			return -ENOMEM;
		r->i = v;
		r->cap = cap;
	}
	r->i[r->n++] = i;
	return 0;
}

static const int DX[8] = { -1, 0, 1, -1, 1, -1, 0, 1 }, DY[8] = { -1, -1, -1, 0, 0, 1, 1, 1 };

/* Queues the EMPTY 8-neighbours of sample (x, y). */
static int queue_around(uint32_t w, uint32_t h, uint8_t *state, struct ring *r, uint32_t x, uint32_t y)
{
	for (int k = 0; k < 8; k++) {
		int64_t X = (int64_t)x + DX[k], Y = (int64_t)y + DY[k];
		if (X < 0 || Y < 0 || X >= w || Y >= h)
			continue;
		size_t j = (size_t)Y * w + (size_t)X;
		if (state[j] == EMPTY) {
			state[j] = QUEUED;
			int ret = ring_push(r, (uint32_t)j);
			if (ret < 0)
				return ret;
		}
	}
	return 0;
}

int relief_fill_nodata(uint32_t w, uint32_t h, const float *heights, const uint8_t *valid, float *out, uint16_t *ring_of)
{
	const size_t n = (size_t)w * h;
	uint8_t *state = malloc(n ? n : 1);
	struct ring ring = { 0 }, next = { 0 };
	if (!state)
		return -ENOMEM;
	size_t filled = 0;
	for (size_t i = 0; i < n; i++) {
		state[i] = valid[i] ? FILLED : EMPTY;
		if (valid[i]) {
			out[i] = heights[i];
			filled++;
		}
		if (ring_of)
			ring_of[i] = 0;
	}
	int ret = filled ? 0 : -ENODATA;
	/* The first ring: the no-data samples around the valid ones. */
	for (uint32_t y = 0; y < h && ret == 0 && filled < n; y++)
		for (uint32_t x = 0; x < w && ret == 0; x++)
			if (valid[(size_t)y * w + x])
				ret = queue_around(w, h, state, &ring, x, y);
	for (uint32_t step = 1; ret == 0 && ring.n; step++) {
		/* Every value of a ring from the rings before it only (QUEUED is not read). */
		for (size_t r = 0; r < ring.n; r++) {
			const size_t i = ring.i[r];
			const uint32_t x = (uint32_t)(i % w), y = (uint32_t)(i / w);
			double sum = 0.0;
			unsigned count = 0;
			for (int k = 0; k < 8; k++) {
				int64_t X = (int64_t)x + DX[k], Y = (int64_t)y + DY[k];
				if (X < 0 || Y < 0 || X >= w || Y >= h || state[(size_t)Y * w + (size_t)X] != FILLED)
					continue;
				sum += out[(size_t)Y * w + (size_t)X];
				count++;
			}
			out[i] = (float)(sum / count); /* count >= 1: it was queued next to a FILLED one */
		}
		for (size_t r = 0; r < ring.n; r++) {
			state[ring.i[r]] = FILLED;
			if (ring_of)
				ring_of[ring.i[r]] = (uint16_t)(step < UINT16_MAX ? step : UINT16_MAX);
		}
		next.n = 0;
		for (size_t r = 0; r < ring.n && ret == 0; r++)
			ret = queue_around(w, h, state, &next, ring.i[r] % w, ring.i[r] / w);
		struct ring t = ring;
		ring = next;
		next = t;
	}
	free(ring.i);
	free(next.i);
	free(state);
	return ret;
}
