/* A displaced, tessellated grid rendered from an analytic height function: the smoke test
 * of the whole tessellation pipeline (and `relief hello`). The grid is patches_per_side^2
 * quad patches over [0, size]^2, each tessellated with `factor` on every edge and inside,
 * displaced by amplitude * relief_grid_height(). Draws are split so that none exceeds
 * RELIEF_VK_MAX_TESS_VERTICES_PER_DRAW tessellated vertices. */
#pragma once

#include <stdbool.h>

#include "target.h"

struct relief_grid_params {
	uint32_t patches_per_side;
	double size;       /* world units */
	uint32_t factor;   /* 1..64 */
	double amplitude;  /* heights are in [-amplitude, amplitude] */
	float mvp[16];     /* world -> clip, column-major */
	float sun[3];      /* unit vector towards the light */
	bool shaded;       /* false: grey height code t = (h/amplitude + 1)/2 */
};

struct relief_grid_stats {
	uint32_t draws;
	uint64_t tes_invocations; /* 0 when pipeline statistics are not supported */
	uint64_t gpu_ns;          /* 0 when timestamps are not supported */
};

struct relief_grid;

int relief_grid_create(struct relief_vk *vk, struct relief_vk_target *target, struct relief_grid **out);
void relief_grid_destroy(struct relief_grid *grid);
/* Renders one frame into `target` and waits for it; the target's readback buffers then hold it. */
int relief_grid_render(struct relief_grid *grid, const struct relief_grid_params *p,
                       struct relief_grid_stats *stats);
/* The CPU twin of the shader's height function, in units of the amplitude, g in [0,1]^2. */
double relief_grid_height(double gx, double gy);
