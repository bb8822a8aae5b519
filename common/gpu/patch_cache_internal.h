/* Internals of the GPU patch cache, shared by its three files: patch_cache.c (requests,
 * layers, eviction, batches: the render thread), patch_gpu.c (descriptors, pipelines,
 * command recording, timestamps) and patch_worker.c (the request heap and the worker
 * threads). See patch_cache.c for the locking rules. Not part of relief-gpu's interface. */
#pragma once

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>

#include "decode.h"
#include "patch_cache.h"
#include "pipeline.h"

#define MAX_BATCH 64
#define IN_FLIGHT 3
/* Items (segments of 8 quads, blocks of 4 x 8 samples) per workgroup of the patch passes
 * (shaders/patch_run.glsl): four per lane. */
#define RUN_ITEMS 256u

/* Twin of `Job` in shaders/patch_job.glsl (std430), read by the three patch passes. */
struct job_params {
	int32_t layer, parent_layer, quadrant, ratio;
	uint32_t slot, flag;
	int32_t mode, P;
	uint32_t mask;
	float q2, inv_2sx, inv_2sy;
	int32_t finest; /* 1: the patch is at the file's finest level (strips pass) */
	float e0;       /* eps_0 above the finest level: the drawn error E0(P), or infinity (strips pass) */
};
_Static_assert(sizeof(struct job_params) == 56, "job record");

struct request {
	float prio;
	uint32_t id;
};

/* A staging slot's content, handed from the worker to the render thread. */
struct job {
	uint32_t id, slot;
	int result; /* 0, or the worker's negative errno */
};

struct batch {
	bool busy;
	uint64_t seq; /* submission order: batches retire in it */
	VkCommandBuffer cmd;
	VkFence fence;
	uint32_t n;
	struct job jobs[MAX_BATCH];
	uint32_t layers[MAX_BATCH];
	int32_t parent_layers[MAX_BATCH]; /* resident, or in an earlier batch still in flight */
};

struct patch_program;

struct relief_patch_cache {
	struct relief_vk *vk;            /* borrowed */
	const struct relief_file *file;  /* borrowed */
	struct relief_logger log;
	struct relief_patch_cache_options o;
	uint32_t P, E, count; /* count: entries (relief_index_entry()), the per-patch arrays' length */
	size_t block_floats;             /* floats per patch from the file (relief_patch_block_floats()) */
	size_t layer_floats;             /* floats per layer: those and the strip bounds (relief_patch_layer_floats()) */
	size_t slot_ints;                /* labels, values, mask, block errors and ranges */
	size_t mask_ints;                /* P^2 validity bytes, four per int */

	/* GPU objects */
	struct relief_vk_image heights, normals;
	/* Memory by use (relief_vk_memory_pick()): errors on the device; staging and jobs
	 * uploads; the layer table shared (the CPU edits it, every view's selection reads all
	 * of it each frame); flags and the use tables read back (a frame stamps only the
	 * patches it touches; the CPU scans them when it evicts). */
	struct relief_vk_buffer errors, staging, flags, layer_table, use_table, use_dist;
	struct relief_vk_buffer jobs; /* job_params[IN_FLIGHT][MAX_BATCH] */
	VkBufferView staging_view;    /* the staging buffer as R32_SINT texels (see patch_gpu.c) */
	VkBufferView errors_view;     /* the block records as R32_SFLOAT texels, for the terrain (patch_gpu.c) */
	VkBufferView layer_view;      /* the layer table as R32_SINT texels, for the terrain */
	/* the passes' layouts and pipelines, the device's (patch_gpu.c) */
	const struct patch_program *prog;
	VkDescriptorPool descriptor_pool;
	VkDescriptorSet set;
	VkCommandPool cmd_pool;
	VkQueryPool timer;
	struct batch batches[IN_FLIGHT];
	uint64_t next_seq;
	struct relief_patch_pool pool;
	uint64_t pool_bytes;

	uint64_t dist_frame; /* the frame whose use_dist half was last reset, 0: none yet */
	uint32_t holds;      /* frames in flight that read the tables (relief_patch_cache_hold()) */

	/* render-thread state, per patch entry (ent()) */
	uint8_t *state;
	int32_t *layer; /* layer of each resident patch, -1 otherwise; mirrored to layer_table */
	uint64_t *last_used;
	uint16_t *children; /* resident children */
	uint16_t *pins;     /* children queued or decoding */
	/* per layer */
	int32_t *owner;
	uint32_t *free_layers, n_free_layers;
	/* symbols ready, waiting for a layer and a batch */
	struct job *pending;
	uint32_t n_pending;
	struct relief_patch_cache_stats stats;

	/* shared with the worker, under lock */
	pthread_mutex_t lock;
	pthread_cond_t work, progress;
	struct request *heap;
	uint32_t n_heap, cap_heap;
	uint32_t heap_live; /* entries left by the last compaction (patch_worker.c) */
	uint8_t *queued;    /* per entry */
	float *queued_prio; /* per entry: a queued or decoding patch's most urgent request priority */
	uint32_t *free_slots, n_free_slots;
	struct job *ready;
	uint32_t n_ready;
	uint32_t in_worker;
	uint64_t entropy_ns;
	bool stop;
	uint32_t n_threads; /* workers started */
	pthread_t threads[RELIEF_PATCH_CACHE_MAX_WORKERS];
};

/* Patch id's entry, the index of its element in the per-patch arrays (and the GPU's
 * tables); UINT32_MAX for a patch without one (EMPTY: never requested, never resident).
 * The cache's jobs, requests and layer owners carry patch ids. */
static inline uint32_t ent(const struct relief_patch_cache *c, uint32_t id)
{
	return relief_index_entry(&c->file->hdr, id);
}

static inline uint32_t parent_of(const struct relief_patch_cache *c, uint32_t id)
{
	uint32_t l, px, py;
	relief_patch_coords(&c->file->layout, id, &l, &px, &py);
	return relief_patch_id(l - 1, px / 2, py / 2);
}

/* A patch that is resident or on its way there: a child may be requested under it, and a
 * child's job keeps waiting for it. Any other state means it will not become resident. */
static inline bool on_its_way(uint8_t state)
{
	return state == RELIEF_PATCH_RESIDENT || state == RELIEF_PATCH_QUEUED || state == RELIEF_PATCH_DECODING;
}

/* patch_gpu.c. Descriptors, pipelines, command buffers and the timestamp pool, and the
 * pools put into the GENERAL layout with both passes run once (pipelines compiled). */
int patch_gpu_init(struct relief_patch_cache *c);
/* Destroys what patch_gpu_init() made (any part may be missing); the device is idle. */
void patch_gpu_finish(struct relief_patch_cache *c);
/* Records and submits batch b (its jobs and layers are set). */
int patch_gpu_submit(struct relief_patch_cache *c, struct batch *b);
/* Adds finished batch b's timestamps to the stats. */
void patch_gpu_time(struct relief_patch_cache *c, const struct batch *b);

/* patch_worker.c. Both under c->lock. */
int patch_queue_push(struct relief_patch_cache *c, float prio, uint32_t id);
void *patch_worker_main(void *data);
