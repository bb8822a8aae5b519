/* A device's shared objects (relief_vk_shared()): made once per device whoever asks and
 * from whichever thread, a failed creation undone and not kept, every object destroyed
 * with the device in the reverse order of making, a bounded number of kinds. (That the
 * patch caches on a device share theirs: test_patch_cache.) */
#include <errno.h>
#include <pthread.h>
#include <unistd.h>

#include "gpu_test.h"

/* What the test kinds did, in order: 'c' + kind index for a creation, 'd' + index for a
 * destruction. */
static char events[64];
static unsigned n_events;
static pthread_mutex_t events_lock = PTHREAD_MUTEX_INITIALIZER;
static int fail_next; /* the next creation fails after making its part */

struct thing {
	int index;   /* which kind made it */
	int made;    /* set by create(), so a caller sees a finished object */
	int partial; /* what a failed create() had made before failing */
};

static void note(char what, int index)
{
	pthread_mutex_lock(&events_lock);
	if (n_events + 2 < sizeof(events)) {
		events[n_events++] = what;
		events[n_events++] = (char)('0' + index);
		events[n_events] = 0;
	}
	pthread_mutex_unlock(&events_lock);
}

/* The kind being asked for (the kinds' create() cannot tell them apart otherwise). */
static const struct relief_vk_shared_kind *asked;

#define KINDS (RELIEF_VK_MAX_SHARED + 1)
static const struct relief_vk_shared_kind kinds[KINDS];

static int thing_create(struct relief_vk *vk, void *obj)
{
	struct thing *t = obj;
	assert_int_equal(t->made, 0); /* zeroed */
	(void)vk;
	t->index = (int)(asked - kinds);
	note('c', t->index);
	usleep(20000); /* long enough for the threads of test_threads_wait_for_one to meet */
	t->partial = 1;
	if (fail_next) {
		fail_next = 0;
		return -EIO;
	}
	t->made = 1;
	return 0;
}

static void thing_destroy(struct relief_vk *vk, void *obj)
{
	struct thing *t = obj;
	(void)vk;
	assert_int_equal(t->partial, 1);
	note('d', t->index);
}

static const struct relief_vk_shared_kind kinds[KINDS] = {
#define KIND { "test thing", sizeof(struct thing), thing_create, thing_destroy }
	KIND, KIND, KIND, KIND, KIND, KIND, KIND, KIND, KIND,
#undef KIND
};
_Static_assert(KINDS == 9, "one initialiser per kind");

static struct thing *get(struct relief_vk *vk, int k, int expect)
{
	void *obj = NULL;
	asked = &kinds[k];
	assert_int_equal(relief_vk_shared(vk, &kinds[k], &obj), expect);
	return obj;
}

static void reset_events(void)
{
	n_events = 0;
	events[0] = 0;
	fail_next = 0;
}

static void test_made_once_destroyed_in_reverse(void **state)
{
	(void)state;
	reset_events();
	struct relief_vk *vk = gpu_test_context();
	struct thing *a = get(vk, 0, 0), *b = get(vk, 1, 0);
	assert_true(a->made && b->made && a != b);
	assert_ptr_equal(get(vk, 0, 0), a);
	assert_ptr_equal(get(vk, 1, 0), b);
	get(vk, 2, 0);
	assert_string_equal(events, "c0c1c2");
	gpu_test_assert_clean(vk);
	relief_vk_destroy(vk);
	assert_string_equal(events, "c0c1c2d2d1d0");
}

static void test_failure_undone_and_not_kept(void **state)
{
	(void)state;
	reset_events();
	struct relief_vk *vk = gpu_test_context();
	fail_next = 1;
	assert_null(get(vk, 0, -EIO));
	assert_string_equal(events, "c0d0"); /* its part destroyed at once */
	struct thing *a = get(vk, 0, 0);
	assert_true(a->made);
	assert_string_equal(events, "c0d0c0");
	gpu_test_assert_clean(vk);
	relief_vk_destroy(vk);
	assert_string_equal(events, "c0d0c0d0");
}

static void test_kinds_bounded(void **state)
{
	(void)state;
	reset_events();
	struct relief_vk *vk = gpu_test_context();
	for (int k = 0; k < RELIEF_VK_MAX_SHARED; k++)
		get(vk, k, 0);
	assert_null(get(vk, RELIEF_VK_MAX_SHARED, -ENOSPC));
	assert_int_equal(n_events, 2 * RELIEF_VK_MAX_SHARED); /* nothing made for it */
	assert_non_null(get(vk, 3, 0));                        /* the others still served */
	gpu_test_assert_clean(vk);
	relief_vk_destroy(vk);
	assert_int_equal(n_events, 4 * RELIEF_VK_MAX_SHARED);
}

struct asker {
	struct relief_vk *vk;
	void *obj;
	int ret;
};

static void *ask(void *arg)
{
	struct asker *a = arg;
	a->ret = relief_vk_shared(a->vk, &kinds[0], &a->obj);
	return NULL;
}

static void test_threads_wait_for_one(void **state)
{
	(void)state;
	reset_events();
	struct relief_vk *vk = gpu_test_context();
	asked = &kinds[0];
	struct asker a[4];
	pthread_t th[4];
	for (int i = 0; i < 4; i++) {
		a[i] = (struct asker){ vk, NULL, 1 };
		assert_int_equal(pthread_create(&th[i], NULL, ask, &a[i]), 0);
	}
	for (int i = 0; i < 4; i++)
		assert_int_equal(pthread_join(th[i], NULL), 0);
	for (int i = 0; i < 4; i++) {
		assert_int_equal(a[i].ret, 0);
		assert_ptr_equal(a[i].obj, a[0].obj);
		assert_true(((struct thing *)a[i].obj)->made);
	}
	assert_string_equal(events, "c0");
	gpu_test_assert_clean(vk);
	relief_vk_destroy(vk);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_made_once_destroyed_in_reverse),
		cmocka_unit_test(test_failure_undone_and_not_kept),
		cmocka_unit_test(test_kinds_bounded),
		cmocka_unit_test(test_threads_wait_for_one),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
