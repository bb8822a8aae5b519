/* The GPU-resident patch cache: texture arrays of patch heights and normals plus a buffer of
 * tessellation-block errors, one layer per resident patch, filled by GPU decoding.
 *
 * Pipeline per patch: a worker thread fetches the stream (pread, CRC check) and
 * entropy-decodes labels and residuals into a staging slot; the render thread's
 * relief_patch_cache_update() records batches of compute dispatches that reconstruct the
 * heights from the parent's layer (bit-exact with the CPU reference decoder) and compute
 * the normal map, and copies the stored block errors (measured against the original data,
 * which the GPU does not have) into the patch's slot of the error buffer. update() never
 * waits: it only takes what the worker finished and what the GPU completed.
 *
 * Pools: heights R32_SINT, (P+2)^2 per layer, quantised (metres = 2 delta_l q), so that a
 * child refines its parent exactly; normals R32_UINT, P^2 per layer, each texel four snorm8
 * (GLSL packSnorm4x8: x east, y north, z up, w validity; in memory the bytes of an
 * R8G8B8A8_SNORM texel), stored packed because a CPU implementation (lavapipe) converts a
 * four-channel store lane by lane but packs in SIMD (docs/benchmarks.md); block records
 * (relief_patch_layer_floats()) per layer. Layer count: as many as the GPU memory budget holds (the
 * three pools' real allocation sizes never exceed it), at most maxImageArrayLayers and the
 * number of non-empty patches. All images stay in VK_IMAGE_LAYOUT_GENERAL.
 *
 * Residency rules: a patch is decoded from its parent's layer once the parent is resident or
 * in a batch already submitted (the queue runs batches in order, so one update can submit a
 * chain of levels, one per free batch; batches retire in submission order, and a child
 * whose parent turned out corrupt is dropped, not made resident); the parent stays pinned
 * until its child is resident; a patch with resident children is never evicted, nor one
 * still being decoded; the root is never evicted. Eviction takes the least recently used
 * resident patch that no view touched in the last keep_frames frames. When every resident
 * patch is in use, a patch waiting for a layer takes the one wanted farthest away in the
 * last frame (pool.use_dist: the distance to its parent's box, so siblings, which a split
 * needs together, count alike), if that is more than twice its own request priority (the
 * LOD selection asks with the same measure): a shared cache short of layers serves the
 * nearest detail of every view, not the first comer's, and with that margin an evicted
 * patch asked for again can never evict the one that took its place (no ping-pong). A
 * patch whose stream fails its CRC (or whose file lost it, or whose values are out of
 * range) is marked bad, logged once, and never drawn: its parent keeps serving that area.
 *
 * Threading: all functions are for the thread that owns the Vulkan queue, except that the
 * worker runs inside. The file must outlive the cache. */
#pragma once

#include <stdbool.h>
#include <stdint.h>

#include "format.h"
#include "vk.h"

struct relief_patch_cache;

struct relief_patch_cache_options {
	uint64_t budget_bytes;   /* GPU memory for the three pools (default 256 MiB) */
	uint32_t staging_slots;  /* entropy-decoded patches waiting for the GPU (default 32) */
	uint32_t batch;          /* patches per submission (default 16) */
	uint32_t keep_frames;    /* not evicted within this many frames of a touch (default 2) */
	uint32_t max_layers;     /* 0, or a cap below what the budget allows (tests) */
	uint32_t workers;        /* entropy-decoding threads (default 1, at most 8) */
	/* Timestamps between a batch's passes too (stats.gpu_decode_ns and the rest), not only
	 * at its start and end: for profiling (relief bench decode). lavapipe flushes its
	 * pipeline at every timestamp not at the top of the pipe, about 0.1 ms each
	 * (docs/benchmarks.md), so a cache that streams leaves them out. */
	bool pass_timing;
};

#define RELIEF_PATCH_CACHE_MAX_WORKERS 8u

enum relief_patch_state {
	RELIEF_PATCH_ABSENT = 0,
	RELIEF_PATCH_QUEUED,   /* waiting for or in the worker */
	RELIEF_PATCH_DECODING, /* symbols ready, waiting for or in a GPU batch */
	RELIEF_PATCH_RESIDENT,
	RELIEF_PATCH_BAD,      /* corrupt or lost; never retried */
	RELIEF_PATCH_NONE,     /* EMPTY in the file: nothing to draw */
};

struct relief_patch_cache_stats {
	uint32_t layers, used, free;
	uint64_t bytes;           /* GPU memory of the pools */
	uint64_t bytes_per_layer; /* bytes / layers */
	uint64_t staging_bytes;   /* host-visible staging */
	uint64_t table_bytes;     /* the per-patch tables (16 bytes per index entry), outside the budget */
	uint64_t decoded, evicted, bad, batches;
	uint64_t gpu_ns;          /* summed GPU time of the decode batches (timestamps) */
	uint64_t gpu_decode_ns;   /* with pass_timing, of which heights: block error copies and the decode pass */
	uint64_t gpu_normals_ns;  /* the normals pass */
	uint64_t gpu_strips_ns;   /* and the transition strip bounds' pass (all 0 without pass_timing) */
	uint64_t entropy_ns;      /* summed worker time in fetch + entropy decoding */
	uint32_t waiting;         /* patches entropy-decoded, not yet taken into a batch */
	uint32_t queue_entries;   /* request queue entries: at most twice the live ones plus 256 */
};

/* The resources a renderer binds. Owned by the cache. */
struct relief_patch_pool {
	VkImageView heights;      /* 2D array, R32_SINT, (P+2)^2 */
	VkImageView normals;      /* 2D array, R32_UINT (packed snorm8 x 4), P^2 */
	VkBuffer block_errors;    /* per layer: its block record (relief_patch_layer_floats()) */
	VkBufferView block_view;  /* the same as R32_SFLOAT texels (a uniform texel buffer) */
	uint32_t layers;
	/* The per-patch tables have one element per entry, the patch's record number in the
	 * file's index (relief_index_entry()): EMPTY patches outside the raster have none.
	 * int32[index_records]: the layer of each resident patch, -1 otherwise; host-visible,
	 * kept current by the cache, read by the LOD selection on the GPU. */
	VkBuffer layer_table;
	VkBufferView layer_view; /* the same as R32_SINT texels (a uniform texel buffer) */
	/* uint32[index_records]: the last frame a view wanted each resident patch (drew it, or
	 * would once its siblings arrive), written by the LOD selection on the GPU; eviction
	 * treats it like relief_patch_cache_touch(). */
	VkBuffer use_table;
	/* uint32[2][index_records], host-visible: for the frames of each parity (the half
	 * relief_patch_cache_use_dist_half() names), the least distance from a view's camera to
	 * the box of a wanted resident patch's parent (float bits; the LOD selection writes it
	 * with atomicMin, UINT32_MAX: no view wanted it). With no unused layer left, a request
	 * much nearer than that takes the layer (the residency rules above). */
	VkBuffer use_dist;
};

int relief_patch_cache_create(struct relief_vk *vk, const struct relief_file *f,
                              const struct relief_patch_cache_options *opts, const struct relief_logger *log,
                              struct relief_patch_cache **out);
void relief_patch_cache_destroy(struct relief_patch_cache *c);

/* Asks for patch id; a lower priority value is served first (e.g. the distance to the
 * closest camera; asked again with a lower value while it still waits for a worker, it is
 * served by that one: with several views, the nearest decides). Returns 0 if it is
 * resident or on its way (its parent must be resident or on its way too: the worker then
 * decodes the parent's symbols first and the GPU reconstructs the child once the parent
 * is resident), -EAGAIN if its parent is neither (the parent is requested instead, more
 * urgently), -ENOENT for a patch with nothing to draw, -EIO for a bad patch, -EINVAL for
 * an id outside the tree. */
int relief_patch_cache_request(struct relief_patch_cache *c, uint32_t id, float priority);
/* The half of pool.use_dist that the views drawn in `frame` write: frame & 1. *reset is
 * true when `frame` differs from the previous call's (the first view of a frame): the
 * caller then fills that half with 0xff bytes on the GPU before the view writes it. */
uint32_t relief_patch_cache_use_dist_half(struct relief_patch_cache *c, uint64_t frame, bool *reset);
/* Marks patch id as used by a view in `frame` (keeps it from eviction for keep_frames). */
void relief_patch_cache_touch(struct relief_patch_cache *c, uint32_t id, uint64_t frame);
/* A frame that reads the cache's tables is in flight (submitted, not yet waited for):
 * while any is, relief_patch_cache_update() and _flush() refuse (-EBUSY), since they
 * write the layer table that frame reads and read the use tables it writes, from the
 * host. The renderer holds the cache from a view's submission to its wait. */
void relief_patch_cache_hold(struct relief_patch_cache *c);
void relief_patch_cache_release(struct relief_patch_cache *c);
/* Non-blocking progress, once per frame: retires finished GPU batches, submits new ones.
 * Returns the number of patches that became resident, or a negative errno (-EBUSY while
 * a frame is in flight, relief_patch_cache_hold()). */
int relief_patch_cache_update(struct relief_patch_cache *c, uint64_t frame);
/* Blocks until nothing is queued, decoding or in flight (tests, benchmarks). -ENOSPC when
 * decoded patches wait for a layer that nothing frees at this frame: every layer holds a
 * patch used within keep_frames of it (a view that wants more patches than the budget
 * holds). */
int relief_patch_cache_flush(struct relief_patch_cache *c, uint64_t frame);

enum relief_patch_state relief_patch_cache_state(const struct relief_patch_cache *c, uint32_t id);
int relief_patch_cache_layer(const struct relief_patch_cache *c, uint32_t id); /* -1 if not resident */
void relief_patch_cache_stats(const struct relief_patch_cache *c, struct relief_patch_cache_stats *s);
const struct relief_patch_pool *relief_patch_cache_pool(const struct relief_patch_cache *c);

/* What a layer's block record holds from the file, in floats: blocks^2 x 4 errors,
 * blocks^2 x 2 height ranges (metres; both as relief_file_block_errors() and _ranges() give
 * them), then which blocks have a valid sample (relief_mask_blocks()), 16 blocks per float:
 * an integer 0..65535 whose bit j in float w is block 16 w + j in raster order. The
 * renderer draws nothing of a block without one. */
size_t relief_patch_block_floats(uint32_t patch_size);
/* A layer's whole block record, in floats: the above, then what the decode computes from
 * the patch's samples, RELIEF_STRIP_FLOATS per block and edge (west, north, east, south;
 * blocks in raster order): the transition strip bounds of relief_strip_bounds(). */
size_t relief_patch_layer_floats(uint32_t patch_size);

/* Copies one layer back to the host (waits): heights (P+2)^2 ints, normals P^2 x 4 snorm8,
 * the block record (relief_patch_layer_floats() floats); any pointer may be NULL. For
 * tests and tools. */
int relief_patch_cache_read_layer(struct relief_patch_cache *c, uint32_t layer, int32_t *heights, int8_t *normals,
                                  float *block_errors);
