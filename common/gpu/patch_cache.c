/* The GPU patch cache: see patch_cache.h for the rules it keeps. This file holds the
 * render-thread side (creation, requests, layers, eviction, batches); the GPU commands are
 * in patch_gpu.c and the worker threads in patch_worker.c.
 *
 * Locking: `lock` guards the request heap, `queued`, the free staging slots, the ready list
 * and the worker counters. Everything else (patch states, layers, batches, Vulkan objects)
 * belongs to the thread that calls the public functions. */
#include <assert.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "patch_cache_internal.h"
#include "strip_bound.h"

/* ---- creation ---- */

size_t relief_patch_block_floats(uint32_t patch_size)
{
	size_t blocks = relief_block_ranges_per_patch(patch_size) / 2;
	return relief_block_errors_per_patch(patch_size) + relief_block_ranges_per_patch(patch_size) + (blocks + 15) / 16;
}

size_t relief_patch_layer_floats(uint32_t patch_size)
{
	size_t blocks = relief_block_ranges_per_patch(patch_size) / 2;
	return relief_patch_block_floats(patch_size) + blocks * 4 * RELIEF_STRIP_FLOATS;
}

static const VkImageUsageFlags POOL_USAGE =
	VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
	VK_IMAGE_USAGE_TRANSFER_DST_BIT;

static uint64_t pool_bytes_for(struct relief_patch_cache *c, uint32_t n)
{
	VkDeviceSize h = relief_vk_image_bytes(c->vk, VK_FORMAT_R32_SINT, c->E, c->E, n, POOL_USAGE);
	VkDeviceSize m = relief_vk_image_bytes(c->vk, VK_FORMAT_R32_UINT, c->P, c->P, n, POOL_USAGE);
	if (!h || !m)
		return UINT64_MAX;
	return h + m + (uint64_t)n * c->layer_floats * sizeof(float);
}

/* The largest layer count whose pools fit the budget (real allocation sizes). */
static uint32_t layers_for_budget(struct relief_patch_cache *c, uint32_t cap)
{
	uint64_t one = pool_bytes_for(c, 1);
	if (one == UINT64_MAX || one > c->o.budget_bytes)
		return 0;
	uint64_t n = c->o.budget_bytes / one;
	if (n > cap)
		n = cap;
	while (n > 0) {
		uint64_t b = pool_bytes_for(c, (uint32_t)n);
		if (b <= c->o.budget_bytes)
			break;
		uint64_t over = (b - c->o.budget_bytes + one - 1) / one;
		n = n > over ? n - over : 0;
	}
	return (uint32_t)n;
}

int relief_patch_cache_create(struct relief_vk *vk, const struct relief_file *f,
                              const struct relief_patch_cache_options *opts, const struct relief_logger *log,
                              struct relief_patch_cache **out)
{
	struct relief_patch_cache *c = calloc(1, sizeof(*c));
	if (!c)
		return -ENOMEM;
	pthread_mutex_init(&c->lock, NULL);
	pthread_cond_init(&c->work, NULL);
	pthread_cond_init(&c->progress, NULL);
	c->vk = vk;
	c->file = f;
	if (log)
		c->log = *log;
	c->o = *opts;
	if (!c->o.budget_bytes)
		c->o.budget_bytes = 256ull << 20;
	if (!c->o.staging_slots)
		c->o.staging_slots = 32;
	if (!c->o.workers || c->o.workers > RELIEF_PATCH_CACHE_MAX_WORKERS)
		c->o.workers = c->o.workers ? RELIEF_PATCH_CACHE_MAX_WORKERS : 1;
	if (!c->o.batch || c->o.batch > MAX_BATCH)
		c->o.batch = c->o.batch > MAX_BATCH ? MAX_BATCH : 16;
	if (!c->o.keep_frames)
		c->o.keep_frames = 2;
	c->P = f->layout.geom.P;
	c->E = f->layout.geom.E;
	c->count = f->hdr.index_records;
	c->block_floats = relief_patch_block_floats(c->P);
	c->layer_floats = relief_patch_layer_floats(c->P);
	c->mask_ints = ((size_t)c->P * c->P + 3) / 4;
	c->slot_ints = f->layout.geom.n_labels + (size_t)c->E * c->E + c->mask_ints + c->block_floats;

	int ret = -ENOMEM;
	c->state = calloc(c->count, 1);
	c->layer = malloc(sizeof(int32_t) * c->count);
	c->last_used = calloc(c->count, sizeof(uint64_t));
	c->children = calloc(c->count, sizeof(uint16_t));
	c->pins = calloc(c->count, sizeof(uint16_t));
	c->queued = calloc(c->count, 1);
	c->queued_prio = calloc(c->count, sizeof(float));
	if (!c->state || !c->layer || !c->last_used || !c->children || !c->pins || !c->queued || !c->queued_prio)
		goto fail;
	uint32_t drawable = 0;
	for (uint32_t e = 0; e < c->count; e++) {
		struct relief_patch_record r;
		relief_file_record(f, relief_index_patch(&f->hdr, e), &r);
		c->state[e] = (r.flags & RELIEF_PATCH_EMPTY) ? RELIEF_PATCH_NONE : RELIEF_PATCH_ABSENT;
		drawable += !(r.flags & RELIEF_PATCH_EMPTY);
	}

	/* Seal records carry a layer in 16 bits (shaders/terrain_seal.glsl). */
	uint32_t cap = vk->props.limits.maxImageArrayLayers < 0xffffu ? vk->props.limits.maxImageArrayLayers : 0xffffu;
	if (cap > drawable)
		cap = drawable;
	/* The block records are read as one uniform texel buffer (patch_gpu.c). */
	const uint32_t texel_cap = (uint32_t)(vk->props.limits.maxTexelBufferElements / c->layer_floats);
	if (cap > texel_cap)
		cap = texel_cap;
	if (c->o.max_layers && cap > c->o.max_layers)
		cap = c->o.max_layers;
	uint32_t n = layers_for_budget(c, cap);
	if (n == 0) {
		relief_log(&c->log, RELIEF_LOG_ERROR, "patch cache: a budget of %llu bytes does not hold one %u-sample patch",
		           (unsigned long long)c->o.budget_bytes, c->P);
		ret = -ENOSPC;
		goto fail;
	}
	if ((ret = relief_vk_image_init(vk, &c->heights, VK_FORMAT_R32_SINT, c->E, c->E, n, VK_IMAGE_VIEW_TYPE_2D_ARRAY,
	                                POOL_USAGE, VK_IMAGE_ASPECT_COLOR_BIT)) < 0 ||
	    (ret = relief_vk_image_init(vk, &c->normals, VK_FORMAT_R32_UINT, c->P, c->P, n,
	                                VK_IMAGE_VIEW_TYPE_2D_ARRAY, POOL_USAGE, VK_IMAGE_ASPECT_COLOR_BIT)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->errors, (VkDeviceSize)n * c->layer_floats * sizeof(float),
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
	                                 VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
	                                 RELIEF_VK_MEMORY_DEVICE)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->staging, (VkDeviceSize)c->o.staging_slots * c->slot_ints * 4,
	                                 VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
	                                 RELIEF_VK_MEMORY_UPLOAD)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->flags, sizeof(uint32_t) * c->o.staging_slots,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, RELIEF_VK_MEMORY_READBACK)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->layer_table, sizeof(int32_t) * c->count,
	                                 VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT, RELIEF_VK_MEMORY_SHARED)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->jobs, sizeof(struct job_params) * IN_FLIGHT * MAX_BATCH,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, RELIEF_VK_MEMORY_UPLOAD)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->use_table, sizeof(uint32_t) * c->count,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                 RELIEF_VK_MEMORY_READBACK)) < 0 ||
	    (ret = relief_vk_buffer_init(vk, &c->use_dist, 2 * sizeof(uint32_t) * c->count,
	                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
	                                 RELIEF_VK_MEMORY_READBACK)) < 0)
		goto fail;
	/* -1: nothing resident */
	memset(c->layer, 0xff, sizeof(int32_t) * c->count);
	memset(c->layer_table.map, 0xff, sizeof(int32_t) * c->count);
	memset(c->use_table.map, 0, sizeof(uint32_t) * c->count);
	memset(c->use_dist.map, 0xff, 2 * sizeof(uint32_t) * c->count);
	c->pool_bytes = pool_bytes_for(c, n);
	c->pool = (struct relief_patch_pool){
		.heights = c->heights.view, .normals = c->normals.view, .block_errors = c->errors.buffer, .layers = n,
		.layer_table = c->layer_table.buffer, .use_table = c->use_table.buffer, .use_dist = c->use_dist.buffer,
		/* .block_view, .layer_view: patch_gpu_init() */
	};
	c->owner = malloc(sizeof(int32_t) * n);
	c->free_layers = malloc(sizeof(uint32_t) * n);
	c->free_slots = malloc(sizeof(uint32_t) * c->o.staging_slots);
	c->pending = malloc(sizeof(struct job) * c->o.staging_slots);
	c->ready = malloc(sizeof(struct job) * c->o.staging_slots);
	if (!c->owner || !c->free_layers || !c->free_slots || !c->pending || !c->ready) {
		ret = -ENOMEM;
		goto fail;
	}
	for (uint32_t i = 0; i < n; i++) {
		c->owner[i] = -1;
		c->free_layers[i] = n - 1 - i; /* pop gives layer 0 first */
	}
	c->n_free_layers = n;
	for (uint32_t i = 0; i < c->o.staging_slots; i++)
		c->free_slots[i] = c->o.staging_slots - 1 - i;
	c->n_free_slots = c->o.staging_slots;
	if ((ret = patch_gpu_init(c)) < 0)
		goto fail;
	for (; c->n_threads < c->o.workers; c->n_threads++)
		if (pthread_create(&c->threads[c->n_threads], NULL, patch_worker_main, c) != 0) {
			ret = -EAGAIN;
			goto fail;
		}
	relief_log(&c->log, RELIEF_LOG_INFO, "patch cache: %u layers of %u-sample patches, %llu bytes of GPU memory "
	           "(budget %llu), %u decode worker(s)", n, c->P, (unsigned long long)c->pool_bytes,
	           (unsigned long long)c->o.budget_bytes, c->n_threads);
	*out = c;
	return 0;
fail:
	relief_patch_cache_destroy(c);
	return ret;
}

void relief_patch_cache_destroy(struct relief_patch_cache *c)
{
	if (!c)
		return;
	if (c->n_threads) {
		pthread_mutex_lock(&c->lock);
		c->stop = true;
		pthread_cond_broadcast(&c->work);
		pthread_mutex_unlock(&c->lock);
		for (uint32_t i = 0; i < c->n_threads; i++)
			pthread_join(c->threads[i], NULL);
	}
	struct relief_vk *vk = c->vk;
	if (vk->device)
		vkDeviceWaitIdle(vk->device);
	patch_gpu_finish(c);
	relief_vk_image_finish(vk, &c->heights);
	relief_vk_image_finish(vk, &c->normals);
	relief_vk_buffer_finish(vk, &c->errors);
	relief_vk_buffer_finish(vk, &c->staging);
	relief_vk_buffer_finish(vk, &c->flags);
	relief_vk_buffer_finish(vk, &c->layer_table);
	relief_vk_buffer_finish(vk, &c->use_table);
	relief_vk_buffer_finish(vk, &c->use_dist);
	relief_vk_buffer_finish(vk, &c->jobs);
	free(c->state);
	free(c->layer);
	free(c->last_used);
	free(c->children);
	free(c->pins);
	free(c->queued);
	free(c->queued_prio);
	free(c->owner);
	free(c->free_layers);
	free(c->free_slots);
	free(c->pending);
	free(c->ready);
	free(c->heap);
	pthread_cond_destroy(&c->work);
	pthread_cond_destroy(&c->progress);
	pthread_mutex_destroy(&c->lock);
	free(c);
}

/* ---- requests ---- */

/* Under lock: pushes id with `priority`, then each ancestor still waiting for the worker
 * again, strictly ahead of it: a child's symbols may be decoded while its parent is on its
 * way, but the worker must take the ancestors first (a child's slot is held until its
 * parent is resident). Entries left behind with a worse priority are skipped when they
 * come up (patch_worker.c). */
static int queue_push_with_ancestors(struct relief_patch_cache *c, uint32_t id, float priority)
{
	int ret = patch_queue_push(c, priority, id);
	if (ret == 0) {
		const uint32_t e = ent(c, id);
		c->queued[e] = 1;
		c->queued_prio[e] = priority;
	}
	float ahead = priority;
	for (uint32_t a = id; ret == 0 && a != 0;) {
		a = parent_of(c, a);
		const uint32_t ae = ent(c, a);
		if (!c->queued[ae])
			break;
		ahead = fminf(ahead - 1.0f, nextafterf(ahead, -INFINITY)); /* strictly ahead, any magnitude */
		if (ahead < c->queued_prio[ae] && (ret = patch_queue_push(c, ahead, a)) == 0)
			c->queued_prio[ae] = ahead;
	}
	return ret;
}

int relief_patch_cache_request(struct relief_patch_cache *c, uint32_t id, float priority)
{
	if (id >= c->file->hdr.patch_count)
		return -EINVAL;
	const uint32_t e = ent(c, id);
	if (e == UINT32_MAX)
		return -ENOENT; /* EMPTY */
	switch (c->state[e]) {
	case RELIEF_PATCH_NONE:
		return -ENOENT;
	case RELIEF_PATCH_BAD:
		return -EIO;
	case RELIEF_PATCH_ABSENT:
		break;
	case RELIEF_PATCH_QUEUED:
	case RELIEF_PATCH_DECODING: {
		/* Asked for again, more urgently (another view is nearer): served sooner, by the
		 * worker if it still waits for it (an error here, no memory for the heap, leaves
		 * the earlier entry, still valid), else when layers are handed out (update()). */
		pthread_mutex_lock(&c->lock);
		if (priority < c->queued_prio[e]) {
			if (c->queued[e])
				queue_push_with_ancestors(c, id, priority);
			else
				c->queued_prio[e] = priority;
		}
		pthread_mutex_unlock(&c->lock);
		return 0;
	}
	default:
		return 0;
	}
	if (id != 0) {
		uint32_t parent = parent_of(c, id); /* a patch's parent has an entry when it has one */
		if (!on_its_way(c->state[ent(c, parent)])) {
			int ret = relief_patch_cache_request(c, parent, priority - 1.0f);
			return ret == 0 || ret == -EAGAIN ? -EAGAIN : ret;
		}
		c->pins[ent(c, parent)]++;
	}
	c->state[e] = RELIEF_PATCH_QUEUED;
	pthread_mutex_lock(&c->lock);
	int ret = queue_push_with_ancestors(c, id, priority);
	if (ret == 0)
		pthread_cond_signal(&c->work);
	else
		c->queued[e] = 0;
	pthread_mutex_unlock(&c->lock);
	if (ret < 0) {
		c->state[e] = RELIEF_PATCH_ABSENT;
		if (id != 0)
			c->pins[ent(c, parent_of(c, id))]--;
	}
	return ret;
}

uint32_t relief_patch_cache_use_dist_half(struct relief_patch_cache *c, uint64_t frame, bool *reset)
{
	*reset = frame != c->dist_frame;
	c->dist_frame = frame;
	return (uint32_t)(frame & 1);
}

void relief_patch_cache_touch(struct relief_patch_cache *c, uint32_t id, uint64_t frame)
{
	uint32_t e = ent(c, id); /* UINT32_MAX also beyond the tree */
	if (e != UINT32_MAX && c->last_used[e] < frame)
		c->last_used[e] = frame;
}

/* ---- layers ---- */

/* The host array is what the CPU reads (layer_table may be uncached, write-combined memory
 * on a discrete GPU); layer_table is what the shaders read. Only this writes either. */
static void set_layer(struct relief_patch_cache *c, uint32_t id, int32_t layer)
{
	const uint32_t e = ent(c, id);
	c->layer[e] = layer;
	((int32_t *)c->layer_table.map)[e] = layer;
}

/* The resident patch whose layer may go: nothing depends on it (no resident child, no
 * child on its way, not the root) and it is not being decoded. */
static bool evictable(const struct relief_patch_cache *c, int32_t id)
{
	if (id <= 0)
		return false;
	const uint32_t e = ent(c, (uint32_t)id);
	return c->state[e] == RELIEF_PATCH_RESIDENT && !c->children[e] && !c->pins[e];
}

/* A layer for a patch requested with `priority`, or -1. */
static int32_t alloc_layer(struct relief_patch_cache *c, uint64_t frame, float priority)
{
	if (c->n_free_layers)
		return (int32_t)c->free_layers[--c->n_free_layers];
	/* Evict the least recently used resident patch that nothing depends on. Views on the
	 * GPU stamp the use table with the frame they drew a patch in. A layer whose patch is
	 * still being decoded (an earlier batch of this update, in flight) is not a candidate:
	 * that patch has never been drawn and would look the oldest of all. */
	const uint32_t *gpu_use = c->use_table.map;
	int32_t best = -1;
	uint64_t oldest = UINT64_MAX;
	for (uint32_t i = 0; i < c->pool.layers; i++) {
		int32_t id = c->owner[i];
		if (!evictable(c, id))
			continue;
		const uint32_t e = ent(c, (uint32_t)id);
		uint64_t used = c->last_used[e] > gpu_use[e] ? c->last_used[e] : gpu_use[e];
		if (used + c->o.keep_frames >= frame)
			continue;
		if (used < oldest) {
			oldest = used;
			best = (int32_t)i;
		}
	}
	/* Everything is in use: the patch wanted farthest away in the last frame drawn, if
	 * more than twice as far as this request (patch_cache.h). Only what that frame's views
	 * stamped counts (the distances of older frames are gone with their half). */
	if (best < 0 && c->dist_frame) {
		const uint32_t *dist = (const uint32_t *)c->use_dist.map + (c->dist_frame & 1) * c->count;
		const uint32_t stamp = (uint32_t)c->dist_frame;
		float farthest = 2.0f * priority;
		for (uint32_t i = 0; i < c->pool.layers; i++) {
			int32_t id = c->owner[i];
			if (!evictable(c, id))
				continue;
			const uint32_t e = ent(c, (uint32_t)id);
			if (gpu_use[e] != stamp || dist[e] == UINT32_MAX)
				continue;
			float d;
			memcpy(&d, &dist[e], sizeof(d));
			if (d > farthest) {
				farthest = d;
				best = (int32_t)i;
			}
		}
	}
	if (best < 0)
		return -1;
	uint32_t id = (uint32_t)c->owner[best];
	c->state[ent(c, id)] = RELIEF_PATCH_ABSENT;
	set_layer(c, id, -1);
	c->children[ent(c, parent_of(c, id))]--;
	c->owner[best] = -1;
	c->stats.evicted++;
	return best;
}

static void mark_bad(struct relief_patch_cache *c, uint32_t id, int why)
{
	uint32_t l, px, py;
	relief_patch_coords(&c->file->layout, id, &l, &px, &py);
	c->state[ent(c, id)] = RELIEF_PATCH_BAD; /* final: logged exactly once */
	c->stats.bad++;
	relief_log(&c->log, RELIEF_LOG_ERROR, "%s: patch %u (level %u, %u,%u): %s; its parent keeps serving the area",
	           relief_file_name(c->file), id, l, px, py,
	           why == -EBADMSG ? "corrupt (checksum or values)" : why == -EIO ? "missing from the file"
	                                                           : "cannot be decoded");
	if (id != 0)
		c->pins[ent(c, parent_of(c, id))]--;
}

static void release_slot(struct relief_patch_cache *c, uint32_t slot)
{
	pthread_mutex_lock(&c->lock);
	c->free_slots[c->n_free_slots++] = slot;
	pthread_cond_signal(&c->work);
	pthread_mutex_unlock(&c->lock);
}

/* ---- batches ---- */

/* Orders `pending` by request priority, most urgent first; ties keep their order. */
static void sort_pending(struct relief_patch_cache *c)
{
	for (uint32_t i = 1; i < c->n_pending; i++) {
		struct job j = c->pending[i];
		float p = c->queued_prio[ent(c, j.id)];
		uint32_t k = i;
		for (; k > 0 && c->queued_prio[ent(c, c->pending[k - 1].id)] > p; k--)
			c->pending[k] = c->pending[k - 1];
		c->pending[k] = j;
	}
}

/* The layer of a patch in a batch that is in flight, or -1. */
static int32_t in_flight_layer(const struct relief_patch_cache *c, uint32_t id)
{
	for (int i = 0; i < IN_FLIGHT; i++) {
		const struct batch *b = &c->batches[i];
		for (uint32_t k = 0; b->busy && k < b->n; k++)
			if (b->jobs[k].id == id)
				return (int32_t)b->layers[k];
	}
	return -1;
}

/* Batches retire in submission order, so a parent decoded in an earlier batch is resident
 * or bad by the time its child's batch retires. */
static void retire(struct relief_patch_cache *c, struct batch *b, uint64_t frame, int *made)
{
	const uint32_t *flags = c->flags.map;
	for (uint32_t i = 0; i < b->n; i++) {
		uint32_t id = b->jobs[i].id, layer = b->layers[i], e = ent(c, id);
		uint32_t pe = ent(c, id ? parent_of(c, id) : 0);
		/* Decoded from a parent that turned out bad (or was dropped in turn) in an earlier
		 * batch: not this patch's fault, and not usable; it may be requested again. */
		bool orphan = id != 0 && c->state[pe] != RELIEF_PATCH_RESIDENT;
		if (orphan || flags[b->jobs[i].slot]) {
			c->owner[layer] = -1;
			c->free_layers[c->n_free_layers++] = layer;
			if (orphan) {
				c->state[e] = RELIEF_PATCH_ABSENT;
				c->pins[pe]--;
			} else {
				mark_bad(c, id, -EBADMSG);
			}
		} else {
			c->state[e] = RELIEF_PATCH_RESIDENT;
			set_layer(c, id, (int32_t)layer);
			if (c->last_used[e] < frame)
				c->last_used[e] = frame;
			if (id != 0) {
				c->children[pe]++;
				c->pins[pe]--;
			}
			c->stats.decoded++;
			(*made)++;
		}
		release_slot(c, b->jobs[i].slot);
	}
	patch_gpu_time(c, b);
	b->busy = false;
	b->n = 0;
}

void relief_patch_cache_hold(struct relief_patch_cache *c)
{
	c->holds++;
}

void relief_patch_cache_release(struct relief_patch_cache *c)
{
	assert(c->holds > 0); /* paired with relief_patch_cache_hold() */
	if (c->holds)
		c->holds--;
}

int relief_patch_cache_update(struct relief_patch_cache *c, uint64_t frame)
{
	if (c->holds) {
		relief_log(&c->log, RELIEF_LOG_ERROR, "patch cache: update while %u frame(s) drawing from it are in flight",
		           c->holds);
		return -EBUSY;
	}
	int made = 0, ret = 0;
	for (;;) { /* the finished batches, oldest first */
		struct batch *oldest = NULL;
		for (int i = 0; i < IN_FLIGHT; i++)
			if (c->batches[i].busy && (!oldest || c->batches[i].seq < oldest->seq))
				oldest = &c->batches[i];
		if (!oldest || vkGetFenceStatus(c->vk->device, oldest->fence) != VK_SUCCESS)
			break;
		retire(c, oldest, frame, &made);
	}
	/* Take what the worker finished. */
	pthread_mutex_lock(&c->lock);
	struct job ready[256];
	uint32_t n = c->n_ready < 256 ? c->n_ready : 256;
	memcpy(ready, c->ready, sizeof(struct job) * n);
	memmove(c->ready, c->ready + n, sizeof(struct job) * (c->n_ready - n));
	c->n_ready -= n;
	c->stats.entropy_ns = c->entropy_ns;
	pthread_mutex_unlock(&c->lock);
	for (uint32_t i = 0; i < n; i++) {
		if (ready[i].result < 0) {
			mark_bad(c, ready[i].id, ready[i].result);
			release_slot(c, ready[i].slot);
		} else {
			c->state[ent(c, ready[i].id)] = RELIEF_PATCH_DECODING;
			c->pending[c->n_pending++] = ready[i];
		}
	}
	/* Fill free batches with pending patches whose parent is resident or in a batch in
	 * flight (the decode pass reads it; the queue runs batches in order and each begins
	 * with a barrier) and that get a layer; the others stay in `pending`. A batch filled
	 * here is in flight for the next, so one update can submit a chain of levels, one per
	 * free batch. Most urgent first (an ancestor is always ahead of its descendants): a
	 * layer that one request cannot have, no later one can (alloc_layer()). */
	sort_pending(c);
	bool no_layer = false;
	for (int i = 0; i < IN_FLIGHT && c->n_pending && !no_layer; i++) {
		struct batch *b = &c->batches[i];
		if (b->busy)
			continue;
		uint32_t kept = 0;
		for (uint32_t k = 0; k < c->n_pending; k++) {
			struct job j = c->pending[k];
			uint32_t parent = j.id ? parent_of(c, j.id) : 0, pe = ent(c, parent);
			uint8_t ps = j.id ? c->state[pe] : RELIEF_PATCH_RESIDENT;
			if (!on_its_way(ps)) {
				/* The parent went bad, or was dropped for that reason itself: an ancestor
				 * serves the area; the request may be made again later. */
				c->state[ent(c, j.id)] = RELIEF_PATCH_ABSENT;
				c->pins[pe]--;
				release_slot(c, j.slot);
				continue;
			}
			int32_t layer = -1, parent_layer = 0;
			if (j.id)
				parent_layer = ps == RELIEF_PATCH_RESIDENT ? c->layer[pe] : in_flight_layer(c, parent);
			if (parent_layer >= 0 && b->n < c->o.batch && !no_layer)
				no_layer = (layer = alloc_layer(c, frame, c->queued_prio[ent(c, j.id)])) < 0;
			if (layer < 0) {
				c->pending[kept++] = j;
				continue;
			}
			b->jobs[b->n] = j;
			b->layers[b->n] = (uint32_t)layer;
			b->parent_layers[b->n] = parent_layer;
			c->owner[layer] = (int32_t)j.id;
			b->n++;
		}
		c->n_pending = kept;
		if (!b->n)
			break;
		if ((ret = patch_gpu_submit(c, b)) < 0)
			return ret;
	}
	return made;
}

int relief_patch_cache_flush(struct relief_patch_cache *c, uint64_t frame)
{
	for (;;) {
		int ret = relief_patch_cache_update(c, frame);
		if (ret < 0)
			return ret;
		bool in_flight = false;
		for (int i = 0; i < IN_FLIGHT; i++)
			if (c->batches[i].busy) {
				vkWaitForFences(c->vk->device, 1, &c->batches[i].fence, VK_TRUE, UINT64_MAX);
				in_flight = true;
			}
		if (in_flight)
			continue;
		pthread_mutex_lock(&c->lock);
		/* The workers can still make progress: one is decoding, one has finished, or a
		 * request waits and a staging slot is free for it. Every slot may instead be held
		 * by a decoded patch waiting for a layer (pending), which the update above could
		 * not give it at this frame: then the requests behind them wait too. */
		bool worker = c->in_worker || c->n_ready || (c->n_heap && c->n_free_slots);
		if (!worker) {
			pthread_mutex_unlock(&c->lock);
			/* Pending symbols here wait for a layer that nothing will free at this frame. */
			return c->n_pending ? -ENOSPC : 0;
		}
		if (!c->n_ready) {
			struct timespec ts;
			clock_gettime(CLOCK_REALTIME, &ts);
			ts.tv_nsec += 2000000;
			if (ts.tv_nsec >= 1000000000) {
				ts.tv_sec++;
				ts.tv_nsec -= 1000000000;
			}
			pthread_cond_timedwait(&c->progress, &c->lock, &ts);
		}
		pthread_mutex_unlock(&c->lock);
	}
}

enum relief_patch_state relief_patch_cache_state(const struct relief_patch_cache *c, uint32_t id)
{
	uint32_t e = ent(c, id);
	return e != UINT32_MAX ? (enum relief_patch_state)c->state[e] : RELIEF_PATCH_NONE;
}

int relief_patch_cache_layer(const struct relief_patch_cache *c, uint32_t id)
{
	uint32_t e = ent(c, id);
	return e != UINT32_MAX && c->state[e] == RELIEF_PATCH_RESIDENT ? c->layer[e] : -1;
}

void relief_patch_cache_stats(const struct relief_patch_cache *c, struct relief_patch_cache_stats *s)
{
	*s = c->stats;
	s->layers = c->pool.layers;
	s->free = c->n_free_layers;
	s->used = c->pool.layers - c->n_free_layers;
	s->bytes = c->pool_bytes;
	s->bytes_per_layer = c->pool_bytes / c->pool.layers;
	s->staging_bytes = c->staging.size + c->flags.size;
	s->table_bytes = c->layer_table.size + c->use_table.size + c->use_dist.size;
	pthread_mutex_t *lock = (pthread_mutex_t *)&c->lock; /* the stats do not change c */
	pthread_mutex_lock(lock);
	s->waiting = c->n_ready + c->n_pending;
	s->queue_entries = c->n_heap;
	pthread_mutex_unlock(lock);
}

const struct relief_patch_pool *relief_patch_cache_pool(const struct relief_patch_cache *c)
{
	return &c->pool;
}

