/* An off-screen render target: RGBA8 colour + D32 depth, a render pass that clears both,
 * and host-visible buffers the frame is copied into for readback.
 *
 * Ownership: the target owns its images, render pass, framebuffer and readback buffers;
 * relief_vk_target_finish() releases them (NULL and half-built targets are fine). */
#pragma once

#include "vk.h"

struct relief_vk_target {
	uint32_t width, height;
	struct relief_vk_image color, depth;
	VkRenderPass pass;
	VkFramebuffer framebuffer;
	/* Valid after the command buffer recorded by relief_vk_target_end() has completed:
	 * color_readback.map holds width*height RGBA8 pixels, depth_readback.map width*height
	 * floats (Vulkan depth in [0, 1]), both row-major from the top row. */
	struct relief_vk_buffer color_readback, depth_readback;
};

int relief_vk_target_init(struct relief_vk *vk, struct relief_vk_target *t, uint32_t width, uint32_t height);
void relief_vk_target_finish(struct relief_vk *vk, struct relief_vk_target *t);
/* Begins the render pass (clears colour to `clear`, depth to `depth_clear`: 1 for a
 * standard depth range, 0 for reversed Z) and sets the viewport and scissor to the whole
 * target. */
void relief_vk_target_begin(struct relief_vk_target *t, VkCommandBuffer cmd, const float clear[4], float depth_clear);
/* Ends the render pass and records the copies into the readback buffers, with the barriers
 * that make them visible to the host once the command buffer completes. */
void relief_vk_target_end(struct relief_vk_target *t, VkCommandBuffer cmd);
