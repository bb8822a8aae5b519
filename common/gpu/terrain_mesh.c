/* The mesh capture (see terrain.h, relief_terrain_view_mesh_enable()): the terrain's
 * draw pipelines with a geometry shader that stores every triangle (terrain_mesh.tese,
 * terrain_mesh.geom), a buffer per view the CPU reads, and the frame's part in it. */
#include <errno.h>
#include <stddef.h>
#include <string.h>

#include "pipeline.h"
#include "terrain_internal.h"

/* Bytes per captured triangle: three vertices and the quad, a uvec4 each (terrain_mesh.geom). */
#define MESH_TRIANGLE_BYTES 64u

uint32_t relief_terrain_mesh_limit(const struct relief_vk *vk)
{
	const uint64_t range = vk->props.limits.maxStorageBufferRange;
	const uint64_t n = range > sizeof(struct mesh_header) ? (range - sizeof(struct mesh_header)) / MESH_TRIANGLE_BYTES : 0;
	return n < UINT32_MAX / 4 ? (uint32_t)n : UINT32_MAX / 4; /* the shader's index 4 k + 3 */
}

int relief_terrain_view_mesh_enable(struct relief_terrain_view *v, uint32_t max_triangles)
{
	struct relief_terrain *t = v->t;
	struct relief_vk *vk = t->vk;
	if (!vk->has.mesh_capture)
		return -ENOTSUP;
	if (v->pending)
		return -EBUSY;
	if (max_triangles == 0)
		return -EINVAL;
	if (max_triangles > relief_terrain_mesh_limit(vk))
		return -E2BIG;
	int ret;
	struct relief_vk_buffer b = { 0 };
	const VkDeviceSize size = sizeof(struct mesh_header) + MESH_TRIANGLE_BYTES * (VkDeviceSize)max_triangles;
	if ((ret = relief_vk_buffer_init(vk, &b, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                 RELIEF_VK_MEMORY_READBACK)) < 0)
		return ret;
	/* Neither set is in use: the view has no frame in flight. */
	relief_vk_buffer_finish(vk, &v->mesh);
	v->mesh = b;
	v->mesh_cap = max_triangles;
	v->mesh_frames = 0;
	*(struct mesh_header *)v->mesh.map = (struct mesh_header){ .cap = max_triangles, .parts = 1 };
	VkDescriptorBufferInfo bi = { v->mesh.buffer, 0, VK_WHOLE_SIZE };
	VkWriteDescriptorSet w[2];
	for (int s = 0; s < 2; s++)
		w[s] = (VkWriteDescriptorSet){
			.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
			.dstSet = v->set[s],
			.dstBinding = MESH_BINDING,
			.descriptorCount = 1,
			.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
			.pBufferInfo = &bi,
		};
	vkUpdateDescriptorSets(vk->device, 2, w, 0, NULL);
	return 0;
}

struct draw_pipelines mesh_pipelines(const struct draw_pipelines *d, bool mesh)
{
	struct draw_pipelines p = *d;
	if (mesh) {
		p.fill = d->mesh_fill;
		p.cull = d->mesh_cull;
		p.fill_open = d->mesh_fill_open;
		p.cull_open = d->mesh_cull_open;
	}
	return p;
}

void mesh_frame_begin(struct relief_terrain_view *v, VkCommandBuffer cmd, const struct relief_view_origin *o,
                      uint32_t parts, uint32_t part)
{
	/* The count starts at 0 (after the last frame's geometry shader, when frames share a
	 * command buffer), the part is this frame's; the geometry shader's atomics follow. */
	barrier(cmd, VK_PIPELINE_STAGE_GEOMETRY_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
	        VK_ACCESS_TRANSFER_WRITE_BIT);
	vkCmdFillBuffer(cmd, v->mesh.buffer, 0, sizeof(uint32_t), 0);
	vkCmdFillBuffer(cmd, v->mesh.buffer, offsetof(struct mesh_header, parts), sizeof(uint32_t), parts > 1 ? parts : 1);
	vkCmdFillBuffer(cmd, v->mesh.buffer, offsetof(struct mesh_header, part), sizeof(uint32_t), parts > 1 ? part : 0);
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_GEOMETRY_SHADER_BIT,
	        VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	v->mesh_cell[0] = o->cell_x;
	v->mesh_cell[1] = o->cell_y;
	v->mesh_frames++;
}

void mesh_frame_end(VkCommandBuffer cmd)
{
	barrier(cmd, VK_PIPELINE_STAGE_GEOMETRY_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
	        VK_ACCESS_HOST_READ_BIT);
}

int64_t relief_terrain_view_mesh(const struct relief_terrain_view *v, struct relief_mesh_vertex *out,
                                 struct relief_mesh_quad *quads, uint32_t cap)
{
	if (v->pending)
		return -EBUSY;
	if (!v->mesh_cap || !v->mesh_frames)
		return -ENODATA;
	const struct mesh_header *hd = v->mesh.map;
	const uint32_t (*in)[4] = (const void *)(hd + 1);
	uint32_t kept = hd->count < v->mesh_cap ? hd->count : v->mesh_cap;
	kept = kept < cap ? kept : cap;
	for (uint64_t t = 0; t < kept; t++) {
		const uint32_t(*r)[4] = in + 4 * t;
		for (int k = 0; k < 3; k++) {
			float height;
			memcpy(&height, &r[k][2], sizeof(height));
			out[3 * t + k] = (struct relief_mesh_vertex){
				.col = v->mesh_cell[0] + (int32_t)r[k][0],
				.row = v->mesh_cell[1] + (int32_t)r[k][1],
				.height = height,
				.patch = r[k][3],
			};
		}
		if (!quads)
			continue;
		struct relief_mesh_quad *q = &quads[t];
		*q = (struct relief_mesh_quad){
			.col = v->mesh_cell[0] + (int32_t)r[3][2],
			.row = v->mesh_cell[1] + (int32_t)r[3][3],
			.cells = RELIEF_BLOCK_CELLS << (r[3][1] >> 8 & 31),
			.inner = (uint8_t)r[3][1],
		};
		for (int k = 0; k < 4; k++)
			q->outer[k] = (uint8_t)(r[3][0] >> (8 * k));
	}
	return hd->count;
}
