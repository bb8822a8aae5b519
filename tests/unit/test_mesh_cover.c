/* mesh_cover_add() on triangles whose place on the viewport is known: a ground triangle
 * filling the view (every pixel centre, and facing away when its corners are reversed),
 * millimetre triangles on a pixel centre and between four, triangles beside the frustum
 * and reaching behind the eye. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "mesh_cover.h"

/* Samples 1 mm apart, so that corners can be put within a pixel; origin (0, 0), rows run
 * south (row r is at y = -r mm). */
static struct relief_file file = { .hdr = { .origin_x = 0, .origin_y = 0, .spacing_x = 0.001, .spacing_y = 0.001 } };

/* From 100 m south of the world's origin and 100 m up, towards the origin: the ground
 * fills the view (its top row looks about 11 degrees below the horizon). */
static const struct relief_view view = { .eye = { 0, -100, 100 }, .target = { 0, 0, 0 }, .fovy = 1.2, .width = 100,
	                                 .height = 100, .znear = 1, .zfar = 1e5, .tau = 1 };

static struct relief_mesh_vertex vertex_at(double x, double y, float z)
{
	return (struct relief_mesh_vertex){ .col = llround(x / file.hdr.spacing_x), .row = llround(-y / file.hdr.spacing_y),
		                            .height = z };
}

/* Where the ray through pixel centre (x + 0.5, y + 0.5) meets the ground (z = 0). */
static struct relief_vec3 ground_at(double x, double y)
{
	/* two points on the ray (relief_view_unproject() takes the pixel's top-left index) */
	struct relief_vec3 a = relief_view_unproject(&view, (int)x, (int)y, 0.5);
	struct relief_vec3 b = relief_view_unproject(&view, (int)x, (int)y, 0.01);
	double t = a.z / (a.z - b.z);
	return (struct relief_vec3){ a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), 0 };
}

/* A front-facing triangle of 6 mm around ground point p (about 0.005 px here). */
static void tiny_around(struct relief_vec3 p, struct relief_mesh_vertex t[3])
{
	t[0] = vertex_at(p.x - 0.003, p.y - 0.003, 0);
	t[1] = vertex_at(p.x + 0.003, p.y - 0.003, 0);
	t[2] = vertex_at(p.x, p.y + 0.003, 0);
}

static struct mesh_cover cover(const struct relief_mesh_vertex *t, uint64_t n)
{
	struct mesh_cover c;
	memset(&c, 0, sizeof(c));
	mesh_cover_add(&file, &view, t, n, &c);
	return c;
}

/* The terrain's upper side, counter-clockwise seen from above, faces a camera above it. */
static void test_ground_fills_view(void **state)
{
	const struct relief_mesh_vertex up[3] = { vertex_at(-1e4, -90, 0), vertex_at(1e4, -90, 0), vertex_at(0, 1e4, 0) };
	struct mesh_cover c = cover(up, 1);
	assert_int_equal(c.kind[MESH_COVER_PIXELS], 1);
	assert_int_equal(c.centres, view.width * view.height);
	const struct relief_mesh_vertex down[3] = { up[0], up[2], up[1] };
	c = cover(down, 1);
	assert_int_equal(c.kind[MESH_COVER_BACK], 1);
	assert_int_equal(c.centres, 0);
}

/* A triangle of a few millimetres (under a hundredth of a pixel here) covers a pixel centre
 * it surrounds, and none when it lies between four. */
static void test_small_triangles(void **state)
{
	struct relief_vec3 q = ground_at(50, 50), r = ground_at(51, 51);
	struct relief_mesh_vertex t[3];
	tiny_around(q, t);
	struct mesh_cover c = cover(t, 1);
	assert_int_equal(c.kind[MESH_COVER_PIXELS], 1);
	assert_int_equal(c.centres, 1);
	tiny_around((struct relief_vec3){ 0.5 * (q.x + r.x), 0.5 * (q.y + r.y), 0 }, t); /* between four centres */
	c = cover(t, 1);
	assert_int_equal(c.kind[MESH_COVER_EMPTY], 1);
	assert_int_equal(c.centres, 0);
}

/* Beside the frustum (all corners beyond its east plane), and one corner behind the eye. */
static void test_outside_and_eye(void **state)
{
	const struct relief_mesh_vertex beside[6] = {
		vertex_at(5000, 0, 0), vertex_at(5010, 0, 0), vertex_at(5000, 10, 0), /* far east */
		vertex_at(0, 0, 0),    vertex_at(5, 0, 0),    vertex_at(0, -300, 0),  /* to behind the camera */
	};
	struct mesh_cover c = cover(beside, 2);
	assert_int_equal(c.kind[MESH_COVER_OUTSIDE], 1);
	assert_int_equal(c.kind[MESH_COVER_EYE], 1);
	assert_int_equal(c.centres, 0);
	uint64_t all = 0;
	for (int k = 0; k < MESH_COVER_KINDS; k++)
		all += c.kind[k];
	assert_int_equal(all, 2);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_ground_fills_view),
		cmocka_unit_test(test_small_triangles),
		cmocka_unit_test(test_outside_and_eye),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
