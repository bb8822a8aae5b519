/* Terrain views (see terrain.h): each view's buffers in two allocations (device and
 * readback), its two descriptor sets, queries and fence, and what the CPU reads back from
 * its last frame. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline.h"
#include "terrain_internal.h"

int relief_terrain_view_create(struct relief_terrain *t, struct relief_terrain_view **out)
{
	struct relief_vk *vk = t->vk;
	struct relief_terrain_view *v = calloc(1, sizeof(*v));
	if (!v)
		return -ENOMEM;
	v->t = t;
	const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
	const VkBufferUsageFlags indirect = storage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
	const VkBufferUsageFlags read = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
	const VkBufferUsageFlags texels = VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT;
	const struct relief_vk_buffer_spec local[] = {
		{ &v->split[0], 4 * t->count, storage },
		{ &v->split[1], 4 * t->count, storage },
		{ &v->instances, sizeof(struct instance) * t->max_patches, storage | read | texels },
		{ &v->cmds, LIST_PARTS * 16 * (VkDeviceSize)(t->max_draws ? t->max_draws : 1), indirect },
		{ &v->counters, sizeof(struct counters), indirect | read | texels },
		{ &v->wants, sizeof(struct want) * WANT_CAP, storage | read },
		{ &v->drawn, 4 * t->count, storage | texels },
		{ &v->factors, 16 * (VkDeviceSize)t->max_quads + 16, storage | texels },
		{ &v->seals, 16 * (VkDeviceSize)t->max_quads + 16, storage | texels },
		{ &v->borders, 8 * (VkDeviceSize)t->max_patches * (4 * t->blocks + 4), storage | texels },
		{ &v->curtains, 16 * (VkDeviceSize)t->max_patches + 4, storage | texels },
		{ &v->camera, sizeof(struct draw_camera), texels | VK_BUFFER_USAGE_TRANSFER_DST_BIT },
		{ &v->lists, 4 * (VkDeviceSize)t->max_quads, storage | texels },
		{ &v->frontier, 8 * (VkDeviceSize)t->count, storage },
		{ &v->passes, 16 * RELIEF_MAX_LEVELS, indirect },
	};
	const struct relief_vk_buffer_spec readback[] = {
		{ &v->read_counters, sizeof(struct counters), VK_BUFFER_USAGE_TRANSFER_DST_BIT },
		{ &v->read_wants, sizeof(struct want) * WANT_CAP, VK_BUFFER_USAGE_TRANSFER_DST_BIT },
		{ &v->read_instances, sizeof(struct instance) * t->max_patches, VK_BUFFER_USAGE_TRANSFER_DST_BIT },
	};
	int ret;
	if ((ret = relief_vk_buffer_group_init(vk, &v->local, local, sizeof(local) / sizeof(local[0]),
	                                       RELIEF_VK_MEMORY_DEVICE)) < 0 ||
	    (ret = relief_vk_buffer_group_init(vk, &v->readback, readback, sizeof(readback) / sizeof(readback[0]),
	                                       RELIEF_VK_MEMORY_READBACK)) < 0)
		goto fail;
	/* The texel views, in binding order from FIRST_TEXELS_BINDING. */
	const struct { const struct relief_vk_buffer *b; VkFormat format; uint32_t components; } tx[VIEW_TEXELS] = {
		{ &v->instances, VK_FORMAT_R32G32B32A32_UINT, 4 }, { &v->borders, VK_FORMAT_R32G32_UINT, 2 },
		{ &v->factors, VK_FORMAT_R32G32B32A32_UINT, 4 },   { &v->seals, VK_FORMAT_R32G32B32A32_UINT, 4 },
		{ &v->lists, VK_FORMAT_R32_UINT, 1 },         { &v->drawn, VK_FORMAT_R32_UINT, 1 },
		{ &v->counters, VK_FORMAT_R32_UINT, 1 },      { &v->curtains, VK_FORMAT_R32_UINT, 1 },
	};
	for (uint32_t i = 0; i < VIEW_TEXELS; i++) {
		char what[48];
		snprintf(what, sizeof(what), "terrain view: binding %u", FIRST_TEXELS_BINDING + i);
		if ((ret = relief_vk_texel_view_create(vk, tx[i].b, tx[i].format, tx[i].components,
		                                       VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT, &vk->log, what,
		                                       &v->texels[i])) < 0)
			goto fail;
	}
	if ((ret = relief_vk_texel_view_create(vk, &v->camera, VK_FORMAT_R32G32B32A32_SFLOAT, 4,
	                                       VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT, &vk->log,
	                                       "terrain view: the draw camera (binding 15)", &v->camera_view)) < 0)
		goto fail;
	VkDescriptorPoolSize sizes[3] = {
		{ VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * STORAGE_BUFFERS },
		{ VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2 * 2 },
		{ VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 2 * UNIFORM_TEXEL_BUFFERS },
	};
	VkDescriptorPoolCreateInfo pi = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
		.maxSets = 2,
		.poolSizeCount = 3,
		.pPoolSizes = sizes,
	};
	if ((ret = relief_vk_check(vk, vkCreateDescriptorPool(vk->device, &pi, NULL, &v->pool), "vkCreateDescriptorPool")) < 0)
		goto fail;
	VkDescriptorSetLayout layouts[2] = { t->prog->set_layout, t->prog->set_layout };
	VkDescriptorSetAllocateInfo ai = {
		.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
		.descriptorPool = v->pool,
		.descriptorSetCount = 2,
		.pSetLayouts = layouts,
	};
	if ((ret = relief_vk_check(vk, vkAllocateDescriptorSets(vk->device, &ai, v->set), "vkAllocateDescriptorSets")) < 0)
		goto fail;
	const struct relief_patch_pool *pool = relief_patch_cache_pool(t->cache);
	for (int s = 0; s < 2; s++) {
		/* The storage buffers by binding; VK_NULL_HANDLE where views[] or the images serve. */
		VkBuffer bufs[BINDINGS] = { VK_NULL_HANDLE, VK_NULL_HANDLE, v->split[s].buffer, v->split[s ^ 1].buffer,
		                            v->instances.buffer, v->counters.buffer, v->wants.buffer, pool->use_table,
		                            v->cmds.buffer, VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE,
		                            v->drawn.buffer, v->factors.buffer, v->curtains.buffer, VK_NULL_HANDLE,
		                            v->seals.buffer, v->borders.buffer, pool->use_dist, v->lists.buffer,
		                            v->frontier.buffer, v->passes.buffer, VK_NULL_HANDLE,
		                            VK_NULL_HANDLE /* the mesh capture's, written when enabled */ };
		VkBufferView views[BINDINGS] = { [RECORDS_BINDING] = pool->block_view, [CAMERA_BINDING] = v->camera_view,
			                         [INFO_BINDING] = t->info_view, [LAYERS_BINDING] = pool->layer_view,
			                         [WINDOWS_BINDING] = t->windows_view };
		memcpy(views + FIRST_TEXELS_BINDING, v->texels, sizeof(v->texels));
		VkDescriptorBufferInfo bi[BINDINGS];
		VkDescriptorImageInfo ii[2] = {
			{ VK_NULL_HANDLE, pool->heights, VK_IMAGE_LAYOUT_GENERAL },
			{ VK_NULL_HANDLE, pool->normals, VK_IMAGE_LAYOUT_GENERAL },
		};
		VkWriteDescriptorSet w[BINDINGS];
		uint32_t n = 0;
		for (uint32_t i = 0; i < BINDINGS; i++) {
			if (i == MESH_BINDING)
				continue;
			const VkDescriptorType type = binding_type(i);
			bi[i] = (VkDescriptorBufferInfo){ bufs[i], 0, VK_WHOLE_SIZE };
			w[n++] = (VkWriteDescriptorSet){
				.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
				.dstSet = v->set[s],
				.dstBinding = i,
				.descriptorCount = 1,
				.descriptorType = type,
				.pBufferInfo = type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER ? &bi[i] : NULL,
				.pImageInfo = i == 9 ? &ii[0] : i == 10 ? &ii[1] : NULL,
				.pTexelBufferView = type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER ? &views[i] : NULL,
			};
		}
		vkUpdateDescriptorSets(vk->device, n, w, 0, NULL);
	}
	VkFenceCreateInfo fi = { .sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO };
	if ((vk->has.pipeline_statistics &&
	     (ret = relief_vk_query_pool_create(vk,
	                                        VK_QUERY_PIPELINE_STATISTIC_CLIPPING_INVOCATIONS_BIT |
	                                                VK_QUERY_PIPELINE_STATISTIC_TESSELLATION_CONTROL_SHADER_PATCHES_BIT,
	                                        1, &v->stats_pool)) < 0) ||
	    ((ret = relief_vk_timer_init(vk, &v->timer, TIMER_SLOTS)) < 0 && ret != -ENOTSUP) ||
	    (ret = relief_vk_check(vk, vkCreateFence(vk->device, &fi, NULL, &v->fence), "vkCreateFence")) < 0)
		goto fail;
	/* Hysteresis starts with nothing split. */
	VkCommandBuffer cmd;
	if ((ret = relief_vk_cmd_begin(vk, &cmd)) < 0)
		goto fail;
	vkCmdFillBuffer(cmd, v->split[0].buffer, 0, VK_WHOLE_SIZE, 0);
	vkCmdFillBuffer(cmd, v->split[1].buffer, 0, VK_WHOLE_SIZE, 0);
	if ((ret = relief_vk_cmd_submit_wait(vk, cmd)) < 0)
		goto fail;
	*out = v;
	return 0;
fail:
	relief_terrain_view_destroy(v);
	return ret;
}

void relief_terrain_view_destroy(struct relief_terrain_view *v)
{
	if (!v)
		return;
	struct relief_vk *vk = v->t->vk;
	if (v->pending)
		relief_terrain_view_wait(v->t, v, NULL);
	if (v->fence)
		vkDestroyFence(vk->device, v->fence, NULL);
	if (v->stats_pool)
		vkDestroyQueryPool(vk->device, v->stats_pool, NULL);
	relief_vk_timer_finish(vk, &v->timer);
	if (v->pool)
		vkDestroyDescriptorPool(vk->device, v->pool, NULL);
	for (uint32_t i = 0; i < VIEW_TEXELS; i++)
		if (v->texels[i])
			vkDestroyBufferView(vk->device, v->texels[i], NULL);
	if (v->camera_view)
		vkDestroyBufferView(vk->device, v->camera_view, NULL);
	relief_vk_buffer_finish(vk, &v->split[0]);
	relief_vk_buffer_finish(vk, &v->split[1]);
	relief_vk_buffer_finish(vk, &v->instances);
	relief_vk_buffer_finish(vk, &v->drawn);
	relief_vk_buffer_finish(vk, &v->factors);
	relief_vk_buffer_finish(vk, &v->seals);
	relief_vk_buffer_finish(vk, &v->borders);
	relief_vk_buffer_finish(vk, &v->curtains);
	relief_vk_buffer_finish(vk, &v->camera);
	relief_vk_buffer_finish(vk, &v->lists);
	relief_vk_buffer_finish(vk, &v->frontier);
	relief_vk_buffer_finish(vk, &v->passes);
	relief_vk_buffer_finish(vk, &v->cmds);
	relief_vk_buffer_finish(vk, &v->counters);
	relief_vk_buffer_finish(vk, &v->wants);
	relief_vk_buffer_finish(vk, &v->read_counters);
	relief_vk_buffer_finish(vk, &v->read_wants);
	relief_vk_buffer_finish(vk, &v->read_instances);
	relief_vk_buffer_finish(vk, &v->mesh);
	relief_vk_buffer_group_finish(vk, &v->local);
	relief_vk_buffer_group_finish(vk, &v->readback);
	free(v);
}

uint64_t relief_terrain_view_bytes(const struct relief_terrain_view *v)
{
	return v->local.size + v->readback.size;
}

int relief_terrain_view_drawn(struct relief_terrain_view *v, uint32_t *ids, uint32_t cap)
{
	struct relief_vk *vk = v->t->vk;
	if (v->pending)
		return -EBUSY;
	uint32_t n = v->last_drawn < cap ? v->last_drawn : cap;
	if (n == 0)
		return 0;
	/* The instances stay in device memory: copied out on demand, not every frame. */
	VkDeviceSize bytes = sizeof(struct instance) * n;
	VkCommandBuffer cmd;
	int ret = relief_vk_cmd_begin(vk, &cmd);
	if (ret < 0)
		return ret;
	/* The last frame's selection wrote them (that frame was waited for). */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
	        VK_ACCESS_TRANSFER_READ_BIT);
	vkCmdCopyBuffer(cmd, v->instances.buffer, v->read_instances.buffer, 1, &(VkBufferCopy){ 0, 0, bytes });
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
	        VK_ACCESS_HOST_READ_BIT);
	if ((ret = relief_vk_cmd_submit_wait(vk, cmd)) < 0)
		return ret;
	const struct instance *in = v->read_instances.map;
	for (uint32_t i = 0; i < n; i++)
		ids[i] = in[i].id;
	return (int)n;
}

uint32_t relief_terrain_view_wants(const struct relief_terrain_view *v, uint32_t *ids, uint32_t cap)
{
	if (v->pending)
		return 0;
	const struct counters *c = v->read_counters.map;
	const struct want *w = v->read_wants.map;
	uint32_t n = c->wants < WANT_CAP ? c->wants : WANT_CAP;
	n = n < cap ? n : cap;
	for (uint32_t i = 0; i < n; i++)
		ids[i] = w[i].id;
	return n;
}
