/* relief bench lod's comparison at equal measured error (tools/bench_match.c). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

#include <cmocka.h>

#include "bench_match.h"

/* Chunked LOD at five tau as a status run measured it on Puget Sound (max error at pixels,
 * median ms, docs/bench/lod-status-dec2026.jsonl): against relief at tau = 1 (0.890 px)
 * the cheapest at least as accurate is tau = 2 (0.865 px, 53.5 ms), not tau = 0.5 and 1
 * (as accurate or more, but slower) nor 4 and 8 (cheaper, but less accurate). */
static void test_cheapest_at_least_as_accurate(void **state)
{
	(void)state;
	const struct bench_point chunked[] = {
		{ 0.217, 137.9 }, { 0.783, 69.5 }, { 0.865, 53.5 }, { 2.149, 37.7 }, { 2.514, 29.7 },
	};
	assert_int_equal(bench_match_cheapest(chunked, 5, 0.890), 2);
	assert_int_equal(bench_match_cheapest(chunked, 5, 0.800), 1);
	assert_int_equal(bench_match_cheapest(chunked, 5, 0.783), 1); /* equal error counts */
	assert_int_equal(bench_match_cheapest(chunked, 5, 10.0), 4);
	assert_int_equal(bench_match_cheapest(chunked, 5, 0.2), -1); /* none is that accurate */
	assert_int_equal(bench_match_cheapest(chunked, 0, 10.0), -1);
}

/* Unmeasured errors (negative, NaN) and times that are not numbers are never chosen; equal
 * times go to the smaller error. */
static void test_unmeasured_and_ties(void **state)
{
	(void)state;
	const struct bench_point p[] = {
		{ -1.0, 1.0 }, { NAN, 1.0 }, { 0.5, NAN }, { 0.5, INFINITY }, { 0.4, 5.0 }, { 0.3, 5.0 }, { 0.3, 5.0 },
	};
	assert_int_equal(bench_match_cheapest(p, 7, 1.0), 5);
	assert_int_equal(bench_match_cheapest(p, 4, 1.0), -1);
	assert_int_equal(bench_match_cheapest(p, 7, NAN), -1); /* nothing is within an unmeasured error */
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_cheapest_at_least_as_accurate),
		cmocka_unit_test(test_unmeasured_and_ties),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
