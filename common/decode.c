#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "decode.h"
#include "parallel.h"

int relief_decoder_init(struct relief_decoder *d, const struct relief_file *f)
{
	const struct relief_patch_geom *g = &f->layout.geom;
	d->file = f;
	d->stream = malloc(f->max_stream ? f->max_stream : 1);
	d->labels = malloc(g->n_labels);
	d->residuals = malloc(sizeof(int32_t) * (g->E * g->E > g->n_residuals ? g->E * g->E : g->n_residuals));
	if (!d->stream || !d->labels || !d->residuals) {
		relief_decoder_finish(d);
		return -ENOMEM;
	}
	return 0;
}

void relief_decoder_finish(struct relief_decoder *d)
{
	if (!d)
		return;
	free(d->stream);
	free(d->labels);
	free(d->residuals);
	d->stream = NULL;
	d->labels = NULL;
	d->residuals = NULL;
}

int relief_decoder_symbols(struct relief_decoder *d, uint32_t id)
{
	const struct relief_patch_geom *g = &d->file->layout.geom;
	size_t size;
	int ret = relief_file_read_stream(d->file, id, d->stream, &size);
	if (ret == -ENOENT) { /* empty patch */
		memset(d->labels, 0, g->n_labels);
		memset(d->residuals, 0, sizeof(int32_t) * g->n_residuals);
		return 0;
	}
	if (ret < 0)
		return ret;
	struct relief_window win;
	relief_file_window(d->file, id, &win);
	return relief_patch_decode_symbols(g, id == 0, &win, d->stream, size, d->labels, d->residuals);
}

int relief_decoder_patch(struct relief_decoder *d, uint32_t id, const int32_t *parent, int32_t *block)
{
	int ret = relief_decoder_symbols(d, id);
	if (ret < 0)
		return ret;
	const struct relief_layout *lay = &d->file->layout;
	if (id == 0)
		return relief_root_reconstruct(&lay->geom, d->residuals, block);
	uint32_t l, px, py;
	relief_patch_coords(lay, id, &l, &px, &py);
	return relief_patch_reconstruct(&lay->geom, lay->ratio, (px & 1) | ((py & 1) << 1), parent, d->labels,
	                                d->residuals, block);
}

struct level_job {
	const struct relief_file *f;
	uint32_t level;
	const int32_t *parents; /* level - 1 blocks */
	int32_t *blocks;
};

/* Patch i of the level's index window (row-major, cols_l a row; relief_index_windows()). */
static int decode_one(void *ctx, size_t i)
{
	struct level_job *j = ctx;
	const struct relief_layout *lay = &j->f->layout;
	const struct relief_header *h = &j->f->hdr;
	const size_t EE = (size_t)lay->geom.E * lay->geom.E;
	uint32_t cols = h->index_cols[j->level], px = (uint32_t)i % cols, py = (uint32_t)i / cols;
	/* A patch's parent lies in its level's window whenever the patch lies in its own. */
	const int32_t *parent =
		j->level ? j->parents + ((size_t)(py / 2) * h->index_cols[j->level - 1] + px / 2) * EE : NULL;
	uint32_t id = relief_patch_id(j->level, px, py);
	struct relief_patch_record r;
	relief_file_record(j->f, id, &r);
	if (r.flags & RELIEF_PATCH_EMPTY) { /* nothing valid here nor below: not decoded */
		memset(j->blocks + i * EE, 0, sizeof(int32_t) * EE);
		return 0;
	}
	struct relief_decoder d;
	int ret = relief_decoder_init(&d, j->f);
	if (ret == 0)
		ret = relief_decoder_patch(&d, id, parent, j->blocks + i * EE);
	relief_decoder_finish(&d);
	return ret;
}

int relief_decode_level_blocks(const struct relief_file *f, uint32_t level, unsigned threads, int32_t **blocks_out)
{
	const struct relief_layout *lay = &f->layout;
	if (level >= lay->levels)
		return -EINVAL;
	const size_t EE = (size_t)lay->geom.E * lay->geom.E;
	int32_t *prev = NULL;
	for (uint32_t l = 0; l <= level; l++) {
		size_t n = (size_t)f->hdr.index_cols[l] * f->hdr.index_rows[l];
		int32_t *cur = malloc(sizeof(int32_t) * EE * n);
		if (!cur) {
			free(prev);
			return -ENOMEM;
		}
		struct level_job j = { f, l, prev, cur };
		int ret = relief_parallel_for(n, threads, decode_one, &j);
		free(prev);
		if (ret < 0) {
			free(cur);
			return ret;
		}
		prev = cur;
	}
	*blocks_out = prev;
	return 0;
}

void relief_level_extent(const struct relief_header *h, uint32_t level, uint32_t *w, uint32_t *hgt)
{
	uint32_t shift = h->levels - 1 - level;
	*w = ((h->width - 1) >> shift) + 1;
	*hgt = ((h->height - 1) >> shift) + 1;
}

static int decode_level(const struct relief_file *f, uint32_t level, unsigned threads, float *heights, uint8_t *mask,
                        bool nodata_nan)
{
	int32_t *blocks;
	int ret = relief_decode_level_blocks(f, level, threads, &blocks);
	if (ret < 0)
		return ret;
	const struct relief_layout *lay = &f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E, side = 1u << level, cols = f->hdr.index_cols[level];
	const double q2 = 2.0 * lay->delta[level];
	uint32_t w, h;
	relief_level_extent(&f->hdr, level, &w, &h);
	uint8_t *pmask = malloc((size_t)P * P);
	if (!pmask) {
		free(blocks);
		return -ENOMEM;
	}
	/* Each sample is taken from the patch that owns it: the one whose interior starts at or
	 * before it (shared borders are equal in both patches; the tests check that). Every
	 * sample of the raster lies in a patch of the level's index window. */
	for (uint32_t py = 0; py < f->hdr.index_rows[level]; py++)
		for (uint32_t px = 0; px < cols; px++) {
			uint32_t id = relief_patch_id(level, px, py);
			const int32_t *b = blocks + ((size_t)py * cols + px) * E * E;
			if ((ret = relief_file_mask(f, id, pmask)) < 0) {
				free(pmask);
				free(blocks);
				return ret;
			}
			for (uint32_t y = 0; y < P; y++) {
				uint64_t gy = (uint64_t)py * (P - 1) + y;
				if (gy >= h || (y == P - 1 && py + 1 < side))
					continue;
				for (uint32_t x = 0; x < P; x++) {
					uint64_t gx = (uint64_t)px * (P - 1) + x;
					if (gx >= w || (x == P - 1 && px + 1 < side))
						continue;
					bool valid = pmask[y * P + x];
					heights[gy * w + gx] = valid || !nodata_nan ? (float)(q2 * b[(y + 1) * E + x + 1]) : NAN;
					if (mask)
						mask[gy * w + gx] = valid;
				}
			}
		}
	free(pmask);
	free(blocks);
	return 0;
}

int relief_decode_level(const struct relief_file *f, uint32_t level, unsigned threads, float *heights, uint8_t *mask)
{
	return decode_level(f, level, threads, heights, mask, true);
}

int relief_decode_level_drawn(const struct relief_file *f, uint32_t level, unsigned threads, float *heights,
                              uint8_t *mask)
{
	return decode_level(f, level, threads, heights, mask, false);
}
