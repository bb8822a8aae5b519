/* The codec's promises, checked exhaustively on the bundled real DEMs at 0.1, 0.5, 1 and
 * 4 m: every valid sample of every level within delta_l of the original; neighbouring
 * patches agree bit for bit on shared samples; Err(P) bounds the patch against the
 * original and the block errors bound each simplified block against the finest decoded
 * surface (checked with an independent evaluator of the triangulated surfaces);
 * packing is deterministic across thread counts; no-data stays no-data, and the no-data
 * samples beside the data decode within the terrain around them; quantising each
 * level over a window around the data changes no byte. */
#include <errno.h>
#include <math.h>

#include "../data_load.h"
#include "decode.h"
#include "fill.h"
#include "format.h"
#include "lod.h"
#include "pack.h"
#include "patch_error.h"

static uint32_t rng_state = 777;
static double rnd(void)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 17;
	rng_state ^= rng_state << 5;
	return (rng_state & 0xffffff) / (double)0x1000000;
}

/* Piecewise-linear value at (u, v) in a cell with corners z00, z10, z01, z11, found by
 * barycentric coordinates in whichever triangle contains the point (diag 0: 00-11). */
static double tri_eval(const double tri[3][3], double u, double v, bool *inside)
{
	double x1 = tri[1][0] - tri[0][0], y1 = tri[1][1] - tri[0][1];
	double x2 = tri[2][0] - tri[0][0], y2 = tri[2][1] - tri[0][1];
	double det = x1 * y2 - x2 * y1;
	double a = ((u - tri[0][0]) * y2 - x2 * (v - tri[0][1])) / det;
	double b = (x1 * (v - tri[0][1]) - (u - tri[0][0]) * y1) / det;
	*inside = a >= -1e-12 && b >= -1e-12 && a + b <= 1 + 1e-12;
	return tri[0][2] + a * (tri[1][2] - tri[0][2]) + b * (tri[2][2] - tri[0][2]);
}

static double surface(double z00, double z10, double z01, double z11, double u, double v, int diag)
{
	double c00[3] = { 0, 0, z00 }, c10[3] = { 1, 0, z10 }, c01[3] = { 0, 1, z01 }, c11[3] = { 1, 1, z11 };
	double t[2][3][3];
	const double *(*pick)[3] = NULL;
	(void)pick;
	const double *list[2][3];
	if (diag == 0) {
		const double *a[3] = { c00, c10, c11 }, *b[3] = { c00, c11, c01 };
		memcpy(list[0], a, sizeof(a));
		memcpy(list[1], b, sizeof(b));
	} else {
		const double *a[3] = { c00, c10, c01 }, *b[3] = { c10, c11, c01 };
		memcpy(list[0], a, sizeof(a));
		memcpy(list[1], b, sizeof(b));
	}
	for (int k = 0; k < 2; k++)
		for (int i = 0; i < 3; i++)
			memcpy(t[k][i], list[k][i], sizeof(double) * 3);
	bool in;
	double r = tri_eval(t[0], u, v, &in);
	if (in)
		return r;
	r = tri_eval(t[1], u, v, &in);
	assert_true(in);
	return r;
}

struct packed {
	struct relief_dem dem;
	uint8_t *img;
	size_t size;
	struct relief_file *f;
};

static void pack(struct packed *p, const char *name, double tol, uint32_t ratio, uint32_t patch, unsigned threads)
{
	struct relief_pack_options o = { .patch = patch, .ratio = ratio, .tolerance = tol, .threads = threads };
	struct relief_pack_stats st;
	assert_int_equal(relief_pack_memory(&p->dem, &o, &p->img, &p->size, &st), 0);
	char err[256];
	if (relief_file_open_memory(p->img, p->size, &p->f, err, sizeof(err)) < 0)
		fail_msg("%s at %g m: %s", name, tol, err);
}

static void unpack(struct packed *p)
{
	relief_file_close(p->f);
	free(p->img);
	p->f = NULL;
	p->img = NULL;
}

/* Walks the tree like the GPU decoder will: each child from its parent patch's own block. */
static int32_t **decode_tree(const struct relief_file *f)
{
	const struct relief_layout *lay = &f->layout;
	const size_t EE = (size_t)lay->geom.E * lay->geom.E;
	int32_t **blocks = calloc(lay->levels, sizeof(*blocks));
	struct relief_decoder dec;
	assert_int_equal(relief_decoder_init(&dec, f), 0);
	for (uint32_t l = 0; l < lay->levels; l++) {
		uint32_t side = 1u << l;
		blocks[l] = malloc(sizeof(int32_t) * EE * side * side);
		for (uint32_t py = 0; py < side; py++)
			for (uint32_t px = 0; px < side; px++) {
				const int32_t *parent = l ? blocks[l - 1] + ((py / 2) * (side / 2) + px / 2) * EE : NULL;
				assert_int_equal(relief_decoder_patch(&dec, relief_patch_id(l, px, py), parent,
				                                      blocks[l] + ((size_t)py * side + px) * EE), 0);
			}
	}
	relief_decoder_finish(&dec);
	return blocks;
}

/* The finest decoded surface at finest-grid point (x, y) under each diagonal choice of its
 * finest cell (value[0], value[1]). False where no corner of that cell is valid: nothing
 * is drawn there. */
static bool finest_at(const struct relief_file *f, int32_t *const *blocks, const struct relief_dem *dem, double x,
                      double y, double *value)
{
	const struct relief_layout *lay = &f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E, L = lay->levels - 1, side = 1u << L;
	uint32_t X = (uint32_t)x, Y = (uint32_t)y;
	X = X >= lay->size - 1 ? lay->size - 2 : X;
	Y = Y >= lay->size - 1 ? lay->size - 2 : Y;
	bool any = false;
	for (uint32_t k = 0; k < 4; k++) {
		uint32_t cx = X + (k & 1), cy = Y + (k >> 1);
		any |= cx < dem->width && cy < dem->height && dem->valid[(size_t)cy * dem->width + cx];
	}
	if (!any)
		return false;
	uint32_t fx = X / (P - 1), fy = Y / (P - 1);
	const int32_t *b = blocks[L] + ((size_t)fy * side + fx) * E * E;
	const int32_t *c = b + (Y - fy * (P - 1) + 1) * E + (X - fx * (P - 1)) + 1;
	const double q2 = 2 * lay->delta[L];
	value[0] = surface(q2 * c[0], q2 * c[1], q2 * c[E], q2 * c[E + 1], x - X, y - Y, 0);
	value[1] = surface(q2 * c[0], q2 * c[1], q2 * c[E], q2 * c[E + 1], x - X, y - Y, 1);
	return true;
}

/* The drawn error E0(P) of patch (l, px, py) (decoded block b, record r) against an
 * evaluation of its own: at the corners and centre of every finest cell with a valid
 * corner in its footprint, the patch's surface (either diagonal) against the finest
 * decoded surface (either diagonal). Those points hold every vertex of the two surfaces'
 * overlay, where their difference peaks, so the stored value must be reached, not only
 * bound it. Above the finest level, where the footprint's original samples are all valid,
 * it must also be within relief_draw_error_bound() of Err(P) (what older files read).
 * Returns the largest E0 / Err(P) seen above the finest level. */
static double check_drawn_error(const struct relief_file *f, int32_t *const *blocks, const struct relief_dem *dem,
                                uint32_t l, uint32_t px, uint32_t py, const int32_t *b,
                                const struct relief_patch_record *r)
{
	const struct relief_layout *lay = &f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E, step = 1u << (lay->levels - 1 - l);
	const double q2 = 2 * lay->delta[l], far = 1.0 - 1e-9;
	const uint64_t X0 = (uint64_t)px * (P - 1) * step, Y0 = (uint64_t)py * (P - 1) * step, span = (uint64_t)(P - 1) * step;
	double found = 0;
	bool all_valid = true;
	for (uint64_t Y = Y0; Y < Y0 + span && Y < dem->height; Y++)
		for (uint64_t X = X0; X < X0 + span && X < dem->width; X++) {
			for (int k = 0; k < 4; k++) {
				uint64_t cx = X + (k & 1), cy = Y + (k >> 1);
				all_valid &= cx < dem->width && cy < dem->height && dem->valid[cy * dem->width + cx];
			}
			for (int k = 0; k < 5; k++) { /* the four corners, then the centre */
				const double du = k == 4 ? 0.5 : (k & 1) ? far : 0.0, dv = k == 4 ? 0.5 : (k & 2) ? far : 0.0;
				double fin[2];
				if (!finest_at(f, blocks, dem, (double)X + du, (double)Y + dv, fin))
					break; /* the cell has no valid corner: nothing is drawn in it */
				const double gx = ((double)(X - X0) + du) / step, gy = ((double)(Y - Y0) + dv) / step;
				const uint32_t cx = (uint32_t)gx, cy = (uint32_t)gy;
				const int32_t *c = b + (cy + 1) * E + cx + 1;
				for (int dc = 0; dc < 2; dc++) {
					double v = surface(q2 * c[0], q2 * c[1], q2 * c[E], q2 * c[E + 1], gx - cx, gy - cy, dc);
					found = fmax(found, fmax(fabs(v - fin[0]), fabs(v - fin[1])));
				}
			}
		}
	if (found > r->draw_error * (1 + 1e-6) + 1e-6 || found < r->draw_error * (1 - 1e-6) - 1e-6)
		fail_msg("level %u patch %u,%u: drawn error %.9g stored, %.9g measured", l, px, py, r->draw_error, found);
	if (l + 1 == lay->levels)
		return 0;
	const double bound = relief_draw_error_bound(r->error, step, lay->delta[lay->levels - 1]);
	if (all_valid && r->draw_error > bound * (1 + 1e-6))
		fail_msg("level %u patch %u,%u: drawn error %.9g above the bound %.9g from Err(P) %.9g", l, px, py,
		         r->draw_error, bound, r->error);
	return r->error > 0 ? r->draw_error / r->error : 0;
}

/* Which levels check_file() checks the drawn error on (slow: one tolerance per file; the
 * finest level, most of a file's cells, only on the small synthetic rasters). */
enum drawn_check { DRAWN_NONE, DRAWN_ABOVE_FINEST, DRAWN_ALL };

static double check_file(struct packed *p, const char *name, double tol, enum drawn_check drawn)
{
	const struct relief_file *f = p->f;
	const struct relief_layout *lay = &f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E;
	const size_t EE = (size_t)E * E;
	const struct relief_dem *dem = &p->dem;
	int32_t **blocks = decode_tree(f);
	double worst_ratio = 0, drawn_ratio = 0;
	uint64_t checked = 0;
	float *eps = malloc(sizeof(float) * relief_block_errors_per_patch(P));
	for (uint32_t l = 0; l < lay->levels; l++) {
		const uint32_t side = 1u << l, step = 1u << (lay->levels - 1 - l);
		const double delta = lay->delta[l], q2 = 2 * delta;
		for (uint32_t py = 0; py < side; py++)
			for (uint32_t px = 0; px < side; px++) {
				uint32_t id = relief_patch_id(l, px, py);
				struct relief_patch_record r;
				relief_file_record(f, id, &r);
				if (r.flags & RELIEF_PATCH_EMPTY)
					continue;
				const int32_t *b = blocks[l] + ((size_t)py * side + px) * EE;
				/* 1. every valid sample within delta_l */
				for (uint32_t y = 0; y < P; y++)
					for (uint32_t x = 0; x < P; x++) {
						uint64_t X = ((uint64_t)px * (P - 1) + x) * step, Y = ((uint64_t)py * (P - 1) + y) * step;
						if (X >= dem->width || Y >= dem->height || !dem->valid[Y * dem->width + X])
							continue;
						double e = fabs(dem->heights[Y * dem->width + X] - q2 * b[(y + 1) * E + x + 1]);
						if (e > delta * (1 + 1e-9))
							fail_msg("%s tol %g level %u patch %u,%u sample %u,%u: error %.9g > %.9g",
							         name, tol, l, px, py, x, y, e, delta);
						worst_ratio = fmax(worst_ratio, e / delta);
						checked++;
					}
				/* 2. east and south neighbours agree on shared samples and rings */
				if (px + 1 < side) {
					const int32_t *n = b + EE;
					struct relief_patch_record nr;
					relief_file_record(f, id + 1, &nr);
					if (!(nr.flags & RELIEF_PATCH_EMPTY))
						for (uint32_t y = 0; y < E; y++) {
							assert_int_equal(b[y * E + P], n[y * E + 1]);       /* x = P-1 / 0 */
							assert_int_equal(b[y * E + P + 1], n[y * E + 2]);   /* ring / x = 1 */
							assert_int_equal(b[y * E + P - 1], n[y * E + 0]);   /* x = P-2 / ring */
						}
				}
				if (py + 1 < side) {
					const int32_t *n = b + EE * side;
					struct relief_patch_record nr;
					relief_file_record(f, id + side, &nr);
					if (!(nr.flags & RELIEF_PATCH_EMPTY))
						for (uint32_t x = 0; x < E; x++) {
							assert_int_equal(b[P * E + x], n[1 * E + x]);
							assert_int_equal(b[(P + 1) * E + x], n[2 * E + x]);
							assert_int_equal(b[(P - 1) * E + x], n[0 * E + x]);
						}
				}
				/* 3. Err(P) bounds the surface (either diagonal) against every valid original sample */
				double worst = 0;
				for (uint64_t Y = (uint64_t)py * (P - 1) * step; Y <= (uint64_t)(py + 1) * (P - 1) * step && Y < dem->height; Y++)
					for (uint64_t X = (uint64_t)px * (P - 1) * step; X <= (uint64_t)(px + 1) * (P - 1) * step && X < dem->width; X++) {
						if (!dem->valid[Y * dem->width + X])
							continue;
						double gx = (double)X / step - (double)px * (P - 1), gy = (double)Y / step - (double)py * (P - 1);
						uint32_t cx = gx >= P - 1 ? P - 2 : (uint32_t)gx, cy = gy >= P - 1 ? P - 2 : (uint32_t)gy;
						const int32_t *c = b + (cy + 1) * E + cx + 1;
						for (int diag = 0; diag < 2; diag++) {
							double s = surface(q2 * c[0], q2 * c[1], q2 * c[E], q2 * c[E + 1], gx - cx, gy - cy, diag);
							worst = fmax(worst, fabs(s - dem->heights[Y * dem->width + X]));
						}
					}
				if (worst > r.error)
					fail_msg("%s tol %g patch %u: measured %.9g exceeds Err(P) %.9g", name, tol, id,
					         worst, r.error);
				assert_true(r.error <= worst * (1 + 1e-6) + 1e-6); /* and it is not loose */
				assert_true(r.error >= delta * 0.5 || l == lay->levels - 1 || worst < delta);
				/* 4. block errors bound the block drawn at level d against the finest decoded
				 * surface: random points of finest cells with a valid corner, every diagonal
				 * choice of both surfaces */
				relief_file_block_errors(f, id, eps);
				for (uint32_t by = 0; by < lay->blocks; by++)
					for (uint32_t bx = 0; bx < lay->blocks; bx++)
						for (uint32_t dd = 1; dd <= RELIEF_BLOCK_LEVELS; dd++) {
							double e_stored = eps[(by * lay->blocks + bx) * 4 + dd - 1], found = 0;
							/* finite: the codes reach every error a block can have (version 8;
							 * before, errors over ~900 tolerances were stored as +infinity) */
							if (!isfinite(e_stored))
								fail_msg("%s tol %g patch %u block %u,%u d=%u: stored bound %g", name, tol, id, bx,
								         by, dd, e_stored);
							uint32_t s = 1u << dd;
							for (int t = 0; t < 24; t++) {
								double u = rnd() * RELIEF_BLOCK_CELLS, v = rnd() * RELIEF_BLOCK_CELLS;
								double fin[2];
								if (!finest_at(f, blocks, dem, (px * (P - 1) + bx * RELIEF_BLOCK_CELLS + u) * step,
								               (py * (P - 1) + by * RELIEF_BLOCK_CELLS + v) * step, fin))
									continue;
								uint32_t ci = (uint32_t)u / s * s, cj = (uint32_t)v / s * s;
								const int32_t *cc = b + (by * RELIEF_BLOCK_CELLS + 1 + cj) * E + bx * RELIEF_BLOCK_CELLS + 1 + ci;
								for (int dc = 0; dc < 2; dc++) {
									double cv = surface(q2 * cc[0], q2 * cc[s], q2 * cc[s * E], q2 * cc[s * E + s],
									                    (u - ci) / s, (v - cj) / s, dc);
									found = fmax(found, fmax(fabs(fin[0] - cv), fabs(fin[1] - cv)));
								}
							}
							if (found > e_stored * (1 + 1e-6) + 1e-6)
								fail_msg("%s tol %g patch %u block %u,%u d=%u: %.9g > stored %.9g", name,
								         tol, id, bx, by, dd, found, e_stored);
						}
				/* 5. the drawn error */
				if (drawn == DRAWN_ALL || (drawn == DRAWN_ABOVE_FINEST && l + 1 < lay->levels))
					drawn_ratio = fmax(drawn_ratio, check_drawn_error(f, blocks, dem, l, px, py, b, &r));
			}
	}
	print_message("%s tol %g: %llu samples checked on %u levels, worst error %.4f delta, %zu bytes\n",
	              name, tol, (unsigned long long)checked, lay->levels, worst_ratio, p->size);
	if (drawn != DRAWN_NONE)
		print_message("%s tol %g: drawn error checked%s, at most %.3f Err(P) above the finest level\n", name, tol,
		              drawn == DRAWN_ALL ? " on every level" : "", drawn_ratio);
	for (uint32_t l = 0; l < lay->levels; l++)
		free(blocks[l]);
	free(blocks);
	free(eps);
	return drawn_ratio;
}

static void bounds_for(enum test_dem d, uint32_t patch)
{
	static const double tols[] = { 0.1, 0.5, 1.0, 4.0 };
	struct packed p = { 0 };
	test_dem_load(d, &p.dem);
	for (size_t i = 0; i < sizeof(tols) / sizeof(tols[0]); i++) {
		pack(&p, test_dem_name(d), tols[i], 2, patch, 0);
		check_file(&p, test_dem_name(d), tols[i], tols[i] == 1.0 ? DRAWN_ABOVE_FINEST : DRAWN_NONE);
		unpack(&p);
	}
	relief_dem_finish(&p.dem);
}

static void test_bounds_puget(void **state) { bounds_for(DEM_PUGET, 129); }
static void test_bounds_alps(void **state) { bounds_for(DEM_ALPS, 129); }
static void test_bounds_lux(void **state) { bounds_for(DEM_LUX, 65); }

static void test_ratio3_and_patch_sizes(void **state)
{
	struct packed p = { 0 };
	test_dem_load(DEM_ALPS, &p.dem);
	pack(&p, test_dem_name(DEM_ALPS), 0.5, 3, 65, 0);
	check_file(&p, test_dem_name(DEM_ALPS), 0.5, DRAWN_ABOVE_FINEST);
	unpack(&p);
	pack(&p, test_dem_name(DEM_ALPS), 1.0, 2, 257, 0);
	check_file(&p, test_dem_name(DEM_ALPS), 1.0, DRAWN_NONE);
	unpack(&p);
	relief_dem_finish(&p.dem);
}

static void test_deterministic(void **state)
{
	struct packed a = { 0 }, b = { 0 };
	test_dem_load(DEM_ALPS, &a.dem);
	pack(&a, test_dem_name(DEM_ALPS), 1.0, 2, 129, 1);
	b.dem = a.dem;
	pack(&b, test_dem_name(DEM_ALPS), 1.0, 2, 129, 2);
	assert_int_equal(a.size, b.size);
	assert_memory_equal(a.img, b.img, a.size);
	unpack(&a);
	unpack(&b);
	relief_dem_finish(&a.dem);
}

/* An empty W x H raster 10 m apart (heights and validity for the caller to fill). */
static void dem_alloc(struct relief_dem *d, uint32_t W, uint32_t H)
{
	*d = (struct relief_dem){ .width = W, .height = H, .spacing_x = 10, .spacing_y = 10, .origin_y = 10.0 * (H - 1) };
	d->heights = malloc(sizeof(float) * W * H);
	d->valid = malloc((size_t)W * H);
	assert_non_null(d->heights);
	assert_non_null(d->valid);
}

/* A W x H raster 10 m apart, its own heights (a smooth swell plus a hash's noise), with
 * no-data in a disc, a corner and every 211th column. */
static void synthetic_dem(struct relief_dem *d, uint32_t W, uint32_t H)
{
	dem_alloc(d, W, H);
	for (uint32_t y = 0; y < H; y++)
		for (uint32_t x = 0; x < W; x++) {
			uint32_t k = y * W + x, hsh = k * 2654435761u;
			size_t i = (size_t)y * W + x;
			d->heights[i] = (float)(400 + 150 * sin(x / 37.0) * cos(y / 23.0) + (hsh >> 24) * 0.05);
			double dx = x - 0.7 * W, dy = y - 0.5 * H;
			d->valid[i] = !(dx * dx + dy * dy < 0.01 * (double)H * H || (x > W - W / 10 && y < H / 10) || x % 211 == 7);
		}
}

/* The drawn error on two synthetic rasters: one with no-data holes and a raster edge
 * inside patches (synthetic_dem()), and an egg crate made to reach the bound's constant:
 * samples (2i, 2j) alternate between 0 and 2A, the rest are 2A but A at (odd, odd). A
 * level-1 patch's cell of 2 finest cells then runs its diagonal where the finest cells
 * take the other one, and E0(P) = 2 Err(P) (relief_draw_error_bound() with n = 2): the
 * coarse selection measured with Err(P) at half of tau, as before format version 7, had no
 * margin left there for the finest level's tolerance. */
static void egg_crate_dem(struct relief_dem *d, uint32_t N, float A)
{
	dem_alloc(d, N, N);
	for (uint32_t y = 0; y < N; y++)
		for (uint32_t x = 0; x < N; x++) {
			float h = 2 * A;
			if (x % 2 == 0 && y % 2 == 0)
				h = (((x >> 1) + (y >> 1)) & 1) ? 2 * A : 0.0f;
			else if (x % 2 == 1 && y % 2 == 1)
				h = A;
			d->heights[(size_t)y * N + x] = h;
			d->valid[(size_t)y * N + x] = 1;
		}
}

static void test_drawn_error_synthetic(void **state)
{
	struct packed p = { 0 };
	synthetic_dem(&p.dem, 700, 300);
	pack(&p, "synthetic", 0.5, 2, 65, 0);
	check_file(&p, "synthetic 700 x 300 with holes", 0.5, DRAWN_ALL);
	unpack(&p);
	relief_dem_finish(&p.dem);
	egg_crate_dem(&p.dem, 257, 10.0f);
	pack(&p, "egg crate", 0.01, 2, 65, 0);
	double ratio = check_file(&p, "egg crate 257 x 257", 0.01, DRAWN_ALL);
	assert_true(ratio > 1.99); /* the constant is reached */
	unpack(&p);
	relief_dem_finish(&p.dem);
}

/* The packer quantises each level over a window around the data, not the padded square:
 * files of long, narrow and tall rasters with holes, and of Mont Blanc (whose raster
 * leaves two fifths of its grid as padding), at every patch size, equal byte for byte
 * those quantised over whole levels, and the windows are smaller. */
static void test_windows_change_nothing(void **state)
{
	struct { uint32_t w, h, patch; } cases[] = { { 3001, 40, 65 }, { 3001, 40, 129 }, { 37, 1500, 257 }, { 700, 300, 65 } };
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]) + 1; c++) {
		struct relief_dem dem;
		uint32_t patch = 129;
		if (c < sizeof(cases) / sizeof(cases[0])) {
			synthetic_dem(&dem, cases[c].w, cases[c].h);
			patch = cases[c].patch;
		} else {
			test_dem_load(DEM_ALPS, &dem);
		}
		uint8_t *img[2];
		size_t size[2];
		struct relief_pack_stats st[2];
		for (int whole = 0; whole < 2; whole++) {
			struct relief_pack_options o = { .patch = patch, .ratio = 2, .tolerance = 0.5, .whole_levels = whole };
			assert_int_equal(relief_pack_memory(&dem, &o, &img[whole], &size[whole], &st[whole]), 0);
		}
		print_message("%u x %u at %u: %zu bytes, %llu samples quantised in windows, %llu whole\n", dem.width,
		              dem.height, patch, size[0], (unsigned long long)st[0].quantised_samples,
		              (unsigned long long)st[1].quantised_samples);
		assert_int_equal(size[0], size[1]);
		assert_memory_equal(img[0], img[1], size[0]);
		assert_true(st[0].quantised_samples < st[1].quantised_samples);
		free(img[0]);
		free(img[1]);
		relief_dem_finish(&dem);
	}
}

/* No-data never becomes a height: the decoded mask equals the input's validity at every
 * level, and decoded heights are NaN exactly there. */
/* Format version 6: the index holds a record for exactly the patches whose footprint
 * starts inside the raster (docs/format.md), every other patch reads EMPTY, and so a long,
 * narrow raster's metadata follows its data, not the square grid. */
static void test_index_follows_raster(void **state)
{
	struct { uint32_t w, h, patch; } cases[] = { { 3001, 40, 65 }, { 37, 1500, 257 }, { 700, 300, 65 } };
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		struct relief_dem dem;
		synthetic_dem(&dem, cases[c].w, cases[c].h);
		struct relief_pack_options o = { .patch = cases[c].patch, .ratio = 2, .tolerance = 0.5 };
		uint8_t *img;
		size_t size;
		struct relief_pack_stats st;
		assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, &st), 0);
		struct relief_file *f;
		char err[256];
		assert_int_equal(relief_file_open_memory(img, size, &f, err, sizeof(err)), 0);
		const struct relief_header *h = &f->hdr;
		uint32_t inside = 0, empty_inside = 0;
		for (uint32_t id = 0; id < h->patch_count; id++) {
			uint32_t l, px, py;
			assert_true(relief_patch_coords(&f->layout, id, &l, &px, &py));
			const uint64_t span = (uint64_t)(h->patch_size - 1) << (h->levels - 1 - l);
			bool in = px * span < h->width && py * span < h->height;
			struct relief_patch_record r;
			relief_file_record(f, id, &r);
			if (in) {
				assert_int_equal(relief_index_entry(h, id), inside); /* in id order, one after another */
				inside++;
				empty_inside += !!(r.flags & RELIEF_PATCH_EMPTY);
			} else {
				assert_int_equal(relief_index_entry(h, id), UINT32_MAX);
				assert_int_equal(r.flags, RELIEF_PATCH_EMPTY);
				assert_int_equal(r.size, 0);
			}
		}
		print_message("%u x %u at %u: %u patches, %u index records (%u of them empty), %llu bytes of metadata\n",
		              dem.width, dem.height, cases[c].patch, h->patch_count, h->index_records, empty_inside,
		              (unsigned long long)h->data_offset);
		assert_int_equal(h->index_records, inside);
		assert_int_equal(relief_index_entry(h, h->patch_count), UINT32_MAX); /* beyond the tree */
		assert_int_equal(relief_index_entry(h, UINT32_MAX), UINT32_MAX);
		assert_int_equal(h->block_patches, inside - empty_inside);
		assert_int_equal(h->patch_count - h->block_patches, st.empty_patches);
		assert_true(inside < h->patch_count);
		relief_file_close(f);
		free(img);
		relief_dem_finish(&dem);
	}
}

static void test_nodata_stays_nodata(void **state)
{
	struct packed p = { 0 };
	test_dem_load(DEM_LUX, &p.dem);
	uint64_t invalid = 0;
	for (size_t i = 0; i < (size_t)p.dem.width * p.dem.height; i++)
		invalid += !p.dem.valid[i];
	assert_int_equal(invalid, 3942); /* the file's NoData cells, per its documentation */
	pack(&p, test_dem_name(DEM_LUX), 0.5, 2, 65, 0);
	assert_true(p.f->hdr.valid_samples == 8550 - 3942);
	for (uint32_t l = 0; l < p.f->hdr.levels; l++) {
		uint32_t w, h, step = 1u << (p.f->hdr.levels - 1 - l);
		relief_level_extent(&p.f->hdr, l, &w, &h);
		float *hh = malloc(sizeof(float) * w * h);
		uint8_t *m = malloc((size_t)w * h);
		assert_int_equal(relief_decode_level(p.f, l, 0, hh, m), 0);
		uint64_t grown = 0;
		for (uint32_t y = 0; y < h; y++)
			for (uint32_t x = 0; x < w; x++) {
				/* the finest level's validity; above it, a valid raster sample within half
				 * the level's spacing (Chebyshev), counted here by brute force */
				const long X = (long)(x * step), Y = (long)(y * step), r = (long)(step / 2);
				uint8_t v = 0;
				for (long yy = Y - r; yy <= Y + r && !v; yy++)
					for (long xx = X - r; xx <= X + r && !v; xx++)
						v = xx >= 0 && yy >= 0 && xx < (long)p.dem.width && yy < (long)p.dem.height &&
						    p.dem.valid[(size_t)yy * p.dem.width + (size_t)xx];
				const bool inside = X < (long)p.dem.width && Y < (long)p.dem.height;
				if (inside)
					assert_int_equal(m[y * w + x], v);
				else /* past the raster's edge the packer's distance may be a little short */
					assert_true(m[y * w + x] >= v);
				v = m[y * w + x];
				assert_int_equal(isnan(hh[y * w + x]), !v);
				grown += v && !(inside && p.dem.valid[(size_t)Y * p.dem.width + (size_t)X]);
				if (v)
					assert_true(hh[y * w + x] > 100 && hh[y * w + x] < 600); /* Luxembourg: 141-547 m */
			}
		print_message("level %u: %llu samples valid beside the data whose own sample is not\n", l,
		              (unsigned long long)grown);
		assert_true(l + 1 == p.f->hdr.levels ? grown == 0 : grown > 0);
		free(hh);
		free(m);
	}
	unpack(&p);
	relief_dem_finish(&p.dem);
}

/* Which patches have gaps under them (relief_file_patch_gaps(): some finest sample under
 * the footprint no-data or past the raster), against a brute-force look at the raster, and
 * the error the selection projects (relief_patch_select_error()): E0(P), or above the
 * finest level where the patch has gaps, half the coverage error (2^(levels - 1 - l)
 * finest cells' diagonals) when that is larger. Returns the patches with gaps. */
static uint32_t gaps_for(enum test_dem d, uint32_t patch)
{
	struct packed p = { 0 };
	test_dem_load(d, &p.dem);
	pack(&p, test_dem_name(d), 1.0, 2, patch, 0);
	const struct relief_header *h = &p.f->hdr;
	const uint32_t W = p.dem.width, H = p.dem.height, L = h->levels;
	uint32_t with_gaps = 0, raised = 0;
	for (uint32_t l = 0; l < L; l++) {
		const uint32_t span = (h->patch_size - 1) << (L - 1 - l);
		for (uint32_t py = 0; py < 1u << l; py++)
			for (uint32_t px = 0; px < 1u << l; px++) {
				bool gap = false;
				for (uint32_t y = py * span; y <= (py + 1) * span && !gap; y++)
					for (uint32_t x = px * span; x <= (px + 1) * span && !gap; x++)
						gap = x >= W || y >= H || !p.dem.valid[(size_t)y * W + x];
				const uint32_t id = relief_patch_id(l, px, py);
				assert_int_equal(relief_file_patch_gaps(p.f, id), gap);
				with_gaps += gap;
				struct relief_patch_record r;
				relief_file_record(p.f, id, &r);
				const float e = relief_patch_select_error(p.f, id, &r);
				const double cover = ldexp(hypot(h->spacing_x, h->spacing_y), (int)(L - 1 - l));
				assert_true(e >= r.draw_error);
				if (gap && l + 1 < L && !(r.flags & RELIEF_PATCH_EMPTY)) {
					assert_true(e >= RELIEF_LOD_COARSE_SHARE * cover);
					raised += e > r.draw_error;
				} else {
					assert_true(e == r.draw_error);
				}
			}
	}
	print_message("%s at %u: %u of the tree's patches have gaps under them, %u selection errors raised by coverage\n",
	              test_dem_name(d), patch, with_gaps, raised);
	unpack(&p);
	relief_dem_finish(&p.dem);
	return with_gaps;
}

static void test_patch_gaps(void **state)
{
	assert_true(gaps_for(DEM_LUX, 65) > 0);   /* no-data outside the border */
	assert_true(gaps_for(DEM_ALPS, 129) > 0); /* 647^2 samples padded to 1025^2 */
	assert_int_equal(gaps_for(DEM_PUGET, 129), 0); /* 1025^2: fills its grid, no no-data */
}

/* relief_fill_nodata() on a raster with two valid islands: valid heights copied bit for
 * bit, each sample's ring its Chebyshev distance to the nearest valid sample, the first
 * ring within [min, max] of its valid 8-neighbours and every fill within the valid range;
 * a raster without a valid sample is refused. */
static void test_fill_rings(void **state)
{
	enum { W = 23, H = 17 };
	float in[W * H], out[W * H];
	uint8_t valid[W * H];
	uint16_t ring[W * H];
	for (uint32_t i = 0; i < W * H; i++) {
		uint32_t x = i % W, y = i / W;
		valid[i] = (x >= 3 && x <= 5 && y >= 4 && y <= 6) || (x == 19 && y == 12);
		in[i] = valid[i] ? (float)(100.0 + 7.0 * x - 3.0 * y + (x == 19 ? 900.0 : 0.0)) : NAN;
	}
	assert_int_equal(relief_fill_nodata(W, H, in, valid, out, ring), 0);
	for (uint32_t i = 0; i < W * H; i++) {
		int x = (int)(i % W), y = (int)(i / W);
		if (valid[i]) {
			assert_memory_equal(&out[i], &in[i], sizeof(float));
			assert_int_equal(ring[i], 0);
			continue;
		}
		int d = INT32_MAX;
		double lo = INFINITY, hi = -INFINITY;
		for (uint32_t j = 0; j < W * H; j++)
			if (valid[j]) {
				int dx = abs((int)(j % W) - x), dy = abs((int)(j / W) - y), c = dx > dy ? dx : dy;
				d = c < d ? c : d;
				if (c == 1) {
					lo = fmin(lo, in[j]);
					hi = fmax(hi, in[j]);
				}
			}
		assert_int_equal(ring[i], d);
		assert_true(out[i] >= 100.0f + 7 * 3 - 3 * 6 && out[i] <= 100.0f + 7 * 19 - 3 * 12 + 900);
		if (d == 1)
			assert_true(out[i] >= lo && out[i] <= hi);
	}
	memset(valid, 0, sizeof(valid));
	assert_int_equal(relief_fill_nodata(W, H, in, valid, out, NULL), -ENODATA);
}

/* Where a renderer draws towards no-data: the half cell beyond a valid sample leans
 * towards its no-data neighbour's decoded value (a fragment is kept where its nearest
 * sample is valid), so at every level every no-data sample with a valid 4-neighbour must
 * lie within the terrain around it: within delta_l of [min, max] of the valid finest
 * samples within two of the level's spacings (Chebyshev) of it, or, past the raster's
 * east or south edge, of its nearest raster sample. Checked where the streams code the
 * sample (relief_level_coded()): in format version 9 every one. Version 8 (which the
 * packer still writes on request) leaves, past the raster's edge, the first padding column
 * of a level whose extent is even in no stream (it copies a coarser level's, the root's
 * MED copying its last coded column): those are counted, not checked (docs/codec.md,
 * "No-data"). Until the packer filled the rim (common/fill.h) the no-data samples took
 * the predictions: Luxembourg's western and northern rims reached 0 m, up to 548 m below
 * the data beside them. */
/* Whether finest sample (x, y) is a valid raster sample. */
static bool valid_at(const struct relief_dem *d, int64_t x, int64_t y)
{
	return x >= 0 && y >= 0 && x < (int64_t)d->width && y < (int64_t)d->height &&
	       d->valid[(size_t)y * d->width + (size_t)x];
}

static void rim_within_terrain(struct packed *p, const char *name, double tol, uint32_t patch, uint32_t version)
{
	struct relief_pack_options o = { .patch = patch, .ratio = 2, .tolerance = tol, .version = version };
	assert_int_equal(relief_pack_memory(&p->dem, &o, &p->img, &p->size, NULL), 0);
	char err[256];
	if (relief_file_open_memory(p->img, p->size, &p->f, err, sizeof(err)) < 0)
		fail_msg("%s: %s", name, err);
	const struct relief_layout *lay = &p->f->layout;
	const uint32_t P = lay->geom.P, E = lay->geom.E, W = p->dem.width, H = p->dem.height;
	int32_t **blocks = decode_tree(p->f);
	uint64_t checked = 0, skipped = 0;
	double worst = 0.0; /* metres outside the allowed range, at most 0 */
	for (uint32_t l = 0; l < lay->levels; l++) {
		const uint32_t side = 1u << l, S = relief_level_size(lay, l);
		const uint64_t step = 1ull << (lay->levels - 1 - l);
		const bool rim = relief_format_has_rim(p->f->hdr.version);
		const uint32_t coded_w = relief_level_coded(lay, W, l, rim), coded_h = relief_level_coded(lay, H, l, rim);
		for (uint32_t py = 0; py < side; py++)
			for (uint32_t px = 0; px < side; px++) {
				const int32_t *b = blocks[l] + ((size_t)py * side + px) * E * E;
				for (uint32_t y = 0; y < P; y++)
					for (uint32_t x = 0; x < P; x++) {
						const int64_t gx = (int64_t)px * (P - 1) + x, gy = (int64_t)py * (P - 1) + y;
						const int64_t X = gx * (int64_t)step, Y = gy * (int64_t)step;
						if (valid_at(&p->dem, X, Y) || gx >= S || gy >= S)
							continue;
						if (!valid_at(&p->dem, X - (int64_t)step, Y) && !valid_at(&p->dem, X + (int64_t)step, Y) &&
						    !valid_at(&p->dem, X, Y - (int64_t)step) && !valid_at(&p->dem, X, Y + (int64_t)step))
							continue;
						if (gx >= coded_w || gy >= coded_h) {
							skipped++;
							continue;
						}
						const int64_t cx = X < W ? X : W - 1, cy = Y < H ? Y : H - 1, r = 2 * (int64_t)step;
						double lo = INFINITY, hi = -INFINITY;
						for (int64_t v = cy - r; v <= cy + r; v++)
							for (int64_t u = cx - r; u <= cx + r; u++)
								if (valid_at(&p->dem, u, v)) {
									lo = fmin(lo, p->dem.heights[(size_t)v * W + (size_t)u]);
									hi = fmax(hi, p->dem.heights[(size_t)v * W + (size_t)u]);
								}
						const double h = 2.0 * lay->delta[l] * b[(y + 1) * E + x + 1];
						const double out = fmax(lo - lay->delta[l] - h, h - hi - lay->delta[l]);
						if (out > 0)
							fail_msg("%s level %u: no-data sample (%lld, %lld) decodes to %.2f m, beside "
							         "valid terrain at %.2f..%.2f m", name, l, (long long)X, (long long)Y,
							         h, lo, hi);
						worst = fmax(worst, out);
						checked++;
					}
			}
		free(blocks[l]);
	}
	free(blocks);
	print_message("%s, version %u: %llu no-data samples beside the data checked, %llu past the edge in no stream\n",
	              name, p->f->hdr.version, (unsigned long long)checked, (unsigned long long)skipped);
	assert_true(checked > 0);
	if (relief_format_has_rim(p->f->hdr.version))
		assert_int_equal(skipped, 0);
	unpack(p);
}

static void test_nodata_rim_at_data_height(void **state)
{
	struct packed p = { 0 };
	for (uint32_t version = 8; version <= 9; version++) {
		test_dem_load(DEM_LUX, &p.dem);
		rim_within_terrain(&p, "Luxembourg", 1.0, 65, version);
		relief_dem_finish(&p.dem);
		test_dem_load(DEM_ALPS, &p.dem); /* 647^2 in a 1025^2 grid: padding east and south */
		rim_within_terrain(&p, "Mont Blanc", 1.0, 129, version);
		relief_dem_finish(&p.dem);
		synthetic_dem(&p.dem, 700, 300);
		rim_within_terrain(&p, "synthetic 700 x 300 with holes", 0.5, 65, version);
		relief_dem_finish(&p.dem);
	}
}

static void test_bad_inputs(void **state)
{
	struct relief_dem dem = { 0 };
	uint8_t *img;
	size_t size;
	struct relief_pack_options o = { .patch = 129, .ratio = 2, .tolerance = 1.0 };
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), -EINVAL);
	float h[4] = { 1, 2, 3, 4 };
	uint8_t v[4] = { 0, 0, 0, 0 };
	dem = (struct relief_dem){ .width = 2, .height = 2, .heights = h, .valid = v, .spacing_x = 1, .spacing_y = 1 };
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), -ENODATA);
	v[0] = v[1] = v[2] = v[3] = 1;
	h[2] = 1e5f;
	o.tolerance = 1e-3;
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), -ERANGE);
	o.tolerance = 1.0;
	o.patch = 100;
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), -EINVAL);
	o.patch = 65;
	o.ratio = 4;
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), -EINVAL);
	o.ratio = 2;
	h[1] = NAN;
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), -EINVAL);
	h[1] = 2;
	/* A flat, tiny terrain (a sea) packs and decodes. */
	h[0] = h[1] = h[2] = h[3] = 0;
	assert_int_equal(relief_pack_memory(&dem, &o, &img, &size, NULL), 0);
	struct relief_file *f;
	char err[128];
	assert_int_equal(relief_file_open_memory(img, size, &f, err, sizeof(err)), 0);
	float out[4];
	assert_int_equal(relief_decode_level(f, 0, 1, out, NULL), 0);
	for (int i = 0; i < 4; i++)
		assert_true(out[i] == 0.0f);
	relief_file_close(f);
	free(img);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bounds_puget),
		cmocka_unit_test(test_bounds_alps),
		cmocka_unit_test(test_bounds_lux),
		cmocka_unit_test(test_ratio3_and_patch_sizes),
		cmocka_unit_test(test_drawn_error_synthetic),
		cmocka_unit_test(test_deterministic),
		cmocka_unit_test(test_nodata_stays_nodata),
		cmocka_unit_test(test_patch_gaps),
		cmocka_unit_test(test_fill_rings),
		cmocka_unit_test(test_nodata_rim_at_data_height),
		cmocka_unit_test(test_windows_change_nothing),
		cmocka_unit_test(test_index_follows_raster),
		cmocka_unit_test(test_bad_inputs),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
