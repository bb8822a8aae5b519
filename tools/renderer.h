/* The GPU chain the rendering subcommands (snap, fly, bench lod) share: a Vulkan context,
 * an off-screen colour + depth target, the patch cache of one file and the terrain
 * renderer drawing from it. Views are the caller's (relief_terrain_view_create()). */
#pragma once

#include <stdint.h>

#include "format.h"
#include "patch_cache.h"
#include "target.h"
#include "terrain.h"
#include "vk.h"

struct tool_renderer {
	struct relief_vk *vk;
	struct relief_vk_target target;
	struct relief_patch_cache *cache;
	struct relief_terrain *terrain;
};

/* Builds the chain for file f (which must outlive it) with a width x height target. 0, or a
 * negative errno with whatever was built already torn down again. */
int tool_renderer_init(struct tool_renderer *r, const struct relief_vk_options *vo, const struct relief_file *f,
                       const struct relief_patch_cache_options *co, uint32_t width, uint32_t height);
/* Accepts a zeroed, failed or finished renderer. */
void tool_renderer_finish(struct tool_renderer *r);
