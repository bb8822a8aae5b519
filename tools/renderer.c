#include <string.h>

#include "cli.h"
#include "renderer.h"

int tool_renderer_init(struct tool_renderer *r, const struct relief_vk_options *vo, const struct relief_file *f,
                       const struct relief_patch_cache_options *co, uint32_t width, uint32_t height)
{
	memset(r, 0, sizeof(*r));
	int ret;
	if ((ret = relief_vk_create(vo, &r->vk)) < 0 || (ret = relief_vk_target_init(r->vk, &r->target, width, height)) < 0 ||
	    (ret = relief_patch_cache_create(r->vk, f, co, &cli_log, &r->cache)) < 0 ||
	    (ret = relief_terrain_create(r->vk, f, r->cache, &r->target, &r->terrain)) < 0)
		tool_renderer_finish(r);
	return ret;
}

void tool_renderer_finish(struct tool_renderer *r)
{
	if (!r)
		return;
	relief_terrain_destroy(r->terrain);
	relief_patch_cache_destroy(r->cache);
	if (r->vk)
		relief_vk_target_finish(r->vk, &r->target);
	relief_vk_destroy(r->vk);
	memset(r, 0, sizeof(*r));
}
