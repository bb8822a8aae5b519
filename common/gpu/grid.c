#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "grid.h"
#include "pipeline.h"

#include "grid.vert.spv.h"
#include "grid.tesc.spv.h"
#include "grid.tese.spv.h"
#include "grid.frag.spv.h"

/* Matches GridPush in shaders/grid_common.glsl (std430 push-constant layout). */
struct grid_push {
	float mvp[16];
	float grid[4];
	float light[4];
};

struct relief_grid {
	struct relief_vk *vk;          /* borrowed */
	struct relief_vk_target *target; /* borrowed */
	VkPipelineLayout layout;
	VkPipeline pipeline;
	VkQueryPool stats_pool;
	struct relief_vk_timer timer;
};

double relief_grid_height(double gx, double gy)
{
	const double tau = 6.28318530717958647692;
	return 0.6 * sin(tau * 1.5 * gx) * cos(tau * gy) + 0.4 * sin(tau * 1.4 * (gx + gy));
}

int relief_grid_create(struct relief_vk *vk, struct relief_vk_target *target, struct relief_grid **out)
{
	struct relief_grid *g = calloc(1, sizeof(*g));
	if (!g)
		return -ENOMEM;
	g->vk = vk;
	g->target = target;
	int ret = relief_vk_pipeline_layout_create(vk, sizeof(struct grid_push), VK_NULL_HANDLE, &g->layout);
	if (ret < 0)
		goto fail;
	struct relief_vk_tess_pipeline_desc desc = {
		.vert = RELIEF_SPIRV(grid_vert_spv),
		.tesc = RELIEF_SPIRV(grid_tesc_spv),
		.tese = RELIEF_SPIRV(grid_tese_spv),
		.frag = RELIEF_SPIRV(grid_frag_spv),
		.control_points = 4,
		.layout = g->layout,
		.pass = target->pass,
	};
	if ((ret = relief_vk_tess_pipeline_create(vk, &desc, &g->pipeline)) < 0)
		goto fail;
	if (vk->has.pipeline_statistics &&
	    (ret = relief_vk_query_pool_create(vk, VK_QUERY_PIPELINE_STATISTIC_TESSELLATION_EVALUATION_SHADER_INVOCATIONS_BIT,
	                                       1, &g->stats_pool)) < 0)
		goto fail;
	if ((ret = relief_vk_timer_init(vk, &g->timer, 2)) < 0 && ret != -ENOTSUP)
		goto fail;
	*out = g;
	return 0;
fail:
	relief_grid_destroy(g);
	return ret;
}

void relief_grid_destroy(struct relief_grid *g)
{
	if (!g)
		return;
	VkDevice dev = g->vk->device;
	relief_vk_timer_finish(g->vk, &g->timer);
	if (g->stats_pool)
		vkDestroyQueryPool(dev, g->stats_pool, NULL);
	if (g->pipeline)
		vkDestroyPipeline(dev, g->pipeline, NULL);
	if (g->layout)
		vkDestroyPipelineLayout(dev, g->layout, NULL);
	free(g);
}

int relief_grid_render(struct relief_grid *g, const struct relief_grid_params *p, struct relief_grid_stats *stats)
{
	if (p->patches_per_side == 0 || p->patches_per_side > 4096 || p->factor < 1 || p->factor > 64 ||
	    !(p->size > 0.0) || !isfinite(p->amplitude))
		return -EINVAL;
	struct relief_vk *vk = g->vk;
	struct grid_push push;
	memcpy(push.mvp, p->mvp, sizeof(push.mvp));
	push.grid[0] = (float)p->patches_per_side;
	push.grid[1] = (float)p->size;
	push.grid[2] = (float)p->factor;
	push.grid[3] = (float)p->amplitude;
	memcpy(push.light, p->sun, sizeof(float) * 3);
	push.light[3] = p->shaded ? 1.0f : 0.0f;

	VkCommandBuffer cmd;
	int ret = relief_vk_cmd_begin(vk, &cmd);
	if (ret < 0)
		return ret;
	relief_vk_timer_reset(&g->timer, cmd);
	relief_vk_timer_write(&g->timer, cmd, 0, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT);
	if (g->stats_pool)
		vkCmdResetQueryPool(cmd, g->stats_pool, 0, 1);
	const float clear[4] = { 0.0f, 0.0f, 0.0f, 1.0f };
	relief_vk_target_begin(g->target, cmd, clear, 1.0f);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, g->pipeline);
	vkCmdPushConstants(cmd, g->layout, VK_SHADER_STAGE_ALL_GRAPHICS, 0, sizeof(push), &push);
	if (g->stats_pool)
		vkCmdBeginQuery(cmd, g->stats_pool, 0, 0);
	uint32_t total = p->patches_per_side * p->patches_per_side;
	uint32_t per_draw = relief_vk_quads_per_draw(p->factor);
	uint32_t draws = 0;
	for (uint32_t first = 0; first < total; first += per_draw, draws++) {
		uint32_t count = total - first < per_draw ? total - first : per_draw;
		vkCmdDraw(cmd, 4, count, 0, first);
	}
	if (g->stats_pool)
		vkCmdEndQuery(cmd, g->stats_pool, 0);
	relief_vk_target_end(g->target, cmd);
	relief_vk_timer_write(&g->timer, cmd, 1, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
	if ((ret = relief_vk_cmd_submit_wait(vk, cmd)) < 0)
		return ret;

	struct relief_grid_stats s = { .draws = draws };
	if (g->stats_pool) {
		ret = relief_vk_check(vk, vkGetQueryPoolResults(vk->device, g->stats_pool, 0, 1, sizeof(uint64_t),
		                      &s.tes_invocations, sizeof(uint64_t),
		                      VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT), "vkGetQueryPoolResults");
		if (ret < 0)
			return ret;
	}
	if (g->timer.pool && (ret = relief_vk_timer_ns(vk, &g->timer, 0, 1, &s.gpu_ns)) < 0)
		return ret;
	if (stats)
		*stats = s;
	return 0;
}
