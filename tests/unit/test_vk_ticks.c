/* Timestamp arithmetic without a GPU: relief_vk_ticks_ns() across the counter's wrap, for
 * counters of 36 and 64 valid bits, with a period that is not a whole number of ns. */
#include <stdint.h>

#include "../test_util.h"
#include "vk.h"

static struct relief_vk clock_of(uint32_t bits, float period)
{
	struct relief_vk vk = { .timestamp_valid_bits = bits };
	vk.props.limits.timestampPeriod = period;
	return vk;
}

static void test_forward_and_back(void **state)
{
	struct relief_vk vk = clock_of(64, 1.0f);
	assert_int_equal(relief_vk_ticks_ns(&vk, 1000, 1250), 250);
	assert_int_equal(relief_vk_ticks_ns(&vk, 1250, 1000), -250); /* a later frame's start before an earlier end */
	assert_int_equal(relief_vk_ticks_ns(&vk, 7, 7), 0);
}

static void test_wrap(void **state)
{
	/* 36 bits: the counter wraps after 2^36 ticks (68.7 s at 1 ns). */
	struct relief_vk vk = clock_of(36, 1.0f);
	const uint64_t top = (1ull << 36) - 10;
	assert_int_equal(relief_vk_ticks_ns(&vk, top, 5), 15);
	assert_int_equal(relief_vk_ticks_ns(&vk, 5, top), -15);
	/* 64 bits wrap the same way. */
	vk = clock_of(64, 1.0f);
	assert_int_equal(relief_vk_ticks_ns(&vk, UINT64_MAX - 1, 3), 5);
	assert_int_equal(relief_vk_ticks_ns(&vk, 3, UINT64_MAX - 1), -5);
	/* Half the range apart: the far side of the wrap, with no overflow at 63 or 64 bits. */
	vk = clock_of(63, 1.0f);
	assert_true(relief_vk_ticks_ns(&vk, 0, 1ull << 62) == -(int64_t)(1ull << 62));
	assert_true(relief_vk_ticks_ns(&vk, 0, 1ull << 61) == (int64_t)(1ull << 61));
	vk = clock_of(64, 1.0f);
	assert_true(relief_vk_ticks_ns(&vk, 0, 1ull << 63) < -(int64_t)(1ull << 62));
	assert_int_equal(relief_vk_ticks_elapsed_ns(&vk, 10, 4), 0); /* out of order: none */
}

static void test_period(void **state)
{
	/* 52.083 ns per tick (a 19.2 MHz counter): rounded to the nearest ns. */
	struct relief_vk vk = clock_of(36, 52.083f);
	assert_int_equal(relief_vk_ticks_ns(&vk, 100, 196), 5000);      /* 96 ticks: 4999.97 ns */
	assert_int_equal(relief_vk_ticks_ns(&vk, (1ull << 36) - 1, 1), 104); /* 2 ticks across the wrap */
	/* No timestamps at all: no time. */
	vk = clock_of(0, 0.0f);
	assert_int_equal(relief_vk_ticks_ns(&vk, 1, 100), 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_forward_and_back),
		cmocka_unit_test(test_wrap),
		cmocka_unit_test(test_period),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
