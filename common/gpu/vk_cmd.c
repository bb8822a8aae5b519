/* One-shot command submission and GPU timestamps. */
#include <errno.h>
#include <string.h>

#include "pipeline.h"
#include "vk.h"

int relief_vk_cmd_begin(struct relief_vk *vk, VkCommandBuffer *cmd)
{
	VkCommandBufferAllocateInfo alloc = {
		.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
		.commandPool = vk->cmd_pool,
		.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
		.commandBufferCount = 1,
	};
	int ret = relief_vk_check(vk, vkAllocateCommandBuffers(vk->device, &alloc, cmd), "vkAllocateCommandBuffers");
	if (ret < 0)
		return ret;
	VkCommandBufferBeginInfo begin = {
		.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
		.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
	};
	ret = relief_vk_check(vk, vkBeginCommandBuffer(*cmd, &begin), "vkBeginCommandBuffer");
	if (ret < 0)
		vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, cmd);
	return ret;
}

int relief_vk_cmd_submit(struct relief_vk *vk, VkCommandBuffer cmd, VkFence fence)
{
	int ret = relief_vk_check(vk, vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
	VkSubmitInfo submit = {
		.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
		.commandBufferCount = 1,
		.pCommandBuffers = &cmd,
	};
	if (ret == 0)
		ret = relief_vk_check(vk, vkQueueSubmit(vk->queue, 1, &submit, fence), "vkQueueSubmit");
	if (ret < 0)
		vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
	return ret;
}

int relief_vk_cmd_submit_wait(struct relief_vk *vk, VkCommandBuffer cmd)
{
	VkFence fence = VK_NULL_HANDLE;
	VkFenceCreateInfo fi = { .sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO };
	int ret = relief_vk_check(vk, vkCreateFence(vk->device, &fi, NULL, &fence), "vkCreateFence");
	if (ret < 0) {
		vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
		return ret;
	}
	if ((ret = relief_vk_cmd_submit(vk, cmd, fence)) == 0) {
		ret = relief_vk_check(vk, vkWaitForFences(vk->device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
		vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
	}
	vkDestroyFence(vk->device, fence, NULL);
	return ret;
}

int relief_vk_timer_init(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t count)
{
	memset(t, 0, sizeof(*t));
	if (vk->timestamp_valid_bits == 0)
		return -ENOTSUP;
	int ret = relief_vk_query_pool_create(vk, 0, count, &t->pool);
	if (ret == 0)
		t->count = count;
	return ret;
}

void relief_vk_timer_finish(struct relief_vk *vk, struct relief_vk_timer *t)
{
	if (t && t->pool)
		vkDestroyQueryPool(vk->device, t->pool, NULL);
	if (t)
		memset(t, 0, sizeof(*t));
}

void relief_vk_timer_reset(struct relief_vk_timer *t, VkCommandBuffer cmd)
{
	if (t->pool)
		vkCmdResetQueryPool(cmd, t->pool, 0, t->count);
}

void relief_vk_timer_write(struct relief_vk_timer *t, VkCommandBuffer cmd, uint32_t slot,
                           VkPipelineStageFlagBits stage)
{
	if (t->pool)
		vkCmdWriteTimestamp(cmd, stage, t->pool, slot);
}

int relief_vk_timer_ns(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t from, uint32_t to,
                       uint64_t *ns)
{
	if (!t->pool)
		return -ENOTSUP;
	if (from >= t->count || to >= t->count)
		return -EINVAL;
	uint64_t stamps[2];
	int ret = relief_vk_check(vk, vkGetQueryPoolResults(vk->device, t->pool, from, 1, sizeof(uint64_t),
	                          &stamps[0], sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
	                          "vkGetQueryPoolResults");
	if (ret == 0)
		ret = relief_vk_check(vk, vkGetQueryPoolResults(vk->device, t->pool, to, 1, sizeof(uint64_t),
		                      &stamps[1], sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
		                      "vkGetQueryPoolResults");
	if (ret < 0)
		return ret;
	uint64_t mask = vk->timestamp_valid_bits >= 64 ? UINT64_MAX : (1ull << vk->timestamp_valid_bits) - 1;
	uint64_t ticks = (stamps[1] - stamps[0]) & mask;
	*ns = (uint64_t)((double)ticks * vk->props.limits.timestampPeriod + 0.5);
	return 0;
}
