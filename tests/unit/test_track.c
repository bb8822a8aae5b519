/* Flight tracks (tools/track.c): parsing with named errors, interpolation, the views made
 * from keys and the side channels of a multi-channel image generator. */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "../test_util.h"
#include "track.h"

static int parse(const char *text, struct track *t, char *err)
{
	return track_parse(text, strlen(text), t, err, 256);
}

static void test_parse_good(void **state)
{
	struct track t;
	char err[256];
	const char *text = "# t x y z heading pitch roll\n"
	                   "0 100 200 300 45 -10 0\n"
	                   "\n"
	                   "  1.5,100.5,200,300,50,-12,5   # comma separated, trailing comment\r\n"
	                   "3\t101\t201\t301\t55\t-90\t-5";
	assert_int_equal(parse(text, &t, err), 0);
	assert_int_equal(t.n, 3);
	assert_true(t.keys[1].t == 1.5 && t.keys[1].x == 100.5 && t.keys[1].roll == 5);
	assert_true(t.keys[2].pitch == -90 && t.keys[2].roll == -5);
	track_finish(&t);
	track_finish(&t); /* finishing twice is harmless */
	track_finish(NULL);
}

static void expect_error(const char *text, const char *needle)
{
	struct track t = { 0 };
	char err[256] = "";
	assert_int_equal(parse(text, &t, err), -EINVAL);
	if (!strstr(err, needle))
		fail_msg("'%s' does not name '%s'", err, needle);
	assert_null(t.keys);
}

static void test_parse_errors(void **state)
{
	expect_error("", "no keys");
	expect_error("# only a comment\n\n", "no keys");
	expect_error("0 1 2 3 4 5\n", "line 1: 6 numbers, expected 7");
	expect_error("0 1 2 3 4 5 6 7\n", "line 1: more than 7");
	/* An empty comma-separated field is an error, not a field dropped: this line once
	 * read as the key 0 1 2 3 4 5 6. */
	expect_error("0 1 2 3 4 5 6\n1,1,, 2,3,4,5,6\n", "line 2: field 3 is empty (two commas");
	expect_error(",0,1,2,3,4,5,6\n", "line 1: field 1 is empty");
	expect_error("0,1,2,3,4,5,6,\n", "line 1: field 8 is empty (a comma after the last number)");
	expect_error("0,1,2,3,4,5,6 , # comment\n", "line 1: field 8 is empty");
	expect_error("0 1 2 3 4 5 6\n1 1 2 x 4 5 6\n", "line 2: z: 'x' is not a number");
	expect_error("0 1 2 3 4 5 6\n0 1 2 3 4 5 6\n", "line 2: time 0 does not increase");
	expect_error("0 1 2 3 4 5 6\n# c\n-1 1 2 3 4 5 6\n", "line 3: time -1 does not increase");
	expect_error("0 1 2 3 4 95 6\n", "line 1: pitch 95 is outside");
	expect_error("0 1 2 3 4 5 inf\n", "roll: 'inf' is not a finite number");
	expect_error("0 1 2 3 4 5 nan\n", "roll: 'nan' is not a finite number");
	expect_error("0 1 2 1e999 4 5 6\n", "z: '1e999' is not a finite number");
	expect_error("0 1 2 3 4 5 6\n1 1 -2e11 3 4 5 6\n", "line 2: y -2e+11 m is beyond 1e+11 m");
	expect_error("0 1 2 3 4 5 6\n1 1 2 3 4 5 0x\n", "line 2: roll: '0x' is not a number");
	expect_error("0 1 2 3 4 5 000000000000000000000000000000000000000000000000000000000000000001\n",
	             "line 1: roll: a number of 66 characters");
	const char with_nul[] = "0 1 2 3 4 5 6\n1 1 2 3\0 4 5 6\n";
	struct track t = { 0 };
	char err[256];
	assert_int_equal(track_parse(with_nul, sizeof(with_nul) - 1, &t, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "line 2: a NUL byte"));
	assert_int_equal(track_load("/nonexistent/track", &t, err, sizeof(err)), -ENOENT);
	assert_non_null(strstr(err, "cannot open"));
}

static void test_interpolation(void **state)
{
	struct track t;
	char err[256];
	assert_int_equal(parse("10 0 0 100 350 -10 170\n12 200 -40 300 10 10 -170\n", &t, err), 0);
	struct track_key k;
	track_at(&t, 11, &k);
	assert_true(fabs(k.x - 100) < 1e-12 && fabs(k.y + 20) < 1e-12 && fabs(k.z - 200) < 1e-12);
	assert_true(fabs(fmod(k.heading + 360.0, 360.0)) < 1e-9); /* 350 -> 10 through north, not south */
	assert_true(fabs(k.pitch) < 1e-12);
	assert_true(fabs(fabs(k.roll) - 180.0) < 1e-9);           /* 170 -> -170 through 180 */
	track_at(&t, -5, &k); /* clamped to the ends */
	assert_true(k.t == 10 && k.x == 0 && k.heading == 350);
	track_at(&t, 99, &k);
	assert_true(k.t == 12 && k.x == 200);
	track_finish(&t);
}

static double dot(struct relief_vec3 a, struct relief_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

static void test_key_views(void **state)
{
	struct relief_view v = { 0 };
	struct relief_vec3 f, r, u;
	/* Heading 90 (east), level, wings level: looking along +x, up is up. */
	struct track_key k = { 0, 500000, 5000000, 1000, 90, 0, 0 };
	track_key_view(&k, &v);
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_true(f.x > 1 - 1e-12 && fabs(u.z - 1) < 1e-12 && v.roll == 0);
	/* Straight down heading east: the nose (east) at the top of the picture. */
	k.pitch = -90;
	track_key_view(&k, &v);
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_true(f.z < -1 + 1e-9 && u.x > 1 - 1e-6 && r.y < -1 + 1e-6);
	/* Straight up heading north: the top of the picture points back, south. */
	k.heading = 0;
	k.pitch = 90;
	track_key_view(&k, &v);
	assert_true(relief_view_axes(&v, &f, &r, &u));
	assert_true(f.z > 1 - 1e-9 && u.y < -1 + 1e-6);
}

static void test_channels(void **state)
{
	struct relief_view centre = { .fovy = 1, .width = 16, .height = 9, .znear = 1, .zfar = 1e5, .tau = 1 };
	struct track_key k = { 0, 1000, 2000, 500, 30, -5, 0 };
	track_key_view(&k, &centre);
	struct relief_view side;
	track_channel_view(&centre, 0.0, &side);
	assert_memory_equal(&side, &centre, sizeof(side));
	/* Level flight, nose on the horizon: a side channel is the heading turned, with no roll.
	 * (Pitched, the channels turn about the tilted up axis and so roll a little.) */
	k.pitch = 0;
	track_key_view(&k, &centre);
	track_channel_view(&centre, 40 * M_PI / 180, &side);
	struct relief_vec3 f, r, u, fc, rc, uc;
	assert_true(relief_view_axes(&centre, &f, &r, &u) && relief_view_axes(&side, &fc, &rc, &uc));
	assert_true(fabs(side.roll) < 1e-9);
	assert_true(fabs(atan2(fc.x, fc.y) * 180 / M_PI - 70) < 1e-6);
	assert_true(fabs(fc.z) < 1e-9 && fabs(f.z) < 1e-9);
	/* Banked 30 degrees right: each channel keeps the aircraft's up, and turns about it. */
	for (int s = -1; s <= 1; s += 2) {
		k.roll = 30;
		k.pitch = -5;
		track_key_view(&k, &centre);
		track_channel_view(&centre, s * 50 * M_PI / 180, &side);
		assert_true(relief_view_axes(&centre, &f, &r, &u) && relief_view_axes(&side, &fc, &rc, &uc));
		assert_true(fabs(dot(uc, u) - 1) < 1e-9);
		assert_true(fabs(dot(fc, f) - cos(50 * M_PI / 180)) < 1e-9);
		assert_true(s * dot(fc, r) > 0); /* to the aircraft's right for s = 1 */
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_parse_good),
		cmocka_unit_test(test_parse_errors),
		cmocka_unit_test(test_interpolation),
		cmocka_unit_test(test_key_views),
		cmocka_unit_test(test_channels),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
