#include <string.h>

#include "target.h"

static int create_pass(struct relief_vk *vk, struct relief_vk_target *t)
{
	VkAttachmentDescription att[2] = {
		{
			.format = VK_FORMAT_R8G8B8A8_UNORM,
			.samples = VK_SAMPLE_COUNT_1_BIT,
			.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR,
			.storeOp = VK_ATTACHMENT_STORE_OP_STORE,
			.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE,
			.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE,
			.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
			.finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
		},
		{
			.format = VK_FORMAT_D32_SFLOAT,
			.samples = VK_SAMPLE_COUNT_1_BIT,
			.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR,
			.storeOp = VK_ATTACHMENT_STORE_OP_STORE,
			.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE,
			.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE,
			.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
			.finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
		},
	};
	VkAttachmentReference color_ref = { 0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL };
	VkAttachmentReference depth_ref = { 1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL };
	VkSubpassDescription sub = {
		.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS,
		.colorAttachmentCount = 1,
		.pColorAttachments = &color_ref,
		.pDepthStencilAttachment = &depth_ref,
	};
	const VkPipelineStageFlags attach_stages = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
		VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
	VkSubpassDependency deps[2] = {
		{
			/* A previous frame's copy-out must finish before this frame clears. */
			.srcSubpass = VK_SUBPASS_EXTERNAL,
			.dstSubpass = 0,
			.srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT,
			.dstStageMask = attach_stages,
			.srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT,
			.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
			                 VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
		},
		{
			/* Attachment writes must land before the copy-out reads them. */
			.srcSubpass = 0,
			.dstSubpass = VK_SUBPASS_EXTERNAL,
			.srcStageMask = attach_stages,
			.dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT,
			.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
			.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT,
		},
	};
	VkRenderPassCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO,
		.attachmentCount = 2,
		.pAttachments = att,
		.subpassCount = 1,
		.pSubpasses = &sub,
		.dependencyCount = 2,
		.pDependencies = deps,
	};
	return relief_vk_check(vk, vkCreateRenderPass(vk->device, &info, NULL, &t->pass), "vkCreateRenderPass");
}

int relief_vk_target_init(struct relief_vk *vk, struct relief_vk_target *t, uint32_t width, uint32_t height)
{
	memset(t, 0, sizeof(*t));
	t->width = width;
	t->height = height;
	VkDeviceSize bytes = (VkDeviceSize)width * height * 4;
	int ret;
	if ((ret = relief_vk_image_init(vk, &t->color, VK_FORMAT_R8G8B8A8_UNORM, width, height, 1, VK_IMAGE_VIEW_TYPE_2D,
	                                VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
	                                VK_IMAGE_ASPECT_COLOR_BIT)) < 0 ||
	    (ret = relief_vk_image_init(vk, &t->depth, VK_FORMAT_D32_SFLOAT, width, height, 1, VK_IMAGE_VIEW_TYPE_2D,
	                                VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
	                                VK_IMAGE_ASPECT_DEPTH_BIT)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &t->color_readback, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, RELIEF_VK_MEMORY_READBACK)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &t->depth_readback, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, RELIEF_VK_MEMORY_READBACK)) < 0 ||
	    (ret = create_pass(vk, t)) < 0)
		goto fail;
	VkImageView views[2] = { t->color.view, t->depth.view };
	VkFramebufferCreateInfo fb = {
		.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO,
		.renderPass = t->pass,
		.attachmentCount = 2,
		.pAttachments = views,
		.width = width,
		.height = height,
		.layers = 1,
	};
	ret = relief_vk_check(vk, vkCreateFramebuffer(vk->device, &fb, NULL, &t->framebuffer), "vkCreateFramebuffer");
	if (ret < 0)
		goto fail;
	return 0;
fail:
	relief_vk_target_finish(vk, t);
	return ret;
}

void relief_vk_target_finish(struct relief_vk *vk, struct relief_vk_target *t)
{
	if (!t)
		return;
	if (t->framebuffer)
		vkDestroyFramebuffer(vk->device, t->framebuffer, NULL);
	if (t->pass)
		vkDestroyRenderPass(vk->device, t->pass, NULL);
	relief_vk_buffer_finish(vk, &t->color_readback);
	relief_vk_buffer_finish(vk, &t->depth_readback);
	relief_vk_image_finish(vk, &t->color);
	relief_vk_image_finish(vk, &t->depth);
	memset(t, 0, sizeof(*t));
}

void relief_vk_target_begin(struct relief_vk_target *t, VkCommandBuffer cmd, const float clear[4], float depth_clear)
{
	VkClearValue clears[2];
	memcpy(clears[0].color.float32, clear, sizeof(float) * 4);
	clears[1].depthStencil = (VkClearDepthStencilValue){ depth_clear, 0 };
	VkRenderPassBeginInfo begin = {
		.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO,
		.renderPass = t->pass,
		.framebuffer = t->framebuffer,
		.renderArea = { { 0, 0 }, { t->width, t->height } },
		.clearValueCount = 2,
		.pClearValues = clears,
	};
	vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
	VkViewport vp = { 0.0f, 0.0f, (float)t->width, (float)t->height, 0.0f, 1.0f };
	VkRect2D scissor = { { 0, 0 }, { t->width, t->height } };
	vkCmdSetViewport(cmd, 0, 1, &vp);
	vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void relief_vk_target_end(struct relief_vk_target *t, VkCommandBuffer cmd)
{
	vkCmdEndRenderPass(cmd);
	VkBufferImageCopy color = {
		.imageSubresource = { VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1 },
		.imageExtent = { t->width, t->height, 1 },
	};
	VkBufferImageCopy depth = color;
	depth.imageSubresource.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
	vkCmdCopyImageToBuffer(cmd, t->color.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
	                       t->color_readback.buffer, 1, &color);
	vkCmdCopyImageToBuffer(cmd, t->depth.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
	                       t->depth_readback.buffer, 1, &depth);
	VkMemoryBarrier host = {
		.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
		.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
		.dstAccessMask = VK_ACCESS_HOST_READ_BIT,
	};
	vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host,
	                     0, NULL, 0, NULL);
}
