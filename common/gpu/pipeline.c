#include <errno.h>

#include "pipeline.h"

int relief_vk_pipeline_layout_create(struct relief_vk *vk, uint32_t push_size, VkDescriptorSetLayout set,
                                     VkPipelineLayout *out)
{
	VkPushConstantRange range = { VK_SHADER_STAGE_ALL_GRAPHICS, 0, push_size };
	VkPipelineLayoutCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
		.setLayoutCount = set ? 1 : 0,
		.pSetLayouts = &set,
		.pushConstantRangeCount = push_size ? 1 : 0,
		.pPushConstantRanges = &range,
	};
	return relief_vk_check(vk, vkCreatePipelineLayout(vk->device, &info, NULL, out), "vkCreatePipelineLayout");
}

int relief_vk_tess_pipeline_create(struct relief_vk *vk, const struct relief_vk_tess_pipeline_desc *d,
                                   VkPipeline *out)
{
	if (d->wireframe && !vk->has.fill_mode_non_solid)
		return -ENOTSUP;
	const struct relief_vk_spirv *code[5] = { &d->vert, &d->tesc, &d->tese, &d->frag, &d->geom };
	const VkShaderStageFlagBits stage[5] = {
		VK_SHADER_STAGE_VERTEX_BIT, VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT,
		VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT, VK_SHADER_STAGE_FRAGMENT_BIT, VK_SHADER_STAGE_GEOMETRY_BIT,
	};
	const int n_stages = d->geom.size ? 5 : 4;
	VkPipelineShaderStageCreateInfo stages[5];
	for (int i = 0; i < n_stages; i++) {
		VkShaderModule module; /* the device's, shared: not destroyed here */
		int ret = relief_vk_shader_module(vk, code[i]->code, code[i]->size, &module);
		if (ret < 0)
			return ret;
		stages[i] = (VkPipelineShaderStageCreateInfo){
			.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
			.stage = stage[i],
			.module = module,
			.pName = "main",
			.pSpecializationInfo = stage[i] == VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT ? d->tese_spec : NULL,
		};
	}
	VkPipelineVertexInputStateCreateInfo vertex = { .sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO };
	VkPipelineInputAssemblyStateCreateInfo assembly = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO,
		.topology = VK_PRIMITIVE_TOPOLOGY_PATCH_LIST,
	};
	VkPipelineTessellationStateCreateInfo tess = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_TESSELLATION_STATE_CREATE_INFO,
		.patchControlPoints = d->control_points,
	};
	VkPipelineViewportStateCreateInfo viewport = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO,
		.viewportCount = 1,
		.scissorCount = 1,
	};
	VkPipelineRasterizationStateCreateInfo raster = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO,
		.polygonMode = d->wireframe ? VK_POLYGON_MODE_LINE : VK_POLYGON_MODE_FILL,
		.cullMode = d->cull_back ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE,
		.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE,
		.lineWidth = 1.0f,
	};
	VkPipelineMultisampleStateCreateInfo ms = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO,
		.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT,
	};
	VkPipelineDepthStencilStateCreateInfo depth = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO,
		.depthTestEnable = VK_TRUE,
		.depthWriteEnable = d->wireframe ? VK_FALSE : VK_TRUE,
		.depthCompareOp = d->reversed_z ? (d->wireframe ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_GREATER)
		                                : (d->wireframe ? VK_COMPARE_OP_LESS_OR_EQUAL : VK_COMPARE_OP_LESS),
	};
	VkPipelineColorBlendAttachmentState blend_att = { .colorWriteMask = 0xf };
	VkPipelineColorBlendStateCreateInfo blend = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
		.attachmentCount = 1,
		.pAttachments = &blend_att,
	};
	VkDynamicState dyn_states[2] = { VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR };
	VkPipelineDynamicStateCreateInfo dyn = {
		.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
		.dynamicStateCount = 2,
		.pDynamicStates = dyn_states,
	};
	VkGraphicsPipelineCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
		.stageCount = (uint32_t)n_stages,
		.pStages = stages,
		.pVertexInputState = &vertex,
		.pInputAssemblyState = &assembly,
		.pTessellationState = &tess,
		.pViewportState = &viewport,
		.pRasterizationState = &raster,
		.pMultisampleState = &ms,
		.pDepthStencilState = &depth,
		.pColorBlendState = &blend,
		.pDynamicState = &dyn,
		.layout = d->layout,
		.renderPass = d->pass,
	};
	return relief_vk_check(vk, vkCreateGraphicsPipelines(vk->device, VK_NULL_HANDLE, 1, &info, NULL, out),
	                       "vkCreateGraphicsPipelines");
}

uint32_t relief_vk_quads_per_draw(uint32_t factor)
{
	/* A quad domain with all factors f (equal spacing) has (f + 1)^2 vertices. */
	uint32_t per_patch = (factor + 1) * (factor + 1);
	uint32_t n = RELIEF_VK_MAX_TESS_VERTICES_PER_DRAW / per_patch;
	return n ? n : 1;
}

int relief_vk_compute_pipeline_create_spec(struct relief_vk *vk, VkPipelineLayout layout, struct relief_vk_spirv code,
                                           const VkSpecializationInfo *spec, VkPipeline *out)
{
	VkShaderModule m;
	int ret = relief_vk_shader_module(vk, code.code, code.size, &m);
	if (ret < 0)
		return ret;
	VkComputePipelineCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
		.stage = { .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
		           .stage = VK_SHADER_STAGE_COMPUTE_BIT, .module = m, .pName = "main", .pSpecializationInfo = spec },
		.layout = layout,
	};
	return relief_vk_check(vk, vkCreateComputePipelines(vk->device, VK_NULL_HANDLE, 1, &info, NULL, out),
	                       "vkCreateComputePipelines");
}

int relief_vk_compute_pipeline_create(struct relief_vk *vk, VkPipelineLayout layout, struct relief_vk_spirv code,
                                      VkPipeline *out)
{
	return relief_vk_compute_pipeline_create_spec(vk, layout, code, NULL, out);
}

int relief_vk_query_pool_create(struct relief_vk *vk, VkQueryPipelineStatisticFlags statistics, uint32_t count,
                                VkQueryPool *out)
{
	VkQueryPoolCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
		.queryType = statistics ? VK_QUERY_TYPE_PIPELINE_STATISTICS : VK_QUERY_TYPE_TIMESTAMP,
		.queryCount = count,
		.pipelineStatistics = statistics,
	};
	return relief_vk_check(vk, vkCreateQueryPool(vk->device, &info, NULL, out), "vkCreateQueryPool");
}
