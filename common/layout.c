#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "layout.h"

int relief_layout_init(struct relief_layout *lay, uint32_t patch, uint32_t levels, uint32_t ratio, double tolerance)
{
	if ((patch != 65 && patch != 129 && patch != 257) || levels < 1 || levels > RELIEF_MAX_LEVELS ||
	    (ratio != 2 && ratio != 3) || !(tolerance >= 1e-4 && tolerance <= 1e4))
		return -EINVAL;
	memset(lay, 0, sizeof(*lay));
	int ret = relief_patch_geom_init(&lay->geom, patch);
	if (ret < 0)
		return ret;
	lay->levels = levels;
	lay->size = relief_level_size(lay, levels - 1);
	lay->ratio = ratio;
	lay->blocks = (patch - 1) / RELIEF_BLOCK_CELLS;
	lay->patch_count = relief_level_first_id(levels);
	lay->tolerance = tolerance;
	double d = tolerance;
	for (int l = (int)levels - 1; l >= 0; l--) {
		lay->delta[l] = d;
		d *= ratio;
	}
	return 0;
}

uint32_t relief_layout_levels_for(uint32_t patch, uint32_t width, uint32_t height)
{
	uint64_t need = width > height ? width : height;
	uint32_t L = 0;
	while ((uint64_t)(patch - 1) * (1ull << L) + 1 < need && L < 63)
		L++;
	return L + 1;
}

uint32_t relief_level_coded(const struct relief_layout *lay, uint32_t extent, uint32_t l, bool rim)
{
	const uint64_t step = 1ull << (lay->levels - 1 - l);
	uint64_t n = (extent + step - 1) / step; /* level-l samples with a finest index < extent */
	n += rim;                                /* and the first one past it */
	if (l > 0)
		n += n & 1; /* the first even one at or beyond (patch origins are even) */
	return (uint32_t)n;
}

/* Window end along one axis (l > 0): the local index of the first sample not coded. */
static int32_t window_end(const struct relief_layout *lay, uint32_t extent, uint32_t l, uint32_t origin, bool rim)
{
	const uint32_t P = lay->geom.P, S = relief_level_size(lay, l);
	const uint64_t n = relief_level_coded(lay, extent, l, rim);
	if ((uint64_t)origin + P >= S || n >= (uint64_t)origin + P + 1)
		return (int32_t)P + 1; /* the grid's ring, or no padding inside the patch */
	return n <= origin ? 0 : (int32_t)(n - origin);
}

void relief_patch_window(const struct relief_layout *lay, uint32_t width, uint32_t height, uint32_t l, uint32_t px,
                         uint32_t py, bool rim, struct relief_window *win)
{
	if (l == 0) {
		/* The root codes the samples inside the extent (with the rim, and the first past
		 * it); every other one, its west and north ring included, takes the MED prediction
		 * (residual 0), which its decoder computes in raster order from what came before,
		 * so any sample outside a rectangle from (0, 0) may be skipped. */
		*win = (struct relief_window){ 0, 0, (int32_t)relief_level_coded(lay, width, 0, rim),
		                               (int32_t)relief_level_coded(lay, height, 0, rim), false, false };
		return;
	}
	const uint32_t step = lay->geom.P - 1;
	win->x0 = -1;
	win->y0 = -1;
	win->x1 = window_end(lay, width, l, px * step, rim);
	win->y1 = window_end(lay, height, l, py * step, rim);
	win->ring_west = px == 0;
	win->ring_north = py == 0;
}

bool relief_patch_coords(const struct relief_layout *lay, uint32_t id, uint32_t *l, uint32_t *px, uint32_t *py)
{
	if (id >= lay->patch_count)
		return false;
	uint32_t level = 0;
	while (relief_level_first_id(level + 1) <= id)
		level++;
	uint32_t local = id - relief_level_first_id(level);
	*l = level;
	*px = local % (1u << level);
	*py = local / (1u << level);
	return true;
}

int relief_qgrid_init(struct relief_qgrid *g, uint32_t size, uint32_t w, uint32_t h)
{
	if (w > size || h > size)
		return -EINVAL;
	g->size = size;
	g->w = w;
	g->h = h;
	g->q = calloc((size_t)(w + 2) * (h + 2), sizeof(int32_t));
	return g->q ? 0 : -ENOMEM;
}

void relief_qgrid_finish(struct relief_qgrid *g)
{
	if (!g)
		return;
	free(g->q);
	g->q = NULL;
}

void relief_qgrid_get_patch(const struct relief_qgrid *g, const struct relief_patch_geom *geom,
                            uint32_t px, uint32_t py, int32_t *block)
{
	/* Patch local -1 = global px (P-1) - 1; the patch lies inside the window. */
	const int x0 = (int)(px * (geom->P - 1)) - 1, y0 = (int)(py * (geom->P - 1)) - 1;
	for (uint32_t y = 0; y < geom->E; y++)
		memcpy(block + (size_t)y * geom->E, g->q + relief_qgrid_index(g, x0, y0 + (int)y), sizeof(int32_t) * geom->E);
}
