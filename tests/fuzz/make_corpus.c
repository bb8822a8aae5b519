/* Writes the seed corpora of the fuzz targets: make_corpus TESTS_DATA_DIR CORPUS_DIR.
 * Seeds are valid inputs (small .relief files, patch and mask streams taken from them,
 * configuration texts) plus truncated and bit-flipped variants. Deterministic, so the
 * committed corpus can be regenerated after a format change. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dem_import.h"
#include "format.h"
#include "pack.h"

static void put(const char *dir, const char *sub, const char *name, const void *data, size_t n)
{
	char path[4096];
	snprintf(path, sizeof(path), "%s/%s/%s", dir, sub, name);
	FILE *f = fopen(path, "wb");
	if (!f || fwrite(data, 1, n, f) != n) {
		fprintf(stderr, "cannot write %s\n", path);
		exit(1);
	}
	fclose(f);
}

/* Text seeds: DIR/SUB/SUB<i>.EXT for each string. */
static void put_texts(const char *dir, const char *sub, const char *ext, const char *const *texts, size_t n)
{
	char name[256];
	for (size_t i = 0; i < n; i++) {
		snprintf(name, sizeof(name), "%s%zu.%s", sub, i, ext);
		put(dir, sub, name, texts[i], strlen(texts[i]));
	}
}

static void variants(const char *dir, const char *sub, const char *base, const uint8_t *data, size_t n)
{
	char name[256];
	snprintf(name, sizeof(name), "%s", base);
	put(dir, sub, name, data, n);
	snprintf(name, sizeof(name), "%s-half", base);
	put(dir, sub, name, data, n / 2);
	uint8_t *copy = malloc(n);
	for (int k = 0; k < 3; k++) {
		memcpy(copy, data, n);
		size_t at = (n / 3) * (size_t)k + 17 < n ? (n / 3) * (size_t)k + 17 : 0;
		copy[at] ^= 0x5a;
		snprintf(name, sizeof(name), "%s-flip%d", base, k);
		put(dir, sub, name, copy, n);
	}
	free(copy);
}

static void pack_file(const char *dir, const char *name, struct relief_dem *dem, uint32_t patch, double tol)
{
	struct relief_pack_options o = { .patch = patch, .ratio = 2, .tolerance = tol, .threads = 1 };
	uint8_t *img;
	size_t size;
	if (relief_pack_memory(dem, &o, &img, &size, NULL) < 0)
		exit(1);
	variants(dir, "format", name, img, size);
	struct relief_file *f;
	char err[256];
	if (relief_file_open_memory(img, size, &f, err, sizeof(err)) < 0)
		exit(1);
	uint8_t *d = malloc(f->max_stream);
	for (uint32_t id = 0; id < f->hdr.patch_count && id < 3; id++) {
		size_t n;
		if (relief_file_read_stream(f, id, d, &n) < 0)
			continue;
		uint8_t *sel = malloc(n + 1);
		sel[0] = (uint8_t)(id == 0 ? 1 : (id - 1) << 1); /* root, or child quadrant */
		memcpy(sel + 1, d, n);
		char base[128];
		snprintf(base, sizeof(base), "%s-patch%u", name, id);
		if (patch == 65)
			variants(dir, "patch", base, sel, n + 1);
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		if ((r.flags & RELIEF_PATCH_MASKED) && patch == 65) {
			uint8_t *m = malloc(r.mask_size + 1);
			m[0] = 16;
			memcpy(m + 1, f->meta + f->hdr.masks_offset + r.mask_offset, r.mask_size);
			snprintf(base, sizeof(base), "%s-mask%u", name, id);
			variants(dir, "patch", base, m, r.mask_size + 1);
			free(m);
		}
		free(sel);
	}
	/* The root and the first other patch whose window skips samples, with their windows
	 * (fuzz_patch bit 5). */
	for (uint32_t id = 0, found = 0; id < f->hdr.patch_count && patch == 65 && found < 2; id++) {
		struct relief_window w;
		relief_file_window(f, id, &w);
		size_t n;
		if ((w.x1 > 65 && w.y1 > 65) || relief_file_read_stream(f, id, d, &n) < 0)
			continue;
		found++;
		uint32_t l, px, py;
		relief_patch_coords(&f->layout, id, &l, &px, &py);
		uint8_t *sel = malloc(n + 4);
		sel[0] = (uint8_t)(32 | (id == 0) | ((px & 1) << 1) | ((py & 1) << 2));
		sel[1] = (uint8_t)w.x1;
		sel[2] = (uint8_t)w.y1;
		sel[3] = (uint8_t)(w.ring_west | w.ring_north << 1);
		memcpy(sel + 4, d, n);
		char base[128];
		snprintf(base, sizeof(base), "%s-window%u", name, id);
		variants(dir, "patch", base, sel, n + 4);
		free(sel);
	}
	free(d);
	relief_file_close(f);
	free(img);
}

int main(int argc, char **argv)
{
	if (argc != 3) {
		fprintf(stderr, "usage: make_corpus TESTS_DATA_DIR CORPUS_DIR\n");
		return 2;
	}
	const char *out = argv[2];
	char path[4096], err[512];
	struct relief_dem dem;
	struct dem_import_options o = { 0 };
	snprintf(path, sizeof(path), "%s/luxembourg_elev.tif", argv[1]);
	if (dem_import(path, &o, &dem, err, sizeof(err)) < 0) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	pack_file(out, "lux65", &dem, 65, 1.0);
	pack_file(out, "lux129", &dem, 129, 4.0);
	relief_dem_finish(&dem);
	/* A Mont Blanc crop in a grid three levels deep: streams with windows (version 3). */
	struct dem_import_options ro = { .has_spacing = true, .spacing = 92.7, .raw_width = 140, .raw_height = 100,
	                                 .raw_type = "float32" };
	snprintf(path, sizeof(path), "%s/alps-crop-140x100.f32", argv[1]);
	if (dem_import(path, &ro, &dem, err, sizeof(err)) < 0) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	pack_file(out, "crop65", &dem, 65, 4.0);
	relief_dem_finish(&dem);
	/* A tiny flat sea with one no-data corner. */
	float h[9] = { 0 };
	uint8_t v[9] = { 0, 1, 1, 1, 1, 1, 1, 1, 1 };
	struct relief_dem sea = { .width = 3, .height = 3, .heights = h, .valid = v, .spacing_x = 10, .spacing_y = 10 };
	pack_file(out, "sea", &sea, 65, 0.5);

	const char *configs[] = {
		"[gpu]\ndevice = llvmpipe\nvalidation = true\nbudget_mib = 64\n",
		"[gpu]\nbudget_mib = 99999999999\n",
		"[gpu\ndevice\n",
		"; comment\n[gpu]\ndevice = 0123456789abcdef0123456789abcdef\n[other]\nx = 1\n",
		"[gpu]\ndecode_workers = 2\ndecode_workers = 08x\n",
	};
	put_texts(out, "config", "ini", configs, sizeof(configs) / sizeof(configs[0]));
	const char *sidecars[] = {
		"[import]\nscale = 0.1\nspacing = 160\n",
		"[import]\nscale = 0.06646829938201\noffset = 454\nspacing = 92.7\nunits = ft\n",
		"[import]\nencoding = terrain-rgb\nnodata = -32768\n",
		"[import]\nspacing = -3\nunits = yards\n",
		"[other]\nscale = 1\n",
	};
	put_texts(out, "sidecar", "ini", sidecars, sizeof(sidecars) / sizeof(sidecars[0]));
	const char *tracks[] = {
		"# t x y z heading pitch roll\n0 60000 40000 3000 45 -10 0\n5 61000 41000 3000 90 -10 30\n"
		"10 62500 41000 2500 135 -90 0\n",
		"0,1,2,3,4,5,6\r\n1.5,1,2,3,4,5,6 # comment\r\n",
		"0 1 2 3 4 5\n",
		"0 1 2 3 4 5 6\n0 1 2 3 4 5 6\n",
		"0 1 2 3 4 95 6\n1 1e999 nan inf -inf 0x10 1e-320\n",
	};
	put_texts(out, "track", "txt", tracks, sizeof(tracks) / sizeof(tracks[0]));
	/* fuzz_args: a parser's letter, then the argument. */
	const char *args[] = {
		"u4", "u0070000", "u70001", "u+5", "u 5", "u-1", "u99999999999", "d1e-3", "dnan", "d1e999",
		"d0x1p4", "s480x270", "s0x10", "s00048x0032", "s5 x4", "s48x32x", "s99999999999x5",
		"v100000,50000,5500", "v1,,2,3", "v,1,2,3", "v1,2,3,", "v1,2", "v1,2,3,4", "l0.5,1,2,4",
		"l1,2,3,4,5", "l-3", "l1e3", "l,", "l", "x1,2,3",
	};
	put_texts(out, "args", "txt", args, sizeof(args) / sizeof(args[0]));
	/* fuzz_import: W, H and flags bytes, gt[6], nodata, scale, offset, spacing, samples
	 * (see fuzz_import.c). */
	const struct {
		const char *name;
		uint8_t w, h, flags;
		double d[10];
		bool i16;
	} rasters[] = {
		{ "utm", 2, 2, 1 | 1 << 1, { 500000, 30, 0, 5000000, 0, -30 }, false },
		{ "wgs84-int16", 2, 2, 1 | 2 << 1 | 16, { 6.0, 0.001, 0, 49.8, 0, -0.001 }, true },
		{ "feet-nodata", 1, 1, 1 | 3 << 1 | 8, { 1000000, 10, 0, 200000, 0, -10, 103 }, false },
		{ "unreferenced-spacing", 1, 1, 128, { 0, 0, 0, 0, 0, 0, 0, 0, 0, 10 }, false },
		{ "scaled", 2, 2, 1 | 1 << 1 | 64, { 0, 1, 0, 4, 0, -1, 0, 0.1, 454 }, false },
		{ "terrain-rgb", 0, 0, 1 | 1 << 1 | 32 | 16, { 0, 1, 0, 2, 0, -1 }, true },
		{ "nan-origin", 2, 2, 1 | 1 << 1, { NAN, 1, 0, 4, 0, -1 }, false },
		{ "tiny-spacing", 2, 2, 1 | 1 << 1, { 0, 1e-9, 0, 4, 0, -1e-9 }, false },
		{ "south-up", 2, 2, 1 | 1 << 1, { 0, 30, 0, 0, 0, 30 }, false },
	};
	for (size_t k = 0; k < sizeof(rasters) / sizeof(rasters[0]); k++) {
		uint8_t buf[4096];
		size_t n = 0;
		buf[n++] = rasters[k].w;
		buf[n++] = rasters[k].h;
		buf[n++] = rasters[k].flags;
		for (int i = 0; i < 10; i++) {
			memcpy(buf + n, &rasters[k].d[i], 8);
			n += 8;
		}
		int W = 2 + rasters[k].w % 15, H = 2 + rasters[k].h % 15, bands = rasters[k].flags & 32 ? 3 : 1;
		for (int i = 0; i < W * H * bands; i++) {
			if (rasters[k].i16) {
				int16_t s16 = (int16_t)(100 + i * 7);
				memcpy(buf + n, &s16, 2);
				n += 2;
			} else {
				float s32 = 100.0f + (float)i * 3.5f;
				memcpy(buf + n, &s32, 4);
				n += 4;
			}
		}
		char name[64];
		snprintf(name, sizeof(name), "%s.bin", rasters[k].name);
		put(out, "import", name, buf, n);
	}
	return 0;
}
