#include <errno.h>
#include <stdlib.h>

#include "fill.h"

struct level {
	uint32_t w, h;
	float *v; /* value (normalised where weight > 0) */
	float *wt;
};

static void free_levels(struct level *lv, int n)
{
	for (int i = 0; i < n; i++) {
		free(lv[i].v);
		free(lv[i].wt);
	}
}

static double sample_bilinear(const struct level *c, double x, double y)
{
	if (x < 0) x = 0;
	if (y < 0) y = 0;
	if (x > c->w - 1) x = c->w - 1;
	if (y > c->h - 1) y = c->h - 1;
	uint32_t x0 = (uint32_t)x, y0 = (uint32_t)y;
	uint32_t x1 = x0 + 1 < c->w ? x0 + 1 : x0, y1 = y0 + 1 < c->h ? y0 + 1 : y0;
	double fx = x - x0, fy = y - y0;
	double a = c->v[(size_t)y0 * c->w + x0], b = c->v[(size_t)y0 * c->w + x1];
	double d = c->v[(size_t)y1 * c->w + x0], e = c->v[(size_t)y1 * c->w + x1];
	return (a * (1 - fx) + b * fx) * (1 - fy) + (d * (1 - fx) + e * fx) * fy;
}

int relief_fill(const float *in, const uint8_t *valid, uint32_t w, uint32_t h, uint32_t size, float *out)
{
	struct level lv[40];
	int n = 0, ret = 0;
	lv[0].w = lv[0].h = size;
	lv[0].v = calloc((size_t)size * size, sizeof(float));
	lv[0].wt = calloc((size_t)size * size, sizeof(float));
	n = 1;
	if (!lv[0].v || !lv[0].wt) {
		ret = -ENOMEM;
		goto out;
	}
	size_t count = 0;
	for (uint32_t y = 0; y < h; y++)
		for (uint32_t x = 0; x < w; x++)
			if (valid[(size_t)y * w + x]) {
				lv[0].v[(size_t)y * size + x] = in[(size_t)y * w + x];
				lv[0].wt[(size_t)y * size + x] = 1.0f;
				count++;
			}
	if (!count) {
		ret = -ENODATA;
		goto out;
	}
	/* Pull. */
	while (lv[n - 1].w > 1 || lv[n - 1].h > 1) {
		struct level *f = &lv[n - 1], *c = &lv[n];
		c->w = (f->w + 1) / 2;
		c->h = (f->h + 1) / 2;
		c->v = calloc((size_t)c->w * c->h, sizeof(float));
		c->wt = calloc((size_t)c->w * c->h, sizeof(float));
		n++;
		if (!c->v || !c->wt) {
			ret = -ENOMEM;
			goto out;
		}
		for (uint32_t y = 0; y < c->h; y++)
			for (uint32_t x = 0; x < c->w; x++) {
				double sv = 0, sw = 0;
				for (uint32_t dy = 0; dy < 2; dy++)
					for (uint32_t dx = 0; dx < 2; dx++) {
						uint32_t fx = 2 * x + dx, fy = 2 * y + dy;
						if (fx >= f->w || fy >= f->h)
							continue;
						double wt = f->wt[(size_t)fy * f->w + fx];
						sv += wt * f->v[(size_t)fy * f->w + fx];
						sw += wt;
					}
				c->v[(size_t)y * c->w + x] = sw > 0 ? (float)(sv / sw) : 0.0f;
				c->wt[(size_t)y * c->w + x] = sw > 1 ? 1.0f : (float)sw;
			}
	}
	/* Push: the coarse sample x covers fine samples 2x and 2x+1, centred at fine 2x + 0.5. */
	for (int k = n - 2; k >= 0; k--) {
		struct level *f = &lv[k], *c = &lv[k + 1];
		for (uint32_t y = 0; y < f->h; y++)
			for (uint32_t x = 0; x < f->w; x++) {
				size_t i = (size_t)y * f->w + x;
				float wt = f->wt[i];
				if (wt >= 1.0f)
					continue;
				double coarse = sample_bilinear(c, (x - 0.5) / 2.0, (y - 0.5) / 2.0);
				f->v[i] = (float)(wt * f->v[i] + (1.0 - wt) * coarse);
			}
	}
	for (size_t i = 0; i < (size_t)size * size; i++)
		out[i] = lv[0].v[i];
out:
	free_levels(lv, n);
	return ret;
}
