#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

#include "parallel.h"

struct job {
	size_t n;
	atomic_size_t next;
	atomic_int error;
	int (*fn)(void *, size_t);
	void *ctx;
};

static void *worker(void *data)
{
	struct job *j = data;
	for (;;) {
		size_t i = atomic_fetch_add(&j->next, 1);
		if (i >= j->n)
			break;
		int r = j->fn(j->ctx, i);
		if (r < 0) {
			int expected = 0;
			atomic_compare_exchange_strong(&j->error, &expected, r);
		}
	}
	return NULL;
}

unsigned relief_cpu_count(void)
{
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	return n > 0 ? (unsigned)n : 1;
}

int relief_parallel_for(size_t n, unsigned threads, int (*fn)(void *ctx, size_t i), void *ctx)
{
	struct job j = { .n = n, .fn = fn, .ctx = ctx };
	atomic_init(&j.next, 0);
	atomic_init(&j.error, 0);
	if (!threads)
		threads = relief_cpu_count();
	if (threads > n)
		threads = n ? (unsigned)n : 1;
	pthread_t *tid = calloc(threads, sizeof(*tid));
	unsigned started = 0;
	if (tid)
		for (; started + 1 < threads; started++)
			if (pthread_create(&tid[started], NULL, worker, &j) != 0)
				break;
	worker(&j); /* the calling thread works too */
	for (unsigned i = 0; i < started; i++)
		pthread_join(tid[i], NULL);
	free(tid);
	return atomic_load(&j.error);
}
