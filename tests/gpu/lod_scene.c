/* The LOD tests' scenes (lod_scene.h). */
#include <errno.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "decode.h"
#include "lod_scene.h"
#include "pack.h"
#include "pipeline.h"
#include "vk.h"

static enum relief_log_level lod_scene_level = RELIEF_LOG_WARN;
static struct relief_logger lod_scene_log = { relief_log_stderr, &lod_scene_level };

void scene_open_at(struct scene *s, struct relief_vk *vk, enum test_dem d, double tol, uint32_t w, uint32_t h,
                   double dx, double dy, uint32_t max_layers)
{
	struct relief_dem dem;
	test_dem_load(d, &dem);
	dem.origin_x += dx;
	dem.origin_y += dy;
	scene_open_dem(s, vk, &dem, tol, w, h, max_layers);
	relief_dem_finish(&dem);
}

void scene_open_dem(struct scene *s, struct relief_vk *vk, const struct relief_dem *dem, double tol, uint32_t w,
                    uint32_t h, uint32_t max_layers)
{
	scene_open_dem_patch(s, vk, dem, 129, tol, w, h, max_layers);
}

void scene_open_dem_patch(struct scene *s, struct relief_vk *vk, const struct relief_dem *dem, uint32_t patch,
                          double tol, uint32_t w, uint32_t h, uint32_t max_layers)
{
	*s = (struct scene){ .ctx = vk };
	struct relief_pack_options o = { .patch = patch, .ratio = 2, .tolerance = tol };
	assert_int_equal(relief_pack_memory(dem, &o, &s->img, &s->size, NULL), 0);
	char err[256];
	assert_int_equal(relief_file_open_memory(s->img, s->size, &s->f, err, sizeof(err)), 0);
	struct relief_patch_cache_options co = { .budget_bytes = 128ull << 20, .max_layers = max_layers };
	assert_int_equal(relief_patch_cache_create(vk, s->f, &co, &lod_scene_log, &s->cache), 0);
	assert_int_equal(relief_vk_target_init(vk, &s->target, w, h), 0);
	assert_int_equal(relief_terrain_create(vk, s->f, s->cache, &s->target, &s->terrain), 0);
	assert_int_equal(relief_terrain_view_create(s->terrain, &s->view), 0);
}

void scene_open(struct scene *s, struct relief_vk *vk, enum test_dem d, double tol, uint32_t w, uint32_t h)
{
	scene_open_at(s, vk, d, tol, w, h, 0, 0, 0);
}

void scene_close(struct scene *s)
{
	relief_terrain_view_destroy(s->view);
	relief_terrain_destroy(s->terrain);
	relief_vk_target_finish(s->ctx, &s->target);
	relief_patch_cache_destroy(s->cache);
	relief_file_close(s->f);
	free(s->img);
	free(s->layer_border);
	free(s->layer_owner);
}

/* relief_lod_borders.charges for a scene: its layer's charges (scene_residency()). */
static const float *scene_charges(void *data, uint32_t id)
{
	const struct scene *s = data;
	int layer = relief_patch_cache_layer(s->cache, id);
	return layer >= 0 && s->layer_owner[layer] == id ? s->layer_border + (size_t)layer * RELIEF_LOD_BORDER_FLOATS
	                                                 : NULL;
}

struct relief_lod_borders scene_residency(struct scene *s, uint8_t *resident)
{
	const uint32_t n = s->f->hdr.patch_count, P = s->f->hdr.patch_size;
	const uint32_t layers = relief_patch_cache_pool(s->cache)->layers;
	if (!s->layer_border) {
		s->layer_border = malloc(sizeof(float) * RELIEF_LOD_BORDER_FLOATS * layers);
		s->layer_owner = malloc(sizeof(uint32_t) * layers);
		assert_non_null(s->layer_border);
		assert_non_null(s->layer_owner);
		for (uint32_t k = 0; k < layers; k++)
			s->layer_owner[k] = UINT32_MAX;
	}
	const uint32_t blocks = (P - 1) / s->f->hdr.block_cells;
	float *rec = malloc(sizeof(float) * relief_patch_layer_floats(P));
	assert_non_null(rec);
	for (uint32_t id = 0; id < n; id++) {
		resident[id] = relief_patch_cache_state(s->cache, id) == RELIEF_PATCH_RESIDENT;
		int layer = relief_patch_cache_layer(s->cache, id);
		if (!resident[id] || layer < 0 || s->layer_owner[layer] == id)
			continue;
		assert_int_equal(relief_patch_cache_read_layer(s->cache, (uint32_t)layer, NULL, NULL, rec), 0);
		relief_lod_border_charges(rec, rec + relief_patch_block_floats(P), blocks,
		                          s->layer_border + (size_t)layer * RELIEF_LOD_BORDER_FLOATS);
		s->layer_owner[layer] = id;
	}
	free(rec);
	return (struct relief_lod_borders){ scene_charges, s };
}

void load_everything(struct scene *s)
{
	for (uint32_t l = 0; l < s->f->hdr.levels; l++) {
		for (uint32_t id = relief_level_first_id(l); id < relief_level_first_id(l + 1); id++)
			relief_patch_cache_request(s->cache, id, 0);
		assert_int_equal(relief_patch_cache_flush(s->cache, 1), 0);
	}
}

int cmp_u32(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return x < y ? -1 : x > y;
}

bool render_fits(struct scene *s, struct relief_view *v, const struct relief_draw_options *opts, float *depth,
                 struct relief_terrain_stats *st)
{
	for (uint64_t frame = 100 + s->frame_base; frame < 140 + s->frame_base; frame++) {
		const int ret = relief_patch_cache_flush(s->cache, frame);
		if (ret == -ENOSPC) { /* every layer holds a patch this view uses, and it wants more */
			struct relief_patch_cache_stats cs;
			relief_patch_cache_stats(s->cache, &cs);
			assert_int_equal(cs.free, 0);
			return false;
		}
		assert_int_equal(ret, 0);
		assert_int_equal(relief_terrain_draw(s->terrain, s->view, v, &s->target, frame, opts, st), 0);
		if (st->requests == 0)
			break;
	}
	assert_int_equal(st->requests, 0);
	/* Every quad drawn is in a draw record of one of the four list parts, each record
	 * holding 1 .. per_draw of them (the quads' count: pipeline statistics, 0 where the
	 * device has none). */
	if (st->quads > 0) {
		const uint64_t per_draw = relief_vk_quads_per_draw(RELIEF_BLOCK_CELLS);
		assert_true(st->draws >= 1 && st->draws <= st->quads);
		assert_true(st->quads <= st->draws * per_draw);
	}
	memcpy(depth, s->target.depth_readback.map, sizeof(float) * v->width * v->height);
	return true;
}

void render_with(struct scene *s, struct relief_view *v, const struct relief_draw_options *opts, float *depth,
                 struct relief_terrain_stats *st)
{
	assert_true(render_fits(s, v, opts, depth, st));
}

void render(struct scene *s, struct relief_view *v, float *depth, struct relief_terrain_stats *st)
{
	render_with(s, v, NULL, depth, st);
}

void assert_seamless(const struct relief_mesh_vertex *tri, uint64_t n)
{
	struct relief_mesh_seams m;
	assert_int_equal(relief_mesh_seams(tri, n, RELIEF_MESH_SEAM_TOL_M, &m), 0);
	print_message("  seams: %llu corners, %llu split, %llu T-junctions (%llu open), largest gap %.3g m at (%lld, %lld)\n",
	              (unsigned long long)m.positions, (unsigned long long)m.split, (unsigned long long)m.junctions,
	              (unsigned long long)m.open, m.max_gap_m, (long long)m.worst.col, (long long)m.worst.row);
	if (m.split)
		print_message("  first split position (%lld, %lld), patch %u draws it at %.4f m\n", (long long)m.split_at.col,
		              (long long)m.split_at.row, m.split_at.patch, m.split_at.height);
	assert_int_equal(m.split, 0);
	assert_int_equal(m.junctions, 0);
	assert_int_equal(m.open, 0);
}

enum { SEAMLESS_ROOM = 1u << 18 };

uint64_t render_seamless(struct scene *s, struct relief_view *v, const struct relief_draw_options *opts)
{
	struct relief_draw_options o = opts ? *opts : (struct relief_draw_options){ .fine = RELIEF_FINE_ERRORS };
	o.mesh = true;
	struct relief_terrain_stats st;
	float *depth = malloc(sizeof(float) * v->width * v->height);
	assert_non_null(depth);
	int64_t n = 0;
	for (int pass = 0; pass < 2; pass++) { /* again with room for every triangle if they did not fit */
		if (s->mesh_room < (pass ? (uint64_t)n : SEAMLESS_ROOM)) {
			s->mesh_room = pass ? (uint32_t)n : SEAMLESS_ROOM;
			assert_int_equal(relief_terrain_view_mesh_enable(s->view, s->mesh_room), 0);
		}
		render_with(s, v, &o, depth, &st);
		n = relief_terrain_view_mesh(s->view, NULL, NULL, 0);
		assert_true(n > 0);
		if (n <= (int64_t)s->mesh_room)
			break;
	}
	assert_true(n <= (int64_t)s->mesh_room);
	struct relief_mesh_vertex *tri = malloc(sizeof(*tri) * 3 * (size_t)n);
	assert_non_null(tri);
	assert_int_equal(relief_terrain_view_mesh(s->view, tri, NULL, (uint32_t)n), n);
	assert_seamless(tri, (uint64_t)n);
	free(tri);
	free(depth);
	return (uint64_t)n;
}

/* The vertical error, in pixels of v, of the point pixel (x, y) shows at reversed depth d
 * (> 0), against the finest level (drawn, valid: relief_surface_vertical_error()); *m, if
 * not NULL, receives it in metres. */
static double pixel_error(const struct scene *s, const struct relief_view *v, const float *drawn,
                          const uint8_t *valid, uint32_t fw, uint32_t fh, int x, int y, float d, double *m)
{
	const struct relief_vec3 p = relief_view_unproject(v, x, y, d);
	const double e = fabs(relief_surface_vertical_error(s->f, drawn, valid, fw, fh, 1, p, NULL));
	if (m)
		*m = e;
	return relief_view_segment_px(v, p, e);
}

/* Pixel (x, y) of a LOD render over tau, farther than the reference: whether it also shows
 * something farther (reversed depth: smaller) than all eight neighbours, each of which
 * shows terrain within tau (see struct comparison). */
static bool pinhole(const struct scene *s, const struct relief_view *v, const float *lod, const float *drawn,
                    const uint8_t *valid, uint32_t fw, uint32_t fh, int x, int y)
{
	const int W = (int)v->width, H = (int)v->height;
	const float d = lod[y * W + x];
	for (int dy = -1; dy <= 1; dy++)
		for (int dx = -1; dx <= 1; dx++) {
			const int xx = x + dx, yy = y + dy;
			if (dx == 0 && dy == 0)
				continue;
			if (xx < 0 || yy < 0 || xx >= W || yy >= H || !(lod[yy * W + xx] > d) ||
			    pixel_error(s, v, drawn, valid, fw, fh, xx, yy, lod[yy * W + xx], NULL) > v->tau)
				return false;
		}
	return true;
}

struct comparison compare(const struct scene *s, const struct relief_view *v, const float *ref,
                          const float *lod, const float *drawn, const uint8_t *valid, uint32_t fw, uint32_t fh)
{
	struct comparison c = { 0 };
	const int W = (int)v->width, H = (int)v->height, r = (int)ceil(v->tau) + 1;
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++) {
			bool interior = true;
			for (int dy = -r; dy <= r && interior; dy++)
				for (int dx = -r; dx <= r && interior; dx++) {
					int xx = x + dx, yy = y + dy;
					interior = xx >= 0 && yy >= 0 && xx < W && yy < H && ref[yy * W + xx] > 0.0f;
				}
			float d = lod[y * W + x];
			if (interior && d <= 0.0f)
				c.holes++;
			if (d > 0.0f && ref[y * W + x] > 0.0f) {
				if (pixel_error(s, v, drawn, valid, fw, fh, x, y, ref[y * W + x], NULL) > REF_OFF_PX) {
					c.off_surface++;
					c.both++;
					continue;
				}
				double e, px = pixel_error(s, v, drawn, valid, fw, fh, x, y, d, &e);
				if (px > v->tau && d < ref[y * W + x] && pinhole(s, v, lod, drawn, valid, fw, fh, x, y)) {
					c.pinholes++;
					c.both++;
					continue;
				}
				if (px > c.worst_px) {
					c.worst_px = px;
					c.worst_m = e;
				}
				c.both++;
			}
		}
	return c;
}

uint32_t view_drawn(struct relief_terrain_view *tv, uint32_t *ids, uint32_t cap)
{
	int n = relief_terrain_view_drawn(tv, ids, cap);
	assert_true(n >= 0);
	return (uint32_t)n;
}

uint32_t view_levels(const struct scene *s, struct relief_terrain_view *tv, uint32_t *ids, uint32_t *n,
                     uint32_t *counts)
{
	uint32_t levels = 0;
	*n = view_drawn(tv, ids, s->f->hdr.index_records); /* drawn patches have entries */
	for (uint32_t i = 0; i < *n; i++) {
		uint32_t l, px, py;
		assert_true(relief_patch_coords(&s->f->layout, ids[i], &l, &px, &py));
		levels |= 1u << l;
		if (counts)
			counts[l]++;
	}
	return levels;
}

uint32_t drawn_levels(const struct scene *s, uint32_t *ids, uint32_t *n)
{
	return view_levels(s, s->view, ids, n, NULL);
}

uint32_t gpu_matches_cpu(struct scene *s, const struct relief_view *v, const struct relief_terrain_stats *st)
{
	const uint32_t n = s->f->hdr.patch_count;
	uint8_t *resident = malloc(n), *prev = calloc(n, 1), *next = malloc(n), *draw = malloc(n);
	uint32_t *want = malloc(4 * n), *gpu = malloc(4 * n), *cpu = malloc(4 * n), n_want;
	const struct relief_lod_borders border = scene_residency(s, resident);
	uint32_t ng = view_drawn(s->view, gpu, n);
	uint32_t nc = relief_lod_select(s->f, v, resident, &border, prev, next, draw, want, n, &n_want);
	uint32_t k = 0;
	for (uint32_t id = 0; id < n; id++)
		if (draw[id])
			cpu[k++] = id;
	qsort(gpu, ng, 4, cmp_u32);
	print_message("  GPU %u patches, CPU %u; %u requests, CPU %u\n", ng, nc, st->requests, n_want);
	assert_int_equal(ng, nc);
	assert_memory_equal(gpu, cpu, 4 * nc);
	assert_int_equal(st->requests, n_want);
	assert_int_equal(st->patches, ng);
	free(resident); free(prev); free(next); free(draw); free(want); free(gpu); free(cpu);
	return ng;
}

uint32_t fresh_view_matches_cpu(struct scene *s, const struct relief_view *v, uint64_t frame,
                                const struct relief_draw_options *opts)
{
	relief_terrain_view_destroy(s->view);
	assert_int_equal(relief_terrain_view_create(s->terrain, &s->view), 0);
	s->mesh_room = 0; /* the new view has no capture */
	struct relief_terrain_stats st;
	assert_int_equal(relief_terrain_draw(s->terrain, s->view, v, &s->target, frame, opts, &st), 0);
	return gpu_matches_cpu(s, v, &st);
}

/* The largest level difference between two drawn patches that share a border: each drawn
 * patch painted, by level, onto a grid of finest-level cells, neighbours compared. */
uint32_t max_level_jump(const struct scene *s, const uint32_t *ids, uint32_t n)
{
	uint32_t side = 1u << (s->f->hdr.levels - 1), worst = 0;
	uint8_t *g = calloc((size_t)side * side, 1);
	for (uint32_t i = 0; i < n; i++) {
		uint32_t l, px, py;
		assert_true(relief_patch_coords(&s->f->layout, ids[i], &l, &px, &py));
		uint32_t k = side >> l;
		for (uint32_t y = py * k; y < (py + 1) * k; y++)
			memset(g + (size_t)y * side + px * k, (int)(l + 1), k);
	}
	for (uint32_t y = 0; y < side; y++)
		for (uint32_t x = 0; x < side; x++) {
			int a = g[(size_t)y * side + x];
			int e = x + 1 < side ? g[(size_t)y * side + x + 1] : 0, so = y + 1 < side ? g[(size_t)(y + 1) * side + x] : 0;
			if (a && e && (uint32_t)abs(a - e) > worst)
				worst = (uint32_t)abs(a - e);
			if (a && so && (uint32_t)abs(a - so) > worst)
				worst = (uint32_t)abs(a - so);
		}
	free(g);
	return worst;
}

/* The finest level and the two depth images of a bound scene whose scene is open. */
void bound_buffers(struct bound_scene *b)
{
	relief_level_extent(&b->s.f->hdr, b->s.f->hdr.levels - 1, &b->fw, &b->fh);
	const size_t n = (size_t)b->fw * b->fh;
	b->drawn = malloc(sizeof(float) * n);
	b->valid = malloc(n);
	assert_int_equal(relief_decode_level_drawn(b->s.f, b->s.f->hdr.levels - 1, 0, b->drawn, b->valid), 0);
	const size_t px = (size_t)b->s.target.width * b->s.target.height; /* BW x BH unless opened otherwise */
	b->ref = malloc(sizeof(float) * px);
	b->lod = malloc(sizeof(float) * px);
}

bool bound_sample_at(const struct bound_scene *b, double x, double y, long *c, long *r)
{
	const struct relief_header *h = &b->s.f->hdr;
	const long cc = lround((x - h->origin_x) / h->spacing_x), rr = lround((h->origin_y - y) / h->spacing_y);
	if (cc < 0 || rr < 0 || cc >= (long)b->fw || rr >= (long)b->fh || !b->valid[(size_t)rr * b->fw + (size_t)cc])
		return false;
	*c = cc;
	*r = rr;
	return true;
}

struct relief_dem grid_dem(int N)
{
	struct relief_dem dem = { .width = (uint32_t)N, .height = (uint32_t)N, .spacing_x = 30, .spacing_y = 30,
		                  .origin_y = 30.0 * (N - 1) };
	dem.heights = calloc((size_t)N * N, sizeof(float));
	dem.valid = malloc((size_t)N * N);
	memset(dem.valid, 1, (size_t)N * N);
	return dem;
}

uint32_t hash32(uint32_t x)
{
	x ^= x >> 16;
	x *= 0x7feb352du;
	x ^= x >> 15;
	x *= 0x846ca68bu;
	x ^= x >> 16;
	return x;
}

struct relief_dem coast_dem(int N, int band)
{
	struct relief_dem dem = grid_dem(N);
	for (int y = 0; y < N; y++)
		for (int x = N / 2 + 1; x < N; x++)
			dem.heights[(size_t)y * N + x] = (float)(5.0 * (x - N / 2) + (hash32((uint32_t)(y * N + x)) % 4000) * 0.05 *
			                                         fmin(1.0, fmax(0.0, (x - N / 2 - band) / 16.0)));
	return dem;
}

struct pose coast_sweep_pose(int N, uint32_t i)
{
	const double cx = 30.0 * (N / 2), len = 30.0 * (N - 1);
	uint32_t r = hash32(1000u + i);
	double ey = len * (0.05 + 0.9 * (r % 1000) / 1000.0), ez = 300 + (hash32(r) % 6000);
	double ex = cx + ((int)(hash32(r + 1) % 4000) - 1000);
	double ang = (hash32(r + 2) % 360) * M_PI / 180, d = 2000 + hash32(r + 3) % 8000;
	return (struct pose){ { ex, ey, ez }, { cx + cos(ang) * d * 0.3, ey + sin(ang) * d, 0 } };
}

struct pose steep_sweep_pose(int N, uint32_t i)
{
	const double cx = 30.0 * (N / 2), len = 30.0 * (N - 1);
	uint32_t r = hash32(5000u + i);
	double ey = len * (0.1 + 0.8 * (r % 1000) / 1000.0), ez = 800 + (hash32(r) % 4000);
	double ex = cx + ((int)(hash32(r + 1) % 2000) - 1000);
	double dx = (int)(hash32(r + 2) % 2000) - 1000, dy = (int)(hash32(r + 3) % 2000) - 1000;
	return (struct pose){ { ex, ey, ez }, { ex + dx, ey + dy, 0 } };
}

struct relief_dem cliffs_dem(void)
{
	enum { N = 513 };
	struct relief_dem dem = grid_dem(N);
	for (int i = 0; i < N * N; i++) {
		int x = i % N, y = i / N; /* y: rows from the north */
		dem.heights[i] = (float)(0.5 * x + 0.3 * y + (x >= 256 ? 1000.0 : 0.0) + (x + y >= 600 ? 300.0 : 0.0));
	}
	return dem;
}

#define CLIFF_X (30.0 * 256) /* the north-south cliff's x; world y runs north */
const struct pose cliffs_poses[CLIFFS_POSES] = {
	{ { CLIFF_X - 3000, 5000, 600 }, { CLIFF_X, 7000, 500 } },      /* at the face from the low side */
	{ { CLIFF_X - 200, 1000, 700 }, { CLIFF_X - 100, 14000, 600 } }, /* along its foot (130 m above the ground) */
	{ { CLIFF_X + 200, 1000, 1600 }, { CLIFF_X + 100, 14000, 1300 } }, /* along its top */
	{ { CLIFF_X, 7680, 6000 }, { CLIFF_X + 10, 7690, 0 } },          /* straight down on it */
	{ { 12000, 14000, 2500 }, { 9000, 9000, 1200 } },                /* at the diagonal step */
};

/* Puget Sound spans x, y in [0, 163840] m; Mt Rainier's summit is at (128480, 79200). */
const struct pose puget_bound_poses[PUGET_BOUND_POSES] = {
	{ { 100000, 50000, 5500 }, { 128480, 79200, 3000 } },
	{ { 5000, 5000, 400 }, { 160000, 150000, 100 } },      /* grazing */
	{ { 81920, 81920, 9000 }, { 81925, 81930, 0 } },       /* above a patch corner */
	{ { 126000, 77000, 4200 }, { 128480, 79200, 4000 } },  /* near the summit cliffs */
};
/* Mont Blanc: x in [0, 59884] m, y in [0, 59884] m, heights 454-4810 m. */
const struct pose alps_bound_poses[ALPS_BOUND_POSES] = {
	{ { 8000, 30000, 1200 }, { 50000, 32000, 1500 } },     /* grazing along a valley floor */
	{ { 30000, 30000, 9000 }, { 30100, 30200, 3000 } },    /* steep look down onto the massif */
	{ { 23731, 23731, 5600 }, { 40000, 40000, 2500 } },    /* eye above a patch corner */
};

void bound_open(struct bound_scene *b, struct relief_vk *vk, enum test_dem dem)
{
	scene_open(&b->s, vk, dem, 1.0, BW, BH);
	bound_buffers(b);
}

void bound_open_dem(struct bound_scene *b, struct relief_vk *vk, const struct relief_dem *dem)
{
	bound_open_dem_patch(b, vk, dem, 129);
}

void bound_open_dem_patch(struct bound_scene *b, struct relief_vk *vk, const struct relief_dem *dem, uint32_t patch)
{
	scene_open_dem_patch(&b->s, vk, dem, patch, 1.0, BW, BH, 0);
	bound_buffers(b);
}

void bound_open_coast(struct bound_scene *b, struct relief_vk *vk, int N)
{
	struct relief_dem dem = coast_dem(N, COAST_BAND);
	bound_open_dem_patch(b, vk, &dem, 65);
	relief_dem_finish(&dem);
}

void bound_close(struct bound_scene *b)
{
	free(b->drawn);
	free(b->valid);
	free(b->ref);
	free(b->lod);
	struct relief_vk *vk = b->s.ctx;
	scene_close(&b->s);
	assert_int_equal(atomic_load(&vk->validation_messages), 0);
}

struct relief_view pose_view(const struct pose *p)
{
	return (struct relief_view){
		.eye = { p->eye[0], p->eye[1], p->eye[2] },
		.target = { p->at[0], p->at[1], p->at[2] },
		.fovy = 50 * M_PI / 180, .width = BW, .height = BH, .znear = 5, .zfar = 4e5, .tau = 0.001,
	};
}

void within_tau_of_reference(struct scene *s, struct relief_view *v, const double *taus, size_t n,
                             const char *what, uint32_t min_pixels)
{
	const uint32_t W = v->width, H = v->height;
	uint32_t fw, fh;
	relief_level_extent(&s->f->hdr, s->f->hdr.levels - 1, &fw, &fh);
	float *drawn = malloc(sizeof(float) * fw * fh), *ref = malloc(sizeof(float) * W * H);
	float *lod = malloc(sizeof(float) * W * H);
	uint8_t *valid = malloc((size_t)fw * fh);
	assert_int_equal(relief_decode_level_drawn(s->f, s->f->hdr.levels - 1, 0, drawn, valid), 0);
	struct relief_terrain_stats st;
	v->tau = 0.001;
	render(s, v, ref, &st);
	for (size_t k = 0; k < n; k++) {
		v->tau = taus[k];
		render(s, v, lod, &st);
		struct comparison c = compare(s, v, ref, lod, drawn, valid, fw, fh);
		print_message("%s, tau %g: %u patches, %llu triangles, %u holes, max vertical error %.3f px (%.1f m) over "
		              "%u pixels, %u pinholes, %u off the surface in the reference\n", what, v->tau, st.patches,
		              (unsigned long long)st.triangles, c.holes, c.worst_px, c.worst_m, c.both, c.pinholes,
		              c.off_surface);
		assert_int_equal(c.holes, 0);
		assert_true(c.pinholes <= 1);
		assert_true(c.both > min_pixels);
		assert_true(c.worst_px <= v->tau);
	}
	free(drawn);
	free(valid);
	free(ref);
	free(lod);
}

void benchmark_frame_within_tau(struct relief_vk *vk, enum test_dem dem, struct relief_view *v, double tau,
                                const char *what)
{
	struct scene s;
	scene_open(&s, vk, dem, 1.0, v->width, v->height);
	within_tau_of_reference(&s, v, &tau, 1, what, v->width * v->height / 4);
	scene_close(&s);
}
