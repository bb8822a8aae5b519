#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "crc32c.h"
#include "fill.h"
#include "format.h"
#include "le.h"
#include "pack.h"
#include "parallel.h"
#include "patch_error.h"

void relief_dem_finish(struct relief_dem *d)
{
	if (!d)
		return;
	free(d->heights);
	free(d->valid);
	free(d->crs_wkt);
	free(d->raw16);
	memset(d, 0, sizeof(*d));
}

static float float_down(double v)
{
	float f = (float)v;
	if ((double)f > v)
		f = nextafterf(f, -INFINITY);
	return f;
}

struct packer {
	const struct relief_dem *dem;
	const struct relief_pack_options *opts;
	struct relief_layout lay;
	struct relief_qgrid q[RELIEF_MAX_LEVELS];
	uint32_t level; /* for the per-level row jobs */
	struct relief_original orig;
	/* What coded samples are quantised from (level_target()): the raster's heights, or
	 * with no-data the fill (target_own) */
	const float *target;
	float *target_own;
	uint16_t *ring; /* with no-data: each raster sample's ring (common/fill.h), else NULL */
	uint32_t coded[RELIEF_MAX_LEVELS][2]; /* relief_level_coded() of width and height */
	struct relief_finest finest; /* what block errors are measured against */

	/* The file's index layout (relief_index_windows()): the per-patch results below have
	 * one element per index entry, the patches whose footprint starts inside the raster;
	 * every other patch is EMPTY by construction and costs nothing. */
	struct relief_header index;

	/* per entry results */
	struct relief_patch_record *rec;
	uint8_t **stream;
	/* per entry with data (NULL for EMPTY ones): measured block errors and the blocks'
	 * height ranges, encoded when the file is assembled */
	double **eps, **ranges;
	uint8_t **mask; /* coded masks of MASKED patches */
	size_t *mask_size;

	pthread_mutex_t lock;
	uint32_t done;
	uint64_t bytes_done;
	double level_err[RELIEF_MAX_LEVELS];
};

/* True when level-l sample (x, y) is coded by every patch stream that holds it
 * (relief_level_coded()), so that the packer may pick its value; the streams skip the
 * others, which take the prediction (label 0, residual 0). */
static inline bool level_coded(const struct packer *p, uint32_t l, int x, int y)
{
	return x >= 0 && y >= 0 && (uint32_t)x < p->coded[l][0] && (uint32_t)y < p->coded[l][1];
}

/* The Chebyshev distance (finest samples) from level-l sample (x, y) to the data: the
 * fill's ring at the nearest raster sample, or the distance past the raster's edge if
 * larger. Exact inside the raster; past its edge at most the true distance. *i receives
 * that raster sample's index. */
static inline uint64_t level_data_distance(const struct packer *p, uint32_t l, int x, int y, uint64_t *i)
{
	const uint64_t step = 1ull << (p->lay.levels - 1 - l), W = p->dem->width, H = p->dem->height;
	const uint64_t X = (uint64_t)x * step, Y = (uint64_t)y * step;
	const uint64_t cx = X < W ? X : W - 1, cy = Y < H ? Y : H - 1;
	*i = cy * W + cx;
	uint64_t d = p->ring ? p->ring[*i] : 0;
	d = X - cx > d ? X - cx : d;
	return Y - cy > d ? Y - cy : d;
}

/* The height a coded level-l sample (x, y) is quantised from, in *h, or false when the
 * packer leaves it to the prediction. Valid samples take the raster's height. So do the
 * samples within one level-l sample spacing (2^(L-1-l) finest samples, Chebyshev) of the
 * data, from the fill (common/fill.h) at no-data samples and from the nearest raster
 * sample past the raster's east and south edges: the half cell a renderer draws beyond a
 * valid sample leans towards its neighbours, so they must lie at the data's height. The
 * rule is a distance against the level's spacing, so a sample filled at a level is filled
 * at every coarser one, where it sits at the same place: the refined labels never clamp
 * (quantise_refined()). Samples farther out cost almost nothing as predictions. */
static inline bool level_target(const struct packer *p, uint32_t l, int x, int y, double *h)
{
	if (!level_coded(p, l, x, y))
		return false;
	uint64_t i;
	if (level_data_distance(p, l, x, y, &i) > 1ull << (p->lay.levels - 1 - l))
		return false;
	*h = p->target[i];
	return true;
}

/* Whether level-l sample (x, y) is valid in its patch's mask. At the finest level: an
 * original, valid sample. Above it: a coded sample within half the level's spacing
 * (Chebyshev, finest samples) of a valid one, so at the data's height (level_target()).
 * A renderer keeps a fragment where its nearest sample is valid, and the finest sample
 * nearest a fragment lies within half a level-l spacing of the level-l sample nearest it;
 * so a patch of any level draws wherever the finest level does, and past the data's edge
 * at most half its spacing more. (Until the forty-fourth December 2026 session a coarse
 * sample was valid where the finest sample under it was: a coarse patch left out up to
 * half its spacing of the data's edge, and a no-data sample on its grid cut a hole a
 * coarse cell wide.) */
static inline bool level_valid(const struct packer *p, uint32_t l, int x, int y)
{
	if (x < 0 || y < 0)
		return false;
	const uint32_t k = p->lay.levels - 1 - l;
	if (k == 0)
		return (uint32_t)x < p->dem->width && (uint32_t)y < p->dem->height &&
		       p->dem->valid[(size_t)y * p->dem->width + (size_t)x];
	uint64_t i;
	return level_coded(p, l, x, y) && level_data_distance(p, l, x, y, &i) <= 1ull << (k - 1);
}

/* The last refined (even) index along a window side of n samples of a level of side S
 * (odd): the last inside both, rounded down to even. */
static inline uint32_t last_refined(uint32_t n, uint32_t S)
{
	return (n < S - 1 ? n : S - 1) & ~1u;
}

/* Level quantisation, pass 1: the refined samples (x, y even, inside), row 2*row2.
 * Level 0 quantises the samples level_target() gives a height.
 * Level l > 0 refines the parent: q = k q_parent + r, r clamped to {-1, 0, 1}. For k = 2
 * the clamp never acts (|h/(2 delta) - 2 q_parent| <= 1); for k = 3 only at exact ties
 * (|.| = 1.5), where r = +-1 still gives |h - 2 delta q| = delta. That holds for filled
 * no-data samples as for valid ones: such a sample's parent is coded (relief_level_coded()
 * halves to at most the parent's) and filled too (level_target()), from the same height.
 * The other samples take r = 0. */
static int quantise_refined(void *ctx, size_t row2)
{
	struct packer *p = ctx;
	uint32_t l = p->level;
	struct relief_qgrid *g = &p->q[l];
	const uint32_t S = g->size;
	const double inv = 1.0 / (2.0 * p->lay.delta[l]);
	if (l == 0) {
		/* The root level is the root patch (ring included): the samples with a target are
		 * quantised, the others (its ring, past the extent, far from the data) take the root
		 * coder's MED prediction, so their residual is 0. Raster order matters here, so the root is
		 * done by one call. */
		const size_t E = S + 2; /* the root's window is the whole level */
		for (size_t i = 0; i < E * E; i++) {
			int x = (int)(i % E) - 1, y = (int)(i / E) - 1;
			double h;
			g->q[i] = level_target(p, 0, x, y, &h) ? (int32_t)llround(h * inv)
			                                       : relief_root_predict(g->q, (uint32_t)E, (uint32_t)(x + 1),
			                                                             (uint32_t)(y + 1));
		}
		return 0;
	}
	const int32_t k = (int32_t)p->lay.ratio;
	const struct relief_qgrid *pg = &p->q[l - 1];
	int y = 2 * (int)row2, last = (int)last_refined(g->w, S);
	for (int x = 0; x <= last; x += 2) {
		int32_t qp = pg->q[relief_qgrid_index(pg, x / 2, y / 2)], r = 0;
		double h;
		if (level_target(p, l, x, y, &h)) {
			r = (int32_t)llround(h * inv) - k * qp;
			r = r < -1 ? -1 : r > 1 ? 1 : r;
		}
		g->q[relief_qgrid_index(g, x, y)] = k * qp + r;
	}
	return 0;
}

/* Global bilinear prediction of a non-refined sample from the refined ones (index clamped
 * at the grid's edge), the value of every sample without a target (level_target()). Any fixed rule keeps every patch's
 * copy of a sample equal; this one makes most of their residuals 0. In a window smaller
 * than the level, the index is clamped at the window's last refined (even) column or row
 * (only refined samples are read: pass 2 writes the others concurrently), so the window's
 * last column or row can differ from the whole level's, which pack_windows() keeps clear
 * of every value a patch reads. */
static int32_t global_predict(const struct relief_qgrid *g, int x, int y)
{
	const int xe = (int)last_refined(g->w, g->size), ye = (int)last_refined(g->h, g->size);
	int x0 = x & 1 ? x - 1 : x, x1 = x & 1 ? x + 1 : x, y0 = y & 1 ? y - 1 : y, y1 = y & 1 ? y + 1 : y;
	x0 = x0 < 0 ? 0 : x0; x1 = x1 > xe ? xe : x1;
	y0 = y0 < 0 ? 0 : y0; y1 = y1 > ye ? ye : y1;
	const int32_t *q = g->q;
	int64_t sum = (int64_t)q[relief_qgrid_index(g, x0, y0)] + q[relief_qgrid_index(g, x1, y0)] +
	              q[relief_qgrid_index(g, x0, y1)] + q[relief_qgrid_index(g, x1, y1)];
	return (int32_t)((sum + 2) >> 2);
}

/* Pass 2 (levels > 0): every other sample of row y in [-1, h], ring included:
 * q = round(target / (2 delta)) where level_target() gives one, the global prediction
 * elsewhere. */
static int quantise_row(void *ctx, size_t row)
{
	struct packer *p = ctx;
	uint32_t l = p->level;
	struct relief_qgrid *g = &p->q[l];
	const uint32_t S = g->size;
	const double inv = 1.0 / (2.0 * p->lay.delta[l]);
	int y = (int)row - 1;
	int32_t *out = g->q + relief_qgrid_index(g, -1, y);
	for (int x = -1; x <= (int)g->w; x++) {
		if (!(x & 1) && !(y & 1) && x >= 0 && y >= 0 && x < (int)S && y < (int)S)
			continue; /* refined: pass 1 */
		double h;
		out[x + 1] = level_target(p, l, x, y, &h) ? (int32_t)llround(h * inv) : global_predict(g, x, y);
	}
	return 0;
}

static void measure_level_error(struct packer *p, uint32_t l)
{
	const struct relief_qgrid *g = &p->q[l];
	const uint32_t step = 1u << (p->lay.levels - 1 - l);
	const double q2 = 2.0 * p->lay.delta[l];
	double worst = 0.0;
	for (uint64_t Y = 0; Y < p->dem->height; Y += step)
		for (uint64_t X = 0; X < p->dem->width; X += step) {
			size_t i = (size_t)Y * p->dem->width + X;
			if (!p->dem->valid[i])
				continue;
			double e = fabs(p->dem->heights[i] - q2 * g->q[relief_qgrid_index(g, (int)(X / step), (int)(Y / step))]);
			worst = e > worst ? e : worst;
		}
	p->level_err[l] = worst;
}

/* The window of each level the packer quantises (relief_qgrid): what the patches holding
 * raster samples read, and what the next finer level's window needs. Level l's patches
 * with a raster sample end at need_l = their last column + 1 (the ring); a window of
 * width w holds the whole level's values at every column up to w - 1 (only the last can
 * differ, global_predict()), given the coarser level's up to w / 2 (a refined sample takes
 * its parent's). So w_l >= need_l + 1 and >= w_{l+1} / 2 + 1; one more of each is kept to
 * spare (with w_l = need_l the tests fail; with both bounds exact they pass), or the
 * level's side. Rows likewise. For a square raster every window is the whole level. */
static void pack_windows(const struct relief_layout *lay, uint32_t width, uint32_t height, uint32_t win[][2])
{
	const uint32_t P = lay->geom.P, L = lay->levels, dims[2] = { width, height };
	for (int l = (int)L - 1; l >= 0; l--) {
		const uint64_t S = relief_level_size(lay, (uint32_t)l), step = 1ull << (L - 1 - (uint32_t)l);
		for (int a = 0; a < 2; a++) {
			uint64_t n = (dims[a] + step - 1) / step; /* level samples over the raster */
			uint64_t need = ((n - 1) / (P - 1) + 1) * (P - 1) + 1, w = need + 2;
			if ((uint32_t)l + 1 < L && w < win[l + 1][a] / 2 + 2)
				w = win[l + 1][a] / 2 + 2;
			win[l][a] = (uint32_t)(w < S ? w : S);
		}
	}
}

uint64_t relief_pack_quantised_samples(const struct relief_layout *lay, uint32_t width, uint32_t height)
{
	uint32_t win[RELIEF_MAX_LEVELS][2];
	pack_windows(lay, width, height, win);
	uint64_t n = 0;
	for (uint32_t l = 0; l < lay->levels; l++)
		n += (uint64_t)(win[l][0] + 2) * (win[l][1] + 2);
	return n;
}

/* Encodes the patch of index entry e (its footprint starts inside the raster, so inside
 * the level's quantised window too). */
static int encode_patch(void *ctx, size_t e)
{
	struct packer *p = ctx;
	const struct relief_patch_geom *geom = &p->lay.geom;
	const uint32_t P = geom->P, E = geom->E;
	uint32_t l, px, py;
	relief_patch_coords(&p->lay, relief_index_patch(&p->index, (uint32_t)e), &l, &px, &py);
	struct relief_patch_record *r = &p->rec[e];
	memset(r, 0, sizeof(*r));
	int ret = 0;
	int32_t *block = NULL;
	double *heights = NULL;
	int8_t *labels = NULL;
	/* block, parent block, residuals (the root codes all E*E values as residuals) */
	block = malloc(sizeof(int32_t) * E * E * 3);
	heights = malloc(sizeof(double) * P * P);
	labels = malloc(geom->n_labels);
	if (!block || !heights || !labels) {
		ret = -ENOMEM;
		goto out;
	}
	int32_t *parent = block + E * E, *residuals = block + 2 * E * E;
	relief_qgrid_get_patch(&p->q[l], geom, px, py, block);
	const double q2 = 2.0 * p->lay.delta[l];
	double hmin = INFINITY, hmax = -INFINITY;
	for (uint32_t y = 0; y < P; y++)
		for (uint32_t x = 0; x < P; x++) {
			double h = q2 * block[(y + 1) * E + x + 1];
			heights[y * P + x] = h;
			hmin = fmin(hmin, h);
			hmax = fmax(hmax, h);
		}
	uint64_t valid_count;
	double err = relief_patch_error(&p->lay, l, px, py, heights, &p->orig, &valid_count);
	if (valid_count == 0) {
		r->flags = RELIEF_PATCH_EMPTY;
		goto out;
	}
	r->height_min = float_down(hmin);
	r->height_max = relief_float_up(hmax);
	r->error = relief_float_up(err);
	p->eps[e] = calloc(relief_block_errors_per_patch(P), sizeof(double));
	p->ranges[e] = calloc(relief_block_ranges_per_patch(P), sizeof(double));
	if (!p->eps[e] || !p->ranges[e]) {
		ret = -ENOMEM;
		goto out;
	}
	double drawn;
	if ((ret = relief_block_errors(&p->lay, l, px, py, heights, &p->finest, p->eps[e], &drawn)) < 0)
		goto out;
	r->draw_error = relief_float_up(drawn);
	relief_block_heights(&p->lay, heights, p->ranges[e]);

	/* Validity mask at this level's samples. */
	uint8_t *mask = malloc((size_t)P * P);
	if (!mask) {
		ret = -ENOMEM;
		goto out;
	}
	bool partial = false;
	for (uint32_t y = 0; y < P; y++)
		for (uint32_t x = 0; x < P; x++) {
			mask[y * P + x] = level_valid(p, l, (int)(px * (P - 1) + x), (int)(py * (P - 1) + y));
			partial |= !mask[y * P + x];
		}
	if (partial) {
		r->flags |= RELIEF_PATCH_MASKED;
		ret = relief_mask_encode(P, mask, &p->mask[e], &p->mask_size[e]);
	}
	free(mask);
	if (ret < 0)
		goto out;

	if (l == 0) {
		relief_root_analyse(geom, block, residuals);
	} else {
		relief_qgrid_get_patch(&p->q[l - 1], geom, px / 2, py / 2, parent);
		ret = relief_patch_analyse(geom, p->lay.ratio, (px & 1) | ((py & 1) << 1), parent, block, labels, residuals);
		if (ret < 0)
			goto out;
	}
	size_t size;
	struct relief_window win;
	relief_patch_window(&p->lay, p->dem->width, p->dem->height, l, px, py, relief_format_has_rim(p->index.version), &win);
	if ((ret = relief_patch_encode(geom, l == 0, &win, labels, residuals, &p->stream[e], &size)) < 0)
		goto out;
	if (size > UINT32_MAX) {
		ret = -EOVERFLOW;
		goto out;
	}
	r->size = (uint32_t)size;
	r->crc = relief_crc32c(0, p->stream[e], size);
out:
	free(block);
	free(heights);
	free(labels);
	if (ret == 0 && p->opts->progress) {
		pthread_mutex_lock(&p->lock);
		p->done++;
		p->bytes_done += r->size;
		p->opts->progress(p->opts->progress_data, p->done, p->index.index_records, p->bytes_done);
		pthread_mutex_unlock(&p->lock);
	}
	return ret;
}

static uint64_t align8(uint64_t v)
{
	return (v + 7) & ~(uint64_t)7;
}

static int assemble(struct packer *p, uint8_t **out, size_t *out_size, struct relief_pack_stats *st)
{
	const struct relief_dem *dem = p->dem;
	const uint32_t n = p->index.index_records, P = p->lay.geom.P;
	const size_t be_per = relief_block_bytes_per_patch(p->index.version, P);
	const size_t ne = relief_block_errors_per_patch(P), nr = relief_block_ranges_per_patch(P);
	struct relief_header h = {
		.version = p->index.version, .patch_size = P, .levels = p->lay.levels, .ratio = p->lay.ratio,
		.block_cells = RELIEF_BLOCK_CELLS, .width = dem->width, .height = dem->height, .size = p->lay.size,
		.source_units = dem->source_units, .patch_count = p->lay.patch_count, .tolerance = p->lay.tolerance,
		.origin_x = dem->origin_x, .origin_y = dem->origin_y, .spacing_x = dem->spacing_x,
		.spacing_y = dem->spacing_y,
	};
	memcpy(h.delta, p->lay.delta, sizeof(h.delta));
	double hmin = INFINITY, hmax = -INFINITY;
	for (size_t i = 0; i < (size_t)dem->width * dem->height; i++)
		if (dem->valid[i]) {
			h.valid_samples++;
			hmin = fmin(hmin, dem->heights[i]);
			hmax = fmax(hmax, dem->heights[i]);
		}
	h.height_min = hmin;
	h.height_max = hmax;
	double largest = 0.0;
	for (uint32_t e = 0; e < n; e++)
		if (!(p->rec[e].flags & RELIEF_PATCH_EMPTY))
			for (size_t i = 0; i < ne; i++)
				largest = isfinite(p->eps[e][i]) && p->eps[e][i] > largest ? p->eps[e][i] : largest;
	h.block_error_unit = relief_block_error_unit(p->lay.tolerance, largest);
	uint64_t data_size = 0;
	for (uint32_t e = 0; e < n; e++) {
		if (p->rec[e].flags & RELIEF_PATCH_MASKED) {
			if (h.masks_size + p->mask_size[e] > UINT32_MAX)
				return -EOVERFLOW;
			p->rec[e].mask_offset = (uint32_t)h.masks_size;
			p->rec[e].mask_size = (uint32_t)p->mask_size[e];
			h.masks_size += p->mask_size[e];
			h.mask_count++;
		}
		if (!(p->rec[e].flags & RELIEF_PATCH_EMPTY)) {
			p->rec[e].offset = data_size;
			data_size += p->rec[e].size;
		}
		st->empty_patches += !!(p->rec[e].flags & RELIEF_PATCH_EMPTY);
	}
	h.block_patches = n - st->empty_patches; /* block records for patches with data only */
	st->empty_patches += p->lay.patch_count - n; /* those without an entry */
	st->masked_patches = h.mask_count;
	st->stream_bytes = data_size;
	size_t crs_len = dem->crs_wkt ? strlen(dem->crs_wkt) : 0;
	h.index_offset = RELIEF_HEADER_SIZE;
	h.block_errors_offset = align8(h.index_offset + (uint64_t)n * RELIEF_INDEX_RECORD_SIZE);
	h.masks_offset = align8(h.block_errors_offset + (uint64_t)h.block_patches * be_per);
	h.crs_offset = align8(h.masks_offset + h.masks_size);
	h.crs_size = (uint32_t)crs_len;
	h.data_offset = align8(h.crs_offset + crs_len);
	h.data_size = data_size;
	h.file_size = h.data_offset + data_size;

	uint8_t *img = calloc(1, h.file_size);
	if (!img)
		return -ENOMEM;
	/* Records, block records, masks and streams in entry order (level by level, row by row
	 * within the window), which is id order: a window's rows are the level's first rows. */
	uint64_t slot = 0;
	for (uint32_t e = 0; e < n; e++) {
		const struct relief_patch_record *r = &p->rec[e];
		relief_record_write(r, img + h.index_offset + (uint64_t)e * RELIEF_INDEX_RECORD_SIZE);
		if (!(r->flags & RELIEF_PATCH_EMPTY)) {
			uint8_t *be = img + h.block_errors_offset + slot++ * be_per;
			for (size_t i = 0; i < ne; i++)
				be[i] = relief_block_error_encode(p->eps[e][i], h.block_error_unit);
			const double *rg = p->ranges[e];
			for (size_t i = 0; i < nr; i += 2)
				be[ne + i / 2] = relief_block_range_encode(rg[i], r->height_min, r->height_max, false) |
				                 relief_block_range_encode(rg[i + 1], r->height_min, r->height_max, true) << 4;
		}
		if (p->rec[e].flags & RELIEF_PATCH_MASKED)
			memcpy(img + h.masks_offset + p->rec[e].mask_offset, p->mask[e], p->mask_size[e]);
		if (!(p->rec[e].flags & RELIEF_PATCH_EMPTY))
			memcpy(img + h.data_offset + p->rec[e].offset, p->stream[e], p->rec[e].size);
	}
	if (crs_len)
		memcpy(img + h.crs_offset, dem->crs_wkt, crs_len);
	h.index_crc = relief_crc32c(0, img + h.index_offset, (uint64_t)n * RELIEF_INDEX_RECORD_SIZE);
	h.block_errors_crc = relief_crc32c(0, img + h.block_errors_offset, (uint64_t)h.block_patches * be_per);
	h.masks_crc = relief_crc32c(0, img + h.masks_offset, h.masks_size);
	h.crs_crc = relief_crc32c(0, img + h.crs_offset, crs_len);
	relief_header_write(&h, img);
	*out = img;
	*out_size = h.file_size;
	st->bytes = h.file_size;
	return 0;
}

static int check_dem(const struct relief_dem *d)
{
	if (!d->width || !d->height || !d->heights || !d->valid)
		return -EINVAL;
	/* What the reader accepts (format.h), so that a packed file always opens. */
	if (!(d->spacing_x >= RELIEF_SPACING_MIN && d->spacing_x <= RELIEF_SPACING_MAX) ||
	    !(d->spacing_y >= RELIEF_SPACING_MIN && d->spacing_y <= RELIEF_SPACING_MAX) ||
	    !(fabs(d->origin_x) <= RELIEF_MAX_COORD) || !(fabs(d->origin_y) <= RELIEF_MAX_COORD))
		return -EINVAL;
	return 0;
}

int relief_pack_memory(const struct relief_dem *dem, const struct relief_pack_options *opts,
                       uint8_t **out, size_t *out_size, struct relief_pack_stats *stats)
{
	int ret = check_dem(dem);
	if (ret < 0)
		return ret;
	if (opts->version && opts->version != 8 && opts->version != RELIEF_FORMAT_VERSION)
		return -EINVAL;
	struct packer *p = calloc(1, sizeof(*p));
	if (!p)
		return -ENOMEM;
	pthread_mutex_init(&p->lock, NULL);
	p->dem = dem;
	p->opts = opts;
	struct relief_pack_stats st = { 0 };
	uint32_t levels = relief_layout_levels_for(opts->patch, dem->width, dem->height);
	ret = levels > RELIEF_MAX_LEVELS ? -EINVAL
	                                 : relief_layout_init(&p->lay, opts->patch, levels, opts->ratio, opts->tolerance);
	if (ret < 0)
		goto out;
	double hmax = 0;
	uint64_t valid = 0;
	for (size_t i = 0; i < (size_t)dem->width * dem->height; i++)
		if (dem->valid[i]) {
			if (!isfinite(dem->heights[i])) {
				ret = -EINVAL;
				goto out;
			}
			hmax = fmax(hmax, fabs(dem->heights[i]));
			valid++;
		}
	if (!valid) {
		ret = -ENODATA;
		goto out;
	}
	if (hmax / (2.0 * p->lay.tolerance) >= (double)(1 << 24)) {
		ret = -ERANGE;
		goto out;
	}
	p->index = (struct relief_header){ .version = opts->version ? opts->version : RELIEF_FORMAT_VERSION,
	                                   .patch_size = opts->patch,
	                                   .levels = p->lay.levels, .width = dem->width, .height = dem->height };
	relief_index_windows(&p->index);
	const uint32_t n = p->index.index_records;
	p->orig = (struct relief_original){ dem->heights, dem->valid, dem->width, dem->height };
	p->target = dem->heights;
	if (valid < (uint64_t)dem->width * dem->height) {
		p->target_own = malloc((size_t)dem->width * dem->height * sizeof(float));
		p->ring = malloc((size_t)dem->width * dem->height * sizeof(uint16_t));
		if (!p->target_own || !p->ring) {
			ret = -ENOMEM;
			goto out;
		}
		if ((ret = relief_fill_nodata(dem->width, dem->height, dem->heights, dem->valid, p->target_own, p->ring)) < 0)
			goto out;
		p->target = p->target_own;
	}
	for (uint32_t l = 0; l < p->lay.levels; l++) {
		p->coded[l][0] = relief_level_coded(&p->lay, dem->width, l, relief_format_has_rim(p->index.version));
		p->coded[l][1] = relief_level_coded(&p->lay, dem->height, l, relief_format_has_rim(p->index.version));
	}
	p->rec = calloc(n, sizeof(*p->rec));
	p->stream = calloc(n, sizeof(*p->stream));
	p->eps = calloc(n, sizeof(*p->eps));
	p->ranges = calloc(n, sizeof(*p->ranges));
	p->mask = calloc(n, sizeof(*p->mask));
	p->mask_size = calloc(n, sizeof(*p->mask_size));
	if (!p->rec || !p->stream || !p->eps || !p->ranges || !p->mask || !p->mask_size) {
		ret = -ENOMEM;
		goto out;
	}
	uint32_t win[RELIEF_MAX_LEVELS][2];
	pack_windows(&p->lay, dem->width, dem->height, win);
	for (uint32_t l = 0; l < p->lay.levels; l++) {
		uint32_t S = relief_level_size(&p->lay, l);
		if (opts->whole_levels)
			win[l][0] = win[l][1] = S;
		if ((ret = relief_qgrid_init(&p->q[l], S, win[l][0], win[l][1])) < 0)
			goto out;
		st.quantised_samples += (uint64_t)(win[l][0] + 2) * (win[l][1] + 2);
		p->level = l;
		if (l == 0) {
			quantise_refined(p, 0);
		} else {
			relief_parallel_for(last_refined(p->q[l].h, S) / 2 + 1, opts->threads, quantise_refined, p);
			relief_parallel_for(p->q[l].h + 2, opts->threads, quantise_row, p);
		}
		measure_level_error(p, l);
	}
	p->finest = (struct relief_finest){ &p->q[p->lay.levels - 1], 2.0 * p->lay.delta[p->lay.levels - 1], &p->orig };
	if ((ret = relief_parallel_for(n, opts->threads, encode_patch, p)) < 0)
		goto out;
	st.levels = p->lay.levels;
	st.patches = p->lay.patch_count;
	memcpy(st.max_error, p->level_err, sizeof(st.max_error));
	if ((ret = assemble(p, out, out_size, &st)) < 0)
		goto out;
	if (stats)
		*stats = st;
out:
	for (uint32_t l = 0; l < RELIEF_MAX_LEVELS; l++)
		relief_qgrid_finish(&p->q[l]);
	for (uint32_t e = 0; e < p->index.index_records; e++) {
		if (p->stream)
			free(p->stream[e]);
		if (p->mask)
			free(p->mask[e]);
		if (p->eps)
			free(p->eps[e]);
		if (p->ranges)
			free(p->ranges[e]);
	}
	free(p->mask);
	free(p->mask_size);
	free(p->stream);
	free(p->rec);
	free(p->eps);
	free(p->ranges);
	free(p->target_own);
	free(p->ring);
	pthread_mutex_destroy(&p->lock);
	free(p);
	return ret;
}

int relief_pack_write(const char *path, const uint8_t *data, size_t size)
{
	size_t n = strlen(path);
	char *tmp = malloc(n + 16);
	if (!tmp)
		return -ENOMEM;
	snprintf(tmp, n + 16, "%s.tmpXXXXXX", path);
	int fd = mkostemp(tmp, O_CLOEXEC);
	if (fd < 0) {
		int e = errno;
		free(tmp);
		return -e;
	}
	int ret = 0;
	size_t off = 0;
	while (off < size) {
		ssize_t w = write(fd, data + off, size - off);
		if (w < 0) {
			if (errno == EINTR)
				continue;
			ret = -errno;
			break;
		}
		off += (size_t)w;
	}
	if (ret == 0 && fchmod(fd, 0644) < 0)
		ret = -errno;
	if (ret == 0 && fsync(fd) < 0)
		ret = -errno;
	if (close(fd) < 0 && ret == 0)
		ret = -errno;
	if (ret == 0 && rename(tmp, path) < 0)
		ret = -errno;
	if (ret < 0)
		unlink(tmp);
	free(tmp);
	return ret;
}
