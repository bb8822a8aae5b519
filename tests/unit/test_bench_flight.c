/* Popping over every frame of the benchmark flight (tools/bench_flight.c): the pairs chosen
 * and the stratified mean over the line, against sums worked out by hand. */
#include <errno.h>
#include <math.h>

#include "../test_util.h"
#include "bench_flight.h"

#define assert_near(a, b, eps) assert_true(fabs((a) - (b)) <= (eps))

/* Two methods' LOD-change pairs and an even sample of 4 of 20 pairs (2, 7, 12, 17): every
 * one of them once, ascending, the sample's marked; too small a cap is refused. */
static void test_choose(void **state)
{
	(void)state;
	uint8_t a[20] = { 0 }, b[20] = { 0 };
	a[3] = a[7] = 1;
	b[0] = b[19] = 1;
	const uint8_t *changed[2] = { a, b };
	uint32_t at[20];
	uint8_t sampled[20];
	assert_int_equal(bench_flight_choose(20, changed, 2, 4, at, sampled, 20), 7);
	const uint32_t want_at[7] = { 0, 2, 3, 7, 12, 17, 19 };
	const uint8_t want_sampled[7] = { 0, 1, 0, 1, 1, 1, 0 };
	assert_memory_equal(at, want_at, sizeof(want_at));
	assert_memory_equal(sampled, want_sampled, sizeof(want_sampled));
	assert_int_equal(bench_flight_choose(20, changed, 2, 4, at, sampled, 6), -E2BIG);
	/* A sample larger than the line takes every pair once. */
	assert_int_equal(bench_flight_choose(5, changed, 0, 9, at, sampled, 20), 5);
	for (uint32_t k = 0; k < 5; k++)
		assert_true(at[k] == k && sampled[k]);
}

/* The mean over 20 pairs: LOD-change pairs 3 and 7 (values 1.0 and 0.6) each once; the
 * other 18 by the sampled pairs that are not the method's own LOD-change pairs (2, 12, 17:
 * 7 is one), here 0.1, 0.2, 0.3, each standing for 6. Another method's LOD-change pair (0)
 * is in neither stratum. */
static void test_mean(void **state)
{
	(void)state;
	uint8_t changed[20] = { 0 };
	changed[3] = changed[7] = 1;
	const uint32_t at[6] = { 0, 2, 3, 7, 12, 17 };
	const uint8_t sampled[6] = { 0, 1, 0, 1, 1, 1 };
	const double v[6] = { 50.0, 0.1, 1.0, 0.6, 0.2, 0.3 };
	struct bench_flight_mean m = bench_flight_mean(20, changed, at, sampled, 6, v);
	assert_int_equal(m.events, 2);
	assert_int_equal(m.sampled, 3);
	assert_near(m.mean, (1.0 + 0.6 + 18 * 0.2) / 20, 1e-12);
	/* Standard error of the sampled part: its share, 18 / 20, times sd / sqrt(n) with the
	 * finite population's correction (1 - 3 / 18); sd of 0.1, 0.2, 0.3 is 0.1. */
	assert_near(m.se, 18.0 / 20 * sqrt(0.01 / 3 * (1 - 3.0 / 18)), 1e-12);
	/* A sampled pair without terrain in view (NaN) leaves the line's pairs as the other
	 * samples show them: here two of three, so 12 pairs stand behind them. */
	const double holed[6] = { 50.0, NAN, 1.0, 0.6, 0.2, 0.3 };
	m = bench_flight_mean(20, changed, at, sampled, 6, holed);
	assert_near(m.mean, (1.0 + 0.6 + 12 * 0.25) / 14, 1e-12);
	/* Constant values on the pairs without a LOD change: the mean is exact, no error. */
	const double flat[6] = { 50.0, 0.5, 2.0, 4.0, 0.5, 0.5 };
	m = bench_flight_mean(20, changed, at, sampled, 6, flat);
	assert_near(m.mean, (2.0 + 4.0 + 18 * 0.5) / 20, 1e-12);
	assert_near(m.se, 0.0, 1e-15);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_choose),
		cmocka_unit_test(test_mean),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
