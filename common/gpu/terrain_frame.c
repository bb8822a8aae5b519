/* A view's frame (see terrain.h): selection, draw records, border and factor passes and
 * the tessellated draws recorded into one command buffer and submitted
 * (relief_terrain_draw_submit()); its statistics and requests once it is done
 * (relief_terrain_view_wait()). */
#include <assert.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "terrain_internal.h"

static int want_cmp(const void *a, const void *b)
{
	uint32_t x = ((const struct want *)a)->id, y = ((const struct want *)b)->id;
	return x < y ? -1 : x > y;
}

/* Records draw records with `pipe` in mode `mode`: those of list part `part`, as many as
 * the count at `count_at` in the view's counters (all of them where
 * vkCmdDrawIndirectCount is missing: unused records hold zero instances). */
static void draw_records(struct relief_terrain *t, struct relief_terrain_view *v, VkCommandBuffer cmd, VkPipeline pipe,
                         struct draw_push *dp, uint32_t mode, enum list_part part, VkDeviceSize count_at)
{
	VkDeviceSize at = 16 * (VkDeviceSize)t->max_draws * (VkDeviceSize)part;
	dp->mode = mode;
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
	vkCmdPushConstants(cmd, t->prog->draw_layout, VK_SHADER_STAGE_ALL_GRAPHICS, 0, sizeof(*dp), dp);
	if (t->vk->has.draw_indirect_count)
		vkCmdDrawIndirectCount(cmd, v->cmds.buffer, at, v->counters.buffer, count_at, t->max_draws, 16);
	else
		vkCmdDrawIndirect(cmd, v->cmds.buffer, at, t->max_draws, 16);
}

/* A list's two parts (LIST_SHOWN or LIST_CLIPPED, then its sealed part): its quads without
 * seals with `open`, counted at `open_at`, those with seals with `sealed`, at `sealed_at`. */
static void draw_list(struct relief_terrain *t, struct relief_terrain_view *v, VkCommandBuffer cmd, VkPipeline open,
                      VkPipeline sealed, struct draw_push *dp, uint32_t mode, enum list_part list,
                      VkDeviceSize open_at, VkDeviceSize sealed_at)
{
	draw_records(t, v, cmd, open, dp, mode, list, open_at);
	draw_records(t, v, cmd, sealed, dp, mode, list + 1, sealed_at);
}

/* The frame's draws, after its compute, into `target`: the shown list, and the clipped one
 * with back faces kept where they are culled; the wireframe over both with opts->wire. */
static void frame_draw(struct relief_terrain *t, struct relief_terrain_view *v, VkCommandBuffer cmd,
                       struct relief_vk_target *target, const struct draw_pipelines *pipes,
                       const struct relief_draw_options *opts, struct draw_push *dp, uint32_t mode, bool cpu_cull,
                       bool gpu_cull)
{
	const float sky[4] = { 0.62f, 0.74f, 0.88f, 1.0f };
	relief_vk_target_begin(target, cmd, sky, 0.0f); /* reversed Z */
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, t->prog->draw_layout, 0, 1, &v->set[v->parity], 0, NULL);
	if (v->stats_pool)
		vkCmdBeginQuery(cmd, v->stats_pool, 0, 0);
	/* With back faces culled, the quads the rasteriser may clip (the clipped list,
	 * lod_factors.comp) are drawn with them kept: the facing of a clipped triangle may be
	 * decided by other arithmetic than its coverage, and a sliver upper side called
	 * back-facing leaves a pinhole (docs/lod.md, "Back faces"). Each list's quads without
	 * seals are drawn by pipelines without the seal code, the others' by pipelines with it. */
	const VkDeviceSize draws = offsetof(struct counters, draws), split = offsetof(struct counters, draw_split),
	                   sealed = offsetof(struct counters, draw_sealed);
	const struct draw_pipelines p = mesh_pipelines(pipes, opts->mesh); /* or the mesh capture's */
	for (int pass = 0; pass < (opts->wire && pipes->wire ? 2 : 1); pass++) {
		if (pass == 1) { /* both lists: the clipped one is empty unless back faces are culled */
			draw_list(t, v, cmd, p.wire, p.wire, dp, mode | 1u, LIST_SHOWN, draws, sealed + 12);
			draw_list(t, v, cmd, p.wire, p.wire, dp, mode | 1u | MODE_CLIPPED_LIST, LIST_CLIPPED, split + 8,
			          sealed + 8);
		} else if (gpu_cull) { /* of the first two calls, one has nothing to draw */
			draw_list(t, v, cmd, p.cull_open, p.cull, dp, mode, LIST_SHOWN, split, sealed);
			draw_list(t, v, cmd, p.fill_open, p.fill, dp, mode, LIST_SHOWN, split + 4, sealed + 4);
			draw_list(t, v, cmd, p.fill_open, p.fill, dp, mode | MODE_CLIPPED_LIST, LIST_CLIPPED, split + 8,
			          sealed + 8);
		} else if (cpu_cull) {
			draw_list(t, v, cmd, p.cull_open, p.cull, dp, mode, LIST_SHOWN, draws, sealed + 12);
			draw_list(t, v, cmd, p.fill_open, p.fill, dp, mode | MODE_CLIPPED_LIST, LIST_CLIPPED, split + 8,
			          sealed + 8);
		} else
			draw_list(t, v, cmd, p.fill_open, p.fill, dp, mode, LIST_SHOWN, draws, sealed + 12);
		if (v->stats_pool && pass == 0)
			vkCmdEndQuery(cmd, v->stats_pool, 0);
	}
	relief_vk_target_end(target, cmd);
	if (opts->mesh)
		mesh_frame_end(cmd);
}

const char *relief_lod_pass_name(enum relief_lod_pass pass)
{
	static const char *const names[RELIEF_LOD_PASSES] = { "setup", "select", "borders", "factors", "lists" };
	return (unsigned)pass < RELIEF_LOD_PASSES ? names[pass] : "unknown";
}

/* The timestamp slot at which LOD pass `pass` ends: the selection and the lists end at the
 * frame's own slots 1 and 2, the others at slots of their own from FIRST_PASS_SLOT. */
static uint32_t pass_slot(enum relief_lod_pass pass)
{
	static const uint32_t slot[RELIEF_LOD_PASSES] = { FIRST_PASS_SLOT, 1, FIRST_PASS_SLOT + 1, FIRST_PASS_SLOT + 2,
	                                                  2 };
	return slot[pass];
}

/* The end of LOD pass `pass` (not the selection or the lists: the frame writes their slots
 * anyway) when the frame times its passes. */
static void pass_end(struct relief_terrain_view *v, VkCommandBuffer cmd, enum relief_lod_pass pass)
{
	if (v->pass_timed)
		relief_vk_timer_write(&v->timer, cmd, pass_slot(pass), VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
}

int relief_terrain_draw_submit(struct relief_terrain *t, struct relief_terrain_view *v, const struct relief_view *view,
                               struct relief_vk_target *target, uint64_t frame, const struct relief_draw_options *opts)
{
	if (v->pending)
		return -EBUSY;
	const struct relief_draw_options defaults = { .fine = RELIEF_FINE_ERRORS };
	if (!opts)
		opts = &defaults;
	const bool wire = opts->wire;
	const char *why;
	/* The level of detail is chosen for lod (selection, block factors, seals), the picture
	 * drawn from view; both give positions relative to lod's camera. */
	const struct relief_view *lod = opts->lod_view ? opts->lod_view : view;
	if (relief_view_check(view, &why) < 0 || relief_view_check(lod, &why) < 0 || lod->width != view->width ||
	    lod->height != view->height || (opts->mesh && (!v->mesh_cap || wire)) ||
	    (opts->mesh_parts > 1 && opts->mesh_part >= opts->mesh_parts) ||
	    (opts->lod_only ? wire || opts->mesh : !target))
		return -EINVAL;
	struct relief_vk *vk = t->vk;
	const struct relief_file *f = t->file;
	/* The pipelines this frame computes and draws with, made the first time a frame needs them. */
	const struct lod_pipelines *lp;
	int ret = terrain_lod_pipelines_create(t, opts->fine, view->morph, &lp);
	if (ret == 0 && !opts->lod_only)
		ret = terrain_draw_pipelines_create(t, view->morph, wire, opts->mesh);
	if (ret < 0)
		return ret;
	const struct draw_pipelines *pipes = &t->draw[view->morph];
	/* Everything hangs from the root: make sure it is on its way. */
	if (relief_patch_cache_state(t->cache, 0) == RELIEF_PATCH_ABSENT)
		relief_patch_cache_request(t->cache, 0, -1.0f);
	struct relief_view_origin o;
	relief_view_origin(f, lod, &o);
	struct select_push sp = {
		.cell = { (int32_t)o.cell_x, (int32_t)o.cell_y },
		.frac = { (float)o.frac_x, (float)o.frac_y },
		.spacing = { (float)f->hdr.spacing_x, (float)f->hdr.spacing_y },
		.cam_z = (float)o.z,
		/* relief's own method bounds a patch's error anywhere in the frustum and leaves part
		 * of tau to the tessellator (lod.h); the baselines' selections use the paper's
		 * kappa (the view axis) and the whole value they are given. */
		.kappa = (float)(opts->fine == RELIEF_FINE_ERRORS ? relief_view_error_kappa(lod) : relief_view_kappa(lod)),
		.tau = (float)((opts->select_tau > 0 ? opts->select_tau : lod->tau) *
		               (opts->fine == RELIEF_FINE_ERRORS ? RELIEF_LOD_COARSE_SHARE : 1.0)),
		.frame = (uint32_t)frame,
		.level = 0,
		.levels = f->hdr.levels,
		.P = f->hdr.patch_size,
		.want_cap = WANT_CAP,
		.delta_finest = (float)f->hdr.tolerance,
		.ratio = f->hdr.ratio,
	};
	relief_view_matrix(lod, sp.vp);
	struct draw_camera camera;
	relief_view_matrix_from(view, lod->eye, camera.vp);
	camera.eye[0] = (float)(view->eye.x - lod->eye.x);
	camera.eye[1] = (float)(view->eye.y - lod->eye.y);
	camera.eye[2] = (float)view->eye.z;
	/* z_clip = n (f - d) / (f - n) at distance d: at d = 0.999 f */
	camera.eye[3] = (float)(0.001 * view->znear * view->zfar / (view->zfar - view->znear));
	struct draw_push dp = {
		.viewport = { (float)lod->width, (float)lod->height },
		.tau = (float)lod->tau,
		.cam_z = (float)o.z,
		.P = f->hdr.patch_size,
		.blocks = t->blocks,
		.per_patch = t->per_patch,
		.sun = { 0.45f, 0.3f, 0.84f, 0.0f },
		.hrange = { (float)f->hdr.height_min, (float)f->hdr.height_max },
		.target_px = opts->target_px > 0 ? opts->target_px : 1.0f,
		.ratio = f->hdr.ratio,
	};
	memcpy(dp.vp, sp.vp, sizeof(dp.vp));
	/* Back faces are hidden wherever the drawing camera is above the surface drawn under it:
	 * along each ray the first surface met is then an upper side; inside the terrain the
	 * underside stays drawn. The CPU's bound (relief_surface_height_bound(), every level's
	 * blocks there, with a margin for the rounding of drawn heights) is conservative;
	 * the GPU decides from the blocks actually drawn around the eye (shaders/lod_eye.glsl)
	 * and lod_commands.comp splits the draw count between the two pipelines, which needs
	 * vkCmdDrawIndirectCount. */
	const bool cpu_cull = !opts->no_face_cull &&
	                      view->eye.z > relief_surface_height_bound(f, view->eye.x, view->eye.y) + FACE_CULL_MARGIN;
	const bool gpu_cull = !opts->no_face_cull && vk->has.draw_indirect_count;
	memcpy(camera.cull, (float[4]){ (float)FACE_CULL_MARGIN, cpu_cull, gpu_cull, 0.0f }, sizeof(camera.cull));
	const struct commands_push cp = { t->per_patch, t->blocks, t->per_draw, t->max_draws };
	/* Zero but the border pass's size: its first invocation decides about back faces,
	 * even with nothing drawn; the selection raises it (lod_select.comp). */
	const struct counters counters_start = { .border_groups = { 1, 1, 1, 0 } };

	VkCommandBuffer cmd;
	ret = relief_vk_cmd_record(vk, &cmd);
	if (ret < 0)
		return ret;
	relief_vk_timer_reset(&v->timer, cmd);
	relief_vk_timer_write(&v->timer, cmd, 0, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT);
	v->pass_timed = opts->pass_timing;
	if (v->stats_pool)
		vkCmdResetQueryPool(cmd, v->stats_pool, 0, 1);
	/* What this frame's transfers and compute write is written before it only by compute
	 * and transfers: other views' frames (the shared use tables and distances) and this
	 * view's last one, which the host waited for; decodes end with a barrier of their own
	 * to every stage, and nothing drawn reads what the frame's compute writes but the
	 * view's own last frame. So other views' drawing may still run (on a GPU) while this
	 * frame selects. test_frames_captured (frames and decodes in one command buffer) sees
	 * no hazard with it, nor without it: each frame's own compute barriers also order the
	 * compute before them. */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
	        VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
	        VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
	vkCmdUpdateBuffer(cmd, v->camera.buffer, 0, sizeof(camera), &camera);
	vkCmdUpdateBuffer(cmd, v->counters.buffer, 0, sizeof(counters_start), &counters_start);
	vkCmdFillBuffer(cmd, v->cmds.buffer, 0, VK_WHOLE_SIZE, 0);
	vkCmdFillBuffer(cmd, v->drawn.buffer, 0, VK_WHOLE_SIZE, 0);
	if (opts->mesh)
		mesh_frame_begin(v, cmd, &o, opts->mesh_parts, opts->mesh_part);
	/* The selection visits the patches on the view's tree only and writes their split
	 * state: every other patch's is 0 (not split). The frontiers (levels SELECT_TOP_LEVELS
	 * and deeper; the first dispatch visits the levels above without one) start empty:
	 * no workgroups, no entries. */
	vkCmdFillBuffer(cmd, v->split[v->parity ^ 1].buffer, 0, VK_WHOLE_SIZE, 0);
	uint32_t passes[RELIEF_MAX_LEVELS][4];
	for (uint32_t l = 0; l < RELIEF_MAX_LEVELS; l++)
		memcpy(passes[l], (uint32_t[4]){ 0, 1, 1, 0 }, sizeof(passes[l]));
	vkCmdUpdateBuffer(cmd, v->passes.buffer, 0, sizeof(passes), passes);
	/* The first view drawn in a frame clears the frame's half of the use distances; the
	 * selection (its half: frame & 1) takes the least over the frame's views. */
	bool reset;
	uint32_t half = relief_patch_cache_use_dist_half(t->cache, frame, &reset);
	if (reset)
		vkCmdFillBuffer(cmd, relief_patch_cache_pool(t->cache)->use_dist, (VkDeviceSize)half * 4 * t->count,
		                (VkDeviceSize)4 * t->count, UINT32_MAX);
	/* The camera is read by compute and by the evaluation shader, the passes as dispatches. */
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
	        VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TESSELLATION_EVALUATION_SHADER_BIT |
	                VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
	        VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
	pass_end(v, cmd, RELIEF_LOD_PASS_SETUP);
	VkDescriptorSet set = v->set[v->parity];
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->prog->select_layout, 0, 1, &set, 0, NULL);
	vkCmdPushConstants(cmd, t->prog->select_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(sp), &sp);
	/* Forced splits (lod_force.comp): levels 1 .. L - 2, where a patch could otherwise be
	 * drawn beside one 5 levels finer (trees of 7 levels or more) or beside a finer border
	 * that its vertices cannot draw within tau (3 or more); one workgroup sweeps them to a
	 * fixed point. The border rule is relief's own: the baselines' selections (whose tau
	 * holds no coarse share) and views that leave the transition strips unbounded do
	 * without it, so where neither rule can apply the pass is left out. */
	const uint32_t border_rule = opts->fine == RELIEF_FINE_ERRORS && !view->loose_transitions;
	if (sp.levels >= 7 || (sp.levels >= 3 && border_rule)) {
		vkCmdPushConstants(cmd, t->prog->select_layout, VK_SHADER_STAGE_COMPUTE_BIT, offsetof(struct select_push, level),
		                   sizeof(border_rule), &border_rule);
		vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->prog->force);
		vkCmdDispatch(cmd, 1, 1, 1);
		barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
		        VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
	}
	/* The top levels in one pass, an invocation per patch; then one pass per level over
	 * its frontier, each sized by the one before (lod_select.comp). */
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->prog->select);
	const uint32_t top = sp.levels < SELECT_TOP_LEVELS ? sp.levels : SELECT_TOP_LEVELS;
	for (uint32_t l = 0; l < sp.levels; l = l == 0 ? top : l + 1) {
		vkCmdPushConstants(cmd, t->prog->select_layout, VK_SHADER_STAGE_COMPUTE_BIT, offsetof(struct select_push, level),
		                   sizeof(l), &l);
		if (l == 0)
			vkCmdDispatch(cmd, (relief_level_first_id(top) + 63) / 64, 1, 1);
		else
			vkCmdDispatchIndirect(cmd, v->passes.buffer, 16 * (VkDeviceSize)l);
		barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
		        VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
		        VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
	}
	/* The last level's barrier above makes the border pass's size ready for its dispatch. */
	relief_vk_timer_write(&v->timer, cmd, 1, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
	const uint32_t mode = (opts->no_skirts ? MODE_NO_SKIRTS : 0u) | (opts->no_block_cull ? MODE_NO_BLOCK_CULL : 0u) |
	                      (opts->keep_empty_blocks ? MODE_KEEP_EMPTY_BLOCKS : 0u) |
	                      (view->loose_transitions ? MODE_LOOSE_STRIPS : 0u);
	dp.mode = mode;
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->prog->factors_layout, 0, 1, &set, 0, NULL);
	vkCmdPushConstants(cmd, t->prog->factors_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(dp), &dp);
	/* The border edges and corners first (lod_borders.comp, which also sizes the factor
	 * pass and decides about back faces), then every quad, as many groups as they need. */
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lp->borders);
	vkCmdDispatchIndirect(cmd, v->counters.buffer, offsetof(struct counters, border_groups));
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	        VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_SHADER_READ_BIT);
	pass_end(v, cmd, RELIEF_LOD_PASS_BORDERS);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lp->factors);
	vkCmdDispatchIndirect(cmd, v->counters.buffer, offsetof(struct counters, factor_groups));
	/* The lists of quads that draw something, and their draw records (lod_commands.comp):
	 * the draws run no shader for the others. */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
	        VK_ACCESS_SHADER_READ_BIT);
	pass_end(v, cmd, RELIEF_LOD_PASS_FACTORS);
	/* Different push ranges make the layouts incompatible for the set: bind it again. */
	vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->prog->commands_layout, 0, 1, &set, 0, NULL);
	vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, t->prog->commands);
	vkCmdPushConstants(cmd, t->prog->commands_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(cp), &cp);
	vkCmdDispatch(cmd, 1, 1, 1);
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
	        VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_VERTEX_SHADER_BIT |
	                VK_PIPELINE_STAGE_TESSELLATION_CONTROL_SHADER_BIT | VK_PIPELINE_STAGE_TESSELLATION_EVALUATION_SHADER_BIT,
	        VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_SHADER_READ_BIT);
	relief_vk_timer_write(&v->timer, cmd, 2, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);

	if (!opts->lod_only)
		frame_draw(t, v, cmd, target, pipes, opts, &dp, mode, cpu_cull, gpu_cull);
	v->drew = !opts->lod_only;
	/* The counters and requests to where the CPU reads them. */
	barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
	        VK_ACCESS_TRANSFER_READ_BIT);
	vkCmdCopyBuffer(cmd, v->counters.buffer, v->read_counters.buffer, 1,
	                &(VkBufferCopy){ 0, 0, sizeof(struct counters) });
	vkCmdCopyBuffer(cmd, v->wants.buffer, v->read_wants.buffer, 1,
	                &(VkBufferCopy){ 0, 0, sizeof(struct want) * WANT_CAP });
	barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
	        VK_ACCESS_HOST_READ_BIT);
	relief_vk_timer_write(&v->timer, cmd, 3, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
	v->captured = cmd == vk->capture;
	if ((ret = relief_vk_cmd_submit(vk, cmd, v->fence)) < 0)
		return ret;
	v->pending = cmd;
	v->gpu_cull = gpu_cull;
	v->parity ^= 1;
	relief_patch_cache_hold(t->cache);
	return 0;
}

int relief_terrain_view_wait(struct relief_terrain *t, struct relief_terrain_view *v, struct relief_terrain_stats *st)
{
	if (!v->pending)
		return -EINVAL;
	struct relief_vk *vk = t->vk;
	if (v->captured && v->pending == vk->capture)
		return -EDEADLK; /* recorded into a capture not yet submitted (relief_vk_capture_end()) */
	const struct relief_file *f = t->file;
	int ret = relief_vk_check(vk, vkWaitForFences(vk->device, 1, &v->fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
	if (ret == 0)
		ret = relief_vk_check(vk, vkResetFences(vk->device, 1, &v->fence), "vkResetFences");
	if (!v->captured)
		relief_vk_cmd_free(vk, v->pending);
	v->pending = VK_NULL_HANDLE;
	v->timed = false;
	relief_patch_cache_release(t->cache);
	if (ret < 0)
		return ret;
	const bool gpu_cull = v->gpu_cull;
	const struct counters *c = v->read_counters.map;
	struct relief_terrain_stats s = {
		.patches = c->drawn,
		.draws = c->draws + c->draw_sealed[3] + c->draw_split[2] + c->draw_sealed[2], /* shown, clipped */
		.requests = c->wants,
		.face_culled = c->draw_culled != 0, /* the decision the draws used */
		.cull_height = gpu_cull && c->found ? c->near_high : NAN,
		.clipped_quads = c->draw_split[3],
		.sealed_quads = c->sealed_quads,
	};
	if (relief_patch_cache_state(t->cache, 0) != RELIEF_PATCH_RESIDENT)
		s.requests++; /* the root itself is still missing */
	v->last_drawn = c->drawn < t->max_patches ? c->drawn : t->max_patches;
	/* The statistics in the order of their bits: clipping invocations, control shader patches. */
	uint64_t stats[2];
	if (v->stats_pool && v->drew) {
		const VkQueryResultFlags flags = VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT;
		if ((ret = relief_vk_check(vk, vkGetQueryPoolResults(vk->device, v->stats_pool, 0, 1, sizeof(stats), stats,
		                                                     sizeof(stats), flags),
		                           "vkGetQueryPoolResults")) < 0)
			return ret;
		s.triangles = stats[0];
		s.quads = stats[1];
	}
	/* No timestamps on this queue (-ENOTSUP): the times stay 0. */
	uint64_t stamp[4];
	v->timed = true;
	for (uint32_t i = 0; i < 4 && v->timed; i++)
		v->timed = relief_vk_timer_ticks(vk, &v->timer, i, &stamp[i]) == 0;
	if (v->timed) {
		s.select_ns = relief_vk_ticks_elapsed_ns(vk, stamp[0], stamp[1]);
		s.lod_ns = relief_vk_ticks_elapsed_ns(vk, stamp[0], stamp[2]);
		s.gpu_ns = relief_vk_ticks_elapsed_ns(vk, stamp[0], stamp[3]);
		v->start_ticks = stamp[0];
		v->end_ticks = stamp[3];
	}
	if (v->timed && v->pass_timed) {
		/* The passes' ends in order; the first starts with the frame. */
		uint64_t end[RELIEF_LOD_PASSES + 1] = { stamp[0] };
		for (uint32_t i = 0; i < RELIEF_LOD_PASSES && ret == 0; i++)
			ret = relief_vk_timer_ticks(vk, &v->timer, pass_slot(i), &end[i + 1]);
		for (uint32_t i = 0; i < RELIEF_LOD_PASSES && ret == 0; i++)
			s.pass_ns[i] = relief_vk_ticks_elapsed_ns(vk, end[i], end[i + 1]);
		if (ret < 0)
			return ret;
	}
	/* Requests, made in id order: coarser patches first (lower ids are coarser), so that a
	 * parent is on its way before its child is asked for and a whole chain is accepted in
	 * one frame. The cache serves the nearest first (its ancestors ahead of it). */
	static_assert(WANT_CAP * sizeof(struct want) <= 16384, "the copy below lives on the stack");
	struct want want[WANT_CAP];
	uint32_t n = c->wants < WANT_CAP ? c->wants : WANT_CAP;
	memcpy(want, v->read_wants.map, n * sizeof(*want)); /* sorted in place below */
	qsort(want, n, sizeof(*want), want_cmp);
	for (uint32_t i = 0; i < n; i++)
		if (want[i].id < f->hdr.patch_count)
			relief_patch_cache_request(t->cache, want[i].id, want[i].distance);
	if (st)
		*st = s;
	return 0;
}

int relief_terrain_draw(struct relief_terrain *t, struct relief_terrain_view *v, const struct relief_view *view,
                        struct relief_vk_target *target, uint64_t frame, const struct relief_draw_options *opts,
                        struct relief_terrain_stats *st)
{
	int ret = relief_terrain_draw_submit(t, v, view, target, frame, opts);
	return ret < 0 ? ret : relief_terrain_view_wait(t, v, st);
}

int relief_terrain_views_span_ns(struct relief_terrain *t, struct relief_terrain_view *const *views, uint32_t n,
                                 uint64_t *ns)
{
	if (n == 0)
		return -EINVAL;
	for (uint32_t i = 0; i < n; i++) {
		if (views[i]->pending)
			return -EBUSY;
		if (!views[i]->timed)
			return -ENODATA;
	}
	/* Relative to the first view's start, so that the counter's wrap does not matter: the
	 * frames of one round are far closer together than half its range. */
	int64_t lo = 0, hi = 0;
	for (uint32_t i = 0; i < n; i++) {
		int64_t a = relief_vk_ticks_ns(t->vk, views[0]->start_ticks, views[i]->start_ticks);
		int64_t b = relief_vk_ticks_ns(t->vk, views[0]->start_ticks, views[i]->end_ticks);
		lo = a < lo ? a : lo;
		hi = b > hi ? b : hi;
	}
	*ns = (uint64_t)(hi - lo);
	return 0;
}
