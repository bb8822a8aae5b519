/* Transition strip bounds (see strip_bound.h), the CPU twin of shaders/patch_strips.comp:
 * its comments say why each bound holds. */
#include <math.h>

#include "layout.h"
#include "strip_bound.h"

struct strip {
	const int32_t *q;
	const uint8_t *valid;
	int P, ox, oy, edge; /* the block's first sample; 0 west, 1 north, 2 east, 3 south */
};

static void at(const struct strip *s, int along, int depth, int *x, int *y)
{
	const int n = RELIEF_BLOCK_CELLS;
	*x = s->ox + (s->edge == 0 ? depth : s->edge == 2 ? n - depth : along);
	*y = s->oy + (s->edge == 1 ? depth : s->edge == 3 ? n - depth : along);
}

static int32_t h(const struct strip *s, int along, int depth)
{
	int x, y;
	at(s, along, depth, &x, &y);
	return s->q[(size_t)(y + 1) * (size_t)(s->P + 2) + (size_t)x + 1];
}

static int valid(const struct strip *s, int along, int depth)
{
	if (!s->valid)
		return 1;
	int x, y;
	at(s, along, depth, &x, &y);
	return s->valid[(size_t)y * (size_t)s->P + (size_t)x] != 0;
}

static float coarse_edge(const struct strip *s, int so)
{
	const int n = RELIEF_BLOCK_CELLS;
	float worst = 0.0f;
	for (int c0 = 0; c0 < n; c0 += so) {
		if (!valid(s, c0, 0) || !valid(s, c0 + so, 0) || !valid(s, c0, so) || !valid(s, c0 + so, so))
			continue;
		const int32_t h00 = h(s, c0, 0);
		const float dx = (float)(h(s, c0 + so, 0) - h00) / (float)so;
		const float dy_lo = (float)(h(s, c0, so) - h00) / (float)so;
		const float dy_hi = (float)(h(s, c0 + so, so) - h(s, c0 + so, 0)) / (float)so;
		for (int si = 1; si < so; si *= 2) {
			const int first = c0 > si ? c0 : si, last = c0 + so < n - si ? c0 + so : n - si;
			for (int t = first; t <= last; t += si) {
				if (t % si != 0 || !valid(s, t, si))
					continue;
				const int x = t - c0;
				const float a = (float)(h(s, t, si) - h00) - dx * (float)x;
				if (x + si <= so)
					worst = fmaxf(worst, fabsf(a - dy_lo * (float)si));
				if (x >= si)
					worst = fmaxf(worst, fabsf(a - dy_hi * (float)si));
			}
		}
	}
	return worst;
}

static float fine_edge(const struct strip *s, int so)
{
	const int n = RELIEF_BLOCK_CELLS, c = 2 * so;
	float worst = 0.0f;
	for (int c0 = 0; c0 < n; c0 += c) {
		if (!valid(s, c0, 0) || !valid(s, c0 + so, 0) || !valid(s, c0 + c, 0) || !valid(s, c0, c) ||
		    !valid(s, c0 + c, c))
			continue;
		const int32_t o = h(s, c0, 0);
		const float m = (float)(h(s, c0 + so, 0) - o), cc = (float)(h(s, c0 + c, 0) - o);
		const float a = (float)(h(s, c0, c) - o), b = (float)(h(s, c0 + c, c) - o);
		const float mid = fabsf(m - 0.5f * cc);
		worst = fmaxf(worst, mid);
		if (c0 >= c && c0 + c <= n - c) {
			const float e1 = fabsf(b + 2.0f * m - a - 2.0f * cc) / 3.0f, e2 = fabsf(a + 2.0f * m - b) / 3.0f;
			worst = fmaxf(worst, fmaxf(mid, fminf(e1, e2)));
		}
	}
	return worst;
}

void relief_strip_bounds(const int32_t *q, uint32_t P, float q2, const uint8_t *valid, float *out)
{
	const uint32_t blocks = (P - 1) / RELIEF_BLOCK_CELLS;
	struct strip s = { .q = q, .valid = valid, .P = (int)P };
	for (uint32_t b = 0; b < blocks * blocks; b++)
		for (int e = 0; e < 4; e++) {
			s.ox = (int)(b % blocks) * RELIEF_BLOCK_CELLS;
			s.oy = (int)(b / blocks) * RELIEF_BLOCK_CELLS;
			s.edge = e;
			float *r = out + ((size_t)b * 4 + (size_t)e) * RELIEF_STRIP_FLOATS;
			for (int l = 1; l <= 4; l++)
				r[l - 1] = q2 * coarse_edge(&s, 1 << l);
			for (int l = 0; l <= 2; l++)
				r[4 + l] = q2 * fine_edge(&s, 1 << l);
			r[7] = 0.0f;
		}
}
