/* relief_box_allowed_error(), the fine LOD's room over a box (docs/lod.md, "The room over a
 * box"; the shaders' allowed_box(), whose reference it is): a vertical segment of that
 * length, up or down, from any point of the box projects to at most tau pixels. Checked at
 * random points of random boxes seen by random cameras (low and high, level, looking down
 * and up, wide and narrow), corners and edges included; exact for a box that is a point;
 * exact to 0.1 % for a box straight ahead of a level camera, where bounding K and w apart
 * would be twenty times too strict. The negative control is built in: the least room at
 * nine points of each box (its corners, edge middles and centre, at both heights), the kind
 * of measure the factor pass took until the forty-ninth December 2026 session, breaks tau
 * at some points of some of the same boxes (5 of 2,208, up to 1.08 tau), so the check tells
 * a bound from a sample. The GPU's twin is held to the same bound by the mesh tests
 * (test_lod_mesh, test_lod_sweep: every triangle within tau). */
#include <math.h>
#include <stdbool.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "lod.h"

static uint64_t rng = 0x9e3779b97f4a7c15ull;

/* Uniform in [0, 1) (xorshift64*). */
static double uniform(void)
{
	rng ^= rng >> 12;
	rng ^= rng << 25;
	rng ^= rng >> 27;
	return (double)((rng * 0x2545f4914f6cdd1dull) >> 11) / 9007199254740992.0;
}

static double between(double lo, double hi) { return lo + (hi - lo) * uniform(); }

/* A random camera at the origin: eye 0.5 m to 10 km above a target up to 30 km away (so
 * from level to straight down), sometimes looking up. */
static struct relief_view random_view(void)
{
	double height = exp(between(log(0.5), log(10000.0))), reach = exp(between(log(10.0), log(30000.0)));
	double heading = between(0, 2 * M_PI), drop = uniform() < 0.15 ? -between(0, 3000) : between(0, height + 3000);
	struct relief_view v = {
		.eye = { 0, 0, height },
		.target = { reach * cos(heading), reach * sin(heading), height - drop },
		.roll = uniform() < 0.2 ? between(-0.5, 0.5) : 0.0,
		.fovy = between(15, 120) * M_PI / 180,
		.width = (uint32_t)between(200, 2000),
		.height = (uint32_t)between(150, 1200),
		.znear = 0.5,
		.zfar = 1e6,
		.tau = exp(between(log(0.25), log(16.0))),
	};
	return v;
}

/* The point at (u, v, s) of the box: bilinear over c[] (a rectangle, so inside it), s of
 * the way up dh. */
static struct relief_vec3 box_point(const struct relief_vec3 c[4], double dh, double u, double v, double s)
{
	struct relief_vec3 p;
	p.x = (1 - v) * ((1 - u) * c[0].x + u * c[1].x) + v * ((1 - u) * c[2].x + u * c[3].x);
	p.y = (1 - v) * ((1 - u) * c[0].y + u * c[1].y) + v * ((1 - u) * c[2].y + u * c[3].y);
	p.z = (1 - v) * ((1 - u) * c[0].z + u * c[1].z) + v * ((1 - u) * c[2].z + u * c[3].z) + s * dh;
	return p;
}

/* The largest image, in tau, of a segment of length e up or down from `samples` points of
 * the box (its 8 corners and 4 edge middles first). */
static double worst_ratio(const struct relief_mat4 *vp, const struct relief_view *v, const struct relief_vec3 c[4],
                          double dh, double e, int samples)
{
	static const double fixed[12][3] = { { 0, 0, 0 },   { 1, 0, 0 },   { 0, 1, 0 }, { 1, 1, 0 }, { 0, 0, 1 },
		                             { 1, 0, 1 },   { 0, 1, 1 },   { 1, 1, 1 }, { 0.5, 0, 0 }, { 0, 0.5, 1 },
		                             { 1, 0.5, 0 }, { 0.5, 1, 1 } };
	double worst = 0;
	for (int k = 0; k < samples; k++) {
		double u, w, s;
		if (k < 12) {
			u = fixed[k][0], w = fixed[k][1], s = fixed[k][2];
		} else {
			u = uniform(), w = uniform(), s = uniform();
			if (k % 4 == 0) /* on a face */
				u = uniform() < 0.5 ? 0 : 1;
		}
		struct relief_vec3 p = box_point(c, dh, u, w, s);
		for (int dir = -1; dir <= 1; dir += 2)
			worst = fmax(worst, relief_segment_px(vp, v->width, v->height, p, dir * e) / v->tau);
	}
	return worst;
}

static void test_box_bound_random(void **state)
{
	(void)state;
	int boxes = 0, tight = 0, sampled_broken = 0;
	double worst = 0, sampled_worst = 0;
	for (int n = 0; n < 4000; n++) {
		struct relief_view v = random_view();
		struct relief_mat4 vp = relief_view_projection(&v, v.eye);
		/* An axis-aligned rectangle 1 m to 20 km a side (or a segment), up to 2 km deep:
		 * half of them within 3 km of the eye and below it, the rest within 30 km, -3 km to
		 * +1 km from the eye's height. */
		bool near = n % 2;
		double side_x = exp(between(0, log(20000.0))), side_y = uniform() < 0.3 ? 0 : side_x * between(0.05, 1);
		double reach = near ? 3000 : 30000, x0 = between(-reach, reach), y0 = between(-reach, reach);
		double z0 = near ? between(-300, 10) - v.eye.z : between(-3000, 1000) - v.eye.z;
		double dh = uniform() < 0.2 ? 0 : exp(between(0, log(2000.0)));
		struct relief_vec3 c[4] = {
			{ x0, y0, z0 }, { x0 + side_x, y0, z0 }, { x0, y0 + side_y, z0 }, { x0 + side_x, y0 + side_y, z0 }
		};
		double e = relief_box_allowed_error(&vp, v.width, v.height, v.tau, c, dh);
		assert_false(isnan(e));
		assert_true(e >= 0);
		/* Below a micrometre (a box reaching within millimetres of the camera's plane) the
		 * segment's image is the difference of two nearly equal projections, which double
		 * rounding moves by more than 1e-6 of it. */
		if (e < 1e-6 || isinf(e))
			continue;
		boxes++;
		double r = worst_ratio(&vp, &v, c, dh, e, 400);
		worst = fmax(worst, r);
		tight += r > 0.9;
		/* What nine measuring points would allow: each point's own room, the least. */
		double e9 = INFINITY;
		for (int k = 0; k < 18; k++) {
			struct relief_vec3 p = box_point(c, dh, (k % 3) * 0.5, (k / 3 % 3) * 0.5, k / 9);
			struct relief_vec3 pt[4] = { p, p, p, p };
			e9 = fmin(e9, relief_box_allowed_error(&vp, v.width, v.height, v.tau, pt, 0));
		}
		if (e9 >= 1e-6 && !isinf(e9)) {
			double r9 = worst_ratio(&vp, &v, c, dh, e9, 400);
			sampled_worst = fmax(sampled_worst, r9);
			sampled_broken += r9 > 1 + 1e-6;
		}
	}
	print_message("%d boxes with room: the bound's largest image %.9f tau, %d of them above 0.9 tau; nine points: "
	              "%d boxes over tau, up to %.9f tau\n",
	              boxes, worst, tight, sampled_broken, sampled_worst);
	assert_true(boxes > 1000);
	assert_true(worst <= 1 + 1e-6);
	assert_true(tight > boxes / 10); /* a bound, not a refusal */
	assert_true(sampled_broken > 0);  /* the negative control */
}

/* A box that is a point: the room is exact in the direction that shortens w. */
static void test_box_bound_point(void **state)
{
	(void)state;
	for (int n = 0; n < 2000; n++) {
		struct relief_view v = random_view();
		struct relief_mat4 vp = relief_view_projection(&v, v.eye);
		struct relief_vec3 p = { between(-20000, 20000), between(-20000, 20000), between(-3000, 500) - v.eye.z };
		struct relief_vec3 c[4] = { p, p, p, p };
		double e = relief_box_allowed_error(&vp, v.width, v.height, v.tau, c, 0);
		if (e < 1e-6 || isinf(e))
			continue;
		double up = relief_segment_px(&vp, v.width, v.height, p, e), down = relief_segment_px(&vp, v.width, v.height, p, -e);
		assert_true(fmax(up, down) <= v.tau * (1 + 1e-6));
		assert_true(fmax(up, down) >= v.tau * (1 - 1e-6));
	}
}

/* A level camera and a box straight ahead, 100 m to 2 km away: K grows as w there, so K /
 * w^2 is largest at the nearest corners, which the bound finds (within 0.1 %); K's
 * largest corner over w's least would allow a twentieth of that. */
static void test_box_bound_level(void **state)
{
	(void)state;
	struct relief_view v = {
		.eye = { 0, 0, 2 }, .target = { 0, 1000, 2 }, .fovy = 60 * M_PI / 180, .width = 1280, .height = 720,
		.znear = 0.5, .zfar = 1e6, .tau = 1,
	};
	struct relief_mat4 vp = relief_view_projection(&v, v.eye);
	struct relief_vec3 c[4] = { { -100, 100, -2 }, { 100, 100, -2 }, { -100, 2000, -2 }, { 100, 2000, -2 } };
	double e = relief_box_allowed_error(&vp, v.width, v.height, v.tau, c, 0);
	double r = worst_ratio(&vp, &v, c, 0, e, 2000);
	print_message("level camera: room %.4f m, largest image %.6f tau\n", e, r);
	assert_true(r <= 1 + 1e-6 && r >= 0.999);
	double near = relief_box_allowed_error(&vp, v.width, v.height, v.tau, (const struct relief_vec3[4]){ c[0], c[0], c[0], c[0] }, 0);
	assert_true(fabs(e - near) <= 1e-3 * near);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_box_bound_random),
		cmocka_unit_test(test_box_bound_point),
		cmocka_unit_test(test_box_bound_level),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
