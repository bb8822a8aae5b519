/* One-shot command submission and GPU timestamps. */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
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

int relief_vk_cmd_record(struct relief_vk *vk, VkCommandBuffer *cmd)
{
	if (vk->capture) {
		*cmd = vk->capture;
		return 0;
	}
	return relief_vk_cmd_begin(vk, cmd);
}

int relief_vk_cmd_reuse(struct relief_vk *vk, VkCommandBuffer own, VkCommandBuffer *cmd)
{
	if (vk->capture) {
		*cmd = vk->capture;
		return 0;
	}
	*cmd = own;
	VkCommandBufferBeginInfo begin = {
		.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
		.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
	};
	int ret = relief_vk_check(vk, vkResetCommandBuffer(own, 0), "vkResetCommandBuffer");
	return ret < 0 ? ret : relief_vk_check(vk, vkBeginCommandBuffer(own, &begin), "vkBeginCommandBuffer");
}

void relief_vk_cmd_free(struct relief_vk *vk, VkCommandBuffer cmd)
{
	if (cmd && cmd != vk->capture)
		vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
}

int relief_vk_cmd_submit_kept(struct relief_vk *vk, VkCommandBuffer cmd, VkFence fence)
{
	if (cmd == vk->capture) {
		if (fence && vk->capture_n_fences == RELIEF_VK_CAPTURE_FENCES)
			return -ENOSPC;
		if (fence)
			vk->capture_fences[vk->capture_n_fences++] = fence;
		return 0;
	}
	int ret = relief_vk_check(vk, vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
	VkSubmitInfo submit = {
		.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
		.commandBufferCount = 1,
		.pCommandBuffers = &cmd,
	};
	if (ret == 0)
		ret = relief_vk_check(vk, vkQueueSubmit(vk->queue, 1, &submit, fence), "vkQueueSubmit");
	return ret;
}

int relief_vk_cmd_submit(struct relief_vk *vk, VkCommandBuffer cmd, VkFence fence)
{
	int ret = relief_vk_cmd_submit_kept(vk, cmd, fence);
	if (ret < 0)
		relief_vk_cmd_free(vk, cmd); /* not the capture's */
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

int relief_vk_capture_begin(struct relief_vk *vk)
{
	if (vk->capture)
		return -EBUSY;
	int ret = relief_vk_cmd_begin(vk, &vk->capture);
	if (ret < 0)
		vk->capture = VK_NULL_HANDLE;
	vk->capture_n_fences = 0;
	return ret;
}

int relief_vk_capture_end(struct relief_vk *vk)
{
	VkCommandBuffer cmd = vk->capture;
	if (!cmd)
		return -EINVAL;
	vk->capture = VK_NULL_HANDLE;
	int ret = relief_vk_cmd_submit_kept(vk, cmd, VK_NULL_HANDLE);
	/* An empty submission signals its fence once everything submitted before is done. */
	for (uint32_t i = 0; i < vk->capture_n_fences && ret == 0; i++)
		ret = relief_vk_check(vk, vkQueueSubmit(vk->queue, 0, NULL, vk->capture_fences[i]), "vkQueueSubmit");
	int wait = relief_vk_check(vk, vkQueueWaitIdle(vk->queue), "vkQueueWaitIdle");
	vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
	vk->capture_n_fences = 0;
	return ret < 0 ? ret : wait;
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

int relief_vk_timer_ticks(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t slot, uint64_t *ticks)
{
	if (!t->pool)
		return -ENOTSUP;
	if (slot >= t->count)
		return -EINVAL;
	int ret = relief_vk_check(vk, vkGetQueryPoolResults(vk->device, t->pool, slot, 1, sizeof(uint64_t), ticks,
	                                                    sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
	                          "vkGetQueryPoolResults");
	if (ret == 0 && vk->timestamp_valid_bits < 64)
		*ticks &= (1ull << vk->timestamp_valid_bits) - 1;
	return ret;
}

int64_t relief_vk_ticks_ns(const struct relief_vk *vk, uint64_t from, uint64_t to)
{
	/* The difference modulo 2^bits, read as signed: right while |to - from| is under half
	 * the counter's range (at least 2^35 ticks where a queue has timestamps at all). */
	uint32_t bits = vk->timestamp_valid_bits < 64 ? vk->timestamp_valid_bits : 64;
	if (bits == 0)
		return 0;
	const uint64_t mask = bits < 64 ? (1ull << bits) - 1 : UINT64_MAX;
	uint64_t d = (to - from) & mask;
	bool negative = (d >> (bits - 1)) & 1;
	uint64_t magnitude = negative ? (0 - d) & mask : d; /* at most 2^(bits - 1) */
	double ns = (double)magnitude * vk->props.limits.timestampPeriod;
	if (ns >= 9.2e18)
		return negative ? -INT64_MAX : INT64_MAX;
	return negative ? -(int64_t)llround(ns) : (int64_t)llround(ns);
}

uint64_t relief_vk_ticks_elapsed_ns(const struct relief_vk *vk, uint64_t from, uint64_t to)
{
	int64_t d = relief_vk_ticks_ns(vk, from, to);
	return d > 0 ? (uint64_t)d : 0;
}

int relief_vk_timer_ns(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t from, uint32_t to,
                       uint64_t *ns)
{
	uint64_t a, b;
	int ret = relief_vk_timer_ticks(vk, t, from, &a);
	if (ret == 0)
		ret = relief_vk_timer_ticks(vk, t, to, &b);
	if (ret < 0)
		return ret;
	*ns = relief_vk_ticks_elapsed_ns(vk, a, b);
	return 0;
}
