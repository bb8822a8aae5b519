#include <math.h>

#include "../test_util.h"
#include "mat4.h"

static void test_perspective_depth_range(void **state)
{
	struct relief_mat4 view, proj, mvp;
	assert_true(relief_mat4_look_at((struct relief_vec3){ 0, 0, 10 }, (struct relief_vec3){ 0, 0, 0 },
	                                (struct relief_vec3){ 0, 1, 0 }, &view));
	proj = relief_mat4_perspective(M_PI / 2, 1.0, 1.0, 100.0);
	mvp = relief_mat4_mul(&proj, &view);
	double w;
	/* A point at the near plane maps to depth 0, at the far plane to 1. */
	struct relief_vec3 n = relief_mat4_transform(&mvp, (struct relief_vec3){ 0, 0, 9 }, &w);
	assert_true(fabs(n.z / w) < 1e-12);
	struct relief_vec3 f = relief_mat4_transform(&mvp, (struct relief_vec3){ 0, 0, -90 }, &w);
	assert_true(fabs(f.z / w - 1.0) < 1e-12);
	/* World +y (the up vector) appears at the top: negative clip y in Vulkan. */
	struct relief_vec3 up = relief_mat4_transform(&mvp, (struct relief_vec3){ 0, 1, 0 }, &w);
	assert_true(up.y / w < 0);
}

static void test_reversed_depth(void **state)
{
	struct relief_mat4 p = relief_mat4_perspective_reversed(M_PI / 3, 2.0, 0.5, 1e6);
	double w;
	struct relief_vec3 n = relief_mat4_transform(&p, (struct relief_vec3){ 0, 0, -0.5 }, &w);
	assert_true(fabs(n.z / w - 1.0) < 1e-12); /* near plane: depth 1 */
	struct relief_vec3 f = relief_mat4_transform(&p, (struct relief_vec3){ 0, 0, -1e6 }, &w);
	assert_true(fabs(f.z / w) < 1e-12);       /* far plane: depth 0 */
	/* Far away, neighbouring float depths are still metres apart, not kilometres. */
	struct relief_vec3 a = relief_mat4_transform(&p, (struct relief_vec3){ 0, 0, -100000 }, &w);
	float d = (float)(a.z / w), next = nextafterf(d, 1.0f);
	double D = 0.5 * 1e6 / (next * (1e6 - 0.5) + 0.5); /* inverse of the mapping */
	assert_true(fabs(D - 100000) < 5.0);
}

static void test_look_at_degenerate(void **state)
{
	struct relief_mat4 m;
	assert_false(relief_mat4_look_at((struct relief_vec3){ 1, 2, 3 }, (struct relief_vec3){ 1, 2, 3 },
	                                 (struct relief_vec3){ 0, 0, 1 }, &m));
	assert_false(relief_mat4_look_at((struct relief_vec3){ 0, 0, 5 }, (struct relief_vec3){ 0, 0, 0 },
	                                 (struct relief_vec3){ 0, 0, 1 }, &m));
	assert_false(relief_mat4_look_at((struct relief_vec3){ NAN, 0, 5 }, (struct relief_vec3){ 0, 0, 0 },
	                                 (struct relief_vec3){ 0, 0, 1 }, &m));
}

static void test_ortho(void **state)
{
	struct relief_mat4 o = relief_mat4_ortho(-2, 2, -1, 1, 5, 15);
	double w;
	struct relief_vec3 a = relief_mat4_transform(&o, (struct relief_vec3){ -2, 1, -5 }, &w);
	assert_true(fabs(a.x + 1) < 1e-12 && fabs(a.y + 1) < 1e-12 && fabs(a.z) < 1e-12 && w == 1.0);
	struct relief_vec3 b = relief_mat4_transform(&o, (struct relief_vec3){ 2, -1, -15 }, &w);
	assert_true(fabs(b.x - 1) < 1e-12 && fabs(b.y - 1) < 1e-12 && fabs(b.z - 1) < 1e-12);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_perspective_depth_range),
		cmocka_unit_test(test_reversed_depth),
		cmocka_unit_test(test_look_at_degenerate),
		cmocka_unit_test(test_ortho),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
