/* relief_lod_border_charges() on a hand-made patch of 3 x 3 blocks: each side takes the
 * blocks along it and their edge on that side only, eps made non-decreasing, the larger of
 * it and the strip charge, non-decreasing again, the largest over the side's blocks. The
 * GPU's twin (edge_charges_in(), lod_force.comp) is held to it by the selection tests
 * (test_lod_mesh's test_mesh_finer_border: the GPU's selection equals the CPU's where the
 * rule splits). Negative controls, run when the test was written: the north and south
 * sides' edge indices swapped, and the strip charges taken without the block errors, each
 * fail it (100 and 0.5 where 1 is due). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "lod.h"
#include "strip_bound.h"

enum { B = 3 };

static float eps[B * B * 4], strips[B * B * 4 * RELIEF_STRIP_FLOATS];

/* Edge `edge` (0 west, 1 north, 2 east, 3 south) of block (bx, by): its strip charges. */
static void set_strips(int bx, int by, int edge, const float v[4])
{
	memcpy(strips + ((size_t)((by * B + bx) * 4 + edge)) * RELIEF_STRIP_FLOATS, v, 4 * sizeof(float));
}

static void set_eps(int bx, int by, const float v[4]) { memcpy(eps + (by * B + bx) * 4, v, 4 * sizeof(float)); }

static void test_sides(void **state)
{
	(void)state;
	memset(eps, 0, sizeof(eps));
	memset(strips, 0, sizeof(strips));
	set_eps(1, 0, (const float[4]){ 1, 0.5f, 3, 2 });          /* north: non-decreasing 1, 1, 3, 3 */
	set_strips(1, 0, 1, (const float[4]){ 0, 2, 0, 0 });        /* ... its north edge: 1, 2, 3, 3 */
	set_strips(2, 0, 1, (const float[4]){ 0.5f, 0.5f, 0.5f, 5 }); /* north-east corner, north edge */
	set_strips(1, 0, 3, (const float[4]){ 100, 100, 100, 100 }); /* a north block's south edge: no side's */
	set_eps(1, 1, (const float[4]){ 50, 50, 50, 50 });          /* the middle block: no side's */
	set_strips(0, 2, 3, (const float[4]){ 0, 0, 0, 4 });        /* south-west corner, south edge */
	set_strips(0, 2, 0, (const float[4]){ 6, 0, 0, 0 });        /* ... and its west edge */
	set_strips(2, 1, 0, (const float[4]){ 77, 77, 77, 77 });    /* an east block's west edge: no side's */
	/* The strips' floats 4..7 (fine-edge charges) are not a border's. */
	strips[((0 * B + 2) * 4 + 2) * RELIEF_STRIP_FLOATS + 5] = 1000;
	float out[RELIEF_LOD_BORDER_FLOATS];
	relief_lod_border_charges(eps, strips, B, out);
	const float want[RELIEF_LOD_BORDER_FLOATS] = {
		1, 2, 3, 5, /* north */
		0, 0, 0, 4, /* south */
		6, 6, 6, 6, /* west */
		0, 0, 0, 0, /* east */
	};
	for (int k = 0; k < RELIEF_LOD_BORDER_FLOATS; k++) {
		if (out[k] != want[k])
			print_error("side %d level %d: %g, want %g\n", k / 4, k % 4 + 1, out[k], want[k]);
		assert_true(out[k] == want[k]);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_sides),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
