/* The patch cache's worker threads: they take requests from a min-heap on priority (the
 * render thread pushes), fetch and entropy-decode each patch into a free staging slot and
 * hand it back on the ready list (patch_cache_internal.h; locking rules in patch_cache.c). */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "patch_cache_internal.h"

static uint64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* ---- request heap (min-heap on priority), under lock ---- */

static void heap_insert(struct relief_patch_cache *c, struct request r)
{
	uint32_t i = c->n_heap++;
	while (i > 0 && c->heap[(i - 1) / 2].prio > r.prio) {
		c->heap[i] = c->heap[(i - 1) / 2];
		i = (i - 1) / 2;
	}
	c->heap[i] = r;
}

/* A patch asked for again more urgently is pushed again, and the older entry stays until
 * it comes up (then skipped): while the workers wait for staging slots (every slot held by
 * a patch waiting for a layer) a camera closing in would grow the heap by an entry per
 * patch and frame, without bound in a long run. So once the heap has grown to twice its
 * live entries (plus 256), the stale ones are dropped: an entry is live while its patch
 * is queued and the entry carries the patch's latest priority. */
static void heap_compact(struct relief_patch_cache *c)
{
	uint32_t n = 0;
	for (uint32_t i = 0; i < c->n_heap; i++)
		if (c->queued[ent(c, c->heap[i].id)] && c->heap[i].prio == c->queued_prio[ent(c, c->heap[i].id)])
			c->heap[n++] = c->heap[i];
	c->n_heap = 0;
	for (uint32_t i = 0; i < n; i++)
		heap_insert(c, c->heap[i]); /* entries below i are already placed, i.. not yet read */
	c->heap_live = n;
}

int patch_queue_push(struct relief_patch_cache *c, float prio, uint32_t id)
{
	if (c->n_heap >= 2 * c->heap_live + 256)
		heap_compact(c);
	if (c->n_heap == c->cap_heap) {
		uint32_t cap = c->cap_heap ? 2 * c->cap_heap : 256;
		struct request *h = realloc(c->heap, sizeof(*h) * cap);
		if (!h)
			return -ENOMEM;
		c->heap = h;
		c->cap_heap = cap;
	}
	heap_insert(c, (struct request){ prio, id });
	return 0;
}

static struct request heap_pop(struct relief_patch_cache *c)
{
	struct request top = c->heap[0], last = c->heap[--c->n_heap];
	uint32_t i = 0;
	for (;;) {
		uint32_t l = 2 * i + 1, r = l + 1, m = i;
		float mp = last.prio;
		if (l < c->n_heap && c->heap[l].prio < mp)
			m = l, mp = c->heap[l].prio;
		if (r < c->n_heap && c->heap[r].prio < mp)
			m = r;
		if (m == i)
			break;
		c->heap[i] = c->heap[m];
		i = m;
	}
	if (c->n_heap)
		c->heap[i] = last;
	return top;
}

/* ---- the worker: fetch, check, entropy-decode into a staging slot ---- */

static int fill_slot(struct relief_patch_cache *c, struct relief_decoder *dec, int32_t *root_tmp, uint32_t id,
                     uint32_t slot)
{
	const struct relief_patch_geom *g = &c->file->layout.geom;
	int ret = relief_decoder_symbols(dec, id);
	if (ret < 0)
		return ret;
	int32_t *s = (int32_t *)c->staging.map + (size_t)slot * c->slot_ints;
	int32_t *values = s + g->n_labels;
	if (id == 0) {
		/* The root's MED prediction runs in raster order: reconstructed here, copied on the GPU. */
		if ((ret = relief_root_reconstruct(g, dec->residuals, root_tmp)) < 0)
			return ret;
		memcpy(values, root_tmp, sizeof(int32_t) * g->E * g->E);
	} else {
		for (uint32_t i = 0; i < g->n_labels; i++)
			s[i] = dec->labels[i];
		memcpy(values, dec->residuals, sizeof(int32_t) * g->n_residuals);
	}
	struct relief_patch_record rec;
	relief_file_record(c->file, id, &rec);
	const size_t n_errors = relief_block_errors_per_patch(c->P), n_ranges = relief_block_ranges_per_patch(c->P);
	const size_t n_blocks = n_ranges / 2;
	uint8_t has_data[RELIEF_MAX_BLOCKS];
	memset(has_data, 1, n_blocks);
	if (rec.flags & RELIEF_PATCH_MASKED) {
		/* Validity bytes, four per int, read by the normals pass into the normals' w. */
		uint8_t *mask = (uint8_t *)(values + (size_t)g->E * g->E);
		memset(mask, 0, c->mask_ints * 4);
		if ((ret = relief_file_mask(c->file, id, mask)) < 0)
			return ret;
		relief_mask_blocks(mask, c->P, has_data);
	}
	float *blocks = (float *)(s + c->slot_ints - c->block_floats);
	relief_file_block_errors(c->file, id, blocks);
	relief_file_block_ranges(c->file, id, blocks + n_errors);
	float *words = blocks + n_errors + n_ranges;
	for (size_t w = 0; w < (n_blocks + 15) / 16; w++) {
		uint32_t bits = 0;
		for (size_t j = 0; j < 16 && 16 * w + j < n_blocks; j++)
			bits |= (uint32_t)has_data[16 * w + j] << j;
		words[w] = (float)bits; /* exact: below 2^24 */
	}
	return 0;
}

void *patch_worker_main(void *data)
{
	struct relief_patch_cache *c = data;
	struct relief_decoder dec;
	int init = relief_decoder_init(&dec, c->file);
	int32_t *root_tmp = malloc(sizeof(int32_t) * c->E * c->E);
	pthread_mutex_lock(&c->lock);
	for (;;) {
		while (!c->stop && (c->n_heap == 0 || c->n_free_slots == 0))
			pthread_cond_wait(&c->work, &c->lock);
		if (c->stop)
			break;
		struct request r = heap_pop(c);
		if (!c->queued[ent(c, r.id)])
			continue; /* a duplicate of a request already served */
		c->queued[ent(c, r.id)] = 0;
		uint32_t slot = c->free_slots[--c->n_free_slots];
		c->in_worker++;
		pthread_mutex_unlock(&c->lock);
		uint64_t t0 = now_ns();
		int result = init < 0 ? init : !root_tmp ? -ENOMEM : fill_slot(c, &dec, root_tmp, r.id, slot);
		uint64_t t1 = now_ns();
		pthread_mutex_lock(&c->lock);
		c->ready[c->n_ready++] = (struct job){ r.id, slot, result };
		c->in_worker--;
		c->entropy_ns += t1 - t0;
		pthread_cond_broadcast(&c->progress);
	}
	pthread_mutex_unlock(&c->lock);
	free(root_tmp);
	if (init == 0)
		relief_decoder_finish(&dec);
	return NULL;
}
