/* relief unpack FILE.relief OUT [--level L] [--raw] [--mask MASK]: reconstructed heights. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include "cli.h"
#include "decode.h"
#include "le.h"

static int write_bytes(const char *path, const void *data, size_t size)
{
	FILE *f = fopen(path, "wbe");
	if (!f)
		return -errno;
	size_t w = fwrite(data, 1, size, f);
	int ret = w == size ? 0 : -EIO;
	if (fclose(f) != 0 && ret == 0)
		ret = -errno;
	return ret;
}

static int write_geotiff(const char *path, const struct relief_file *f, uint32_t level, const float *h, uint32_t w,
                         uint32_t hgt)
{
	GDALAllRegister();
	GDALDriverH drv = GDALGetDriverByName("GTiff");
	if (!drv)
		return -ENOTSUP;
	char *opts[] = { "COMPRESS=DEFLATE", "PREDICTOR=3", NULL };
	GDALDatasetH ds = GDALCreate(drv, path, (int)w, (int)hgt, 1, GDT_Float32, opts);
	if (!ds)
		return -EIO;
	double step = (double)(1u << (f->hdr.levels - 1 - level));
	double sx = f->hdr.spacing_x * step, sy = f->hdr.spacing_y * step;
	double gt[6] = { f->hdr.origin_x - 0.5 * sx, sx, 0, f->hdr.origin_y + 0.5 * sy, 0, -sy };
	GDALSetGeoTransform(ds, gt);
	if (f->crs[0]) {
		OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
		if (OSRSetFromUserInput(srs, f->crs) == OGRERR_NONE)
			GDALSetSpatialRef(ds, srs);
		OSRDestroySpatialReference(srs);
	}
	GDALRasterBandH band = GDALGetRasterBand(ds, 1);
	GDALSetRasterNoDataValue(band, NAN);
	CPLErr e = GDALRasterIO(band, GF_Write, 0, 0, (int)w, (int)hgt, (void *)h, (int)w, (int)hgt, GDT_Float32, 0, 0);
	GDALClose(ds);
	return e == CE_None ? 0 : -EIO;
}

int cmd_unpack(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "level", required_argument, NULL, 'l' },
		{ "raw", no_argument, NULL, 'R' },
		{ "mask", required_argument, NULL, 'm' },
		{ "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	uint32_t level = UINT32_MAX;
	bool raw = false;
	const char *mask_path = NULL;
	int c;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":l:h", opts, NULL)) != -1) {
		switch (c) {
		case 'l':
			if (!cli_parse_u32("unpack", "--level", optarg, 0, RELIEF_MAX_LEVELS - 1, &level))
				return EXIT_USAGE;
			break;
		case 'R': raw = true; break;
		case 'm': mask_path = optarg; break;
		case 'h':
			printf("usage: relief unpack FILE.relief OUT [--level L] [--raw] [--mask MASK]\n"
			       "Writes the reconstructed heights (metres) of one level (default the finest):\n"
			       "a float32 GeoTIFF, or with --raw little-endian float32, row-major from the\n"
			       "north row, no header. No-data samples are NaN; above the finest level a\n"
			       "sample within half the level's spacing of data is valid (it is drawn there,\n"
			       "at the data's height). --mask writes 1 byte per sample (1 = valid).\n");
			return 0;
		case ':':
		default:
			return cli_option_error("unpack", c, argv);
		}
	}
	if (argc - optind != 2) {
		fprintf(stderr, "relief unpack: expected FILE.relief and OUT\n");
		return EXIT_USAGE;
	}
	const char *in = argv[optind], *out = argv[optind + 1];
	const char *outs[] = { out, mask_path };
	if (!cli_outputs_ok("unpack", outs, 2, &in, 1))
		return EXIT_USAGE;
	char err[512];
	struct relief_file *f;
	if (relief_file_open(in, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief unpack: %s: %s\n", in, err);
		return 1;
	}
	int status = 1;
	if (level == UINT32_MAX)
		level = f->hdr.levels - 1;
	if (level >= f->hdr.levels) {
		fprintf(stderr, "relief unpack: --level %u: %s has levels 0..%u\n", level, in, f->hdr.levels - 1);
		relief_file_close(f);
		return EXIT_USAGE;
	}
	uint32_t w, h;
	relief_level_extent(&f->hdr, level, &w, &h);
	float *heights = malloc(sizeof(float) * w * h);
	uint8_t *mask = malloc((size_t)w * h);
	int ret = heights && mask ? relief_decode_level(f, level, 0, heights, mask) : -ENOMEM;
	if (ret < 0) {
		fprintf(stderr, "relief unpack: %s: decoding level %u failed: %s\n", in, level,
		        ret == -EBADMSG ? "corrupt patch data" : strerror(-ret));
		goto out;
	}
	/* Each output replaces what was there only once it is complete. */
	char *tmp;
	if ((ret = cli_replace_begin(out, &tmp)) == 0) {
		if (raw) {
			for (size_t i = 0; i < (size_t)w * h; i++)
				le_put_f32((uint8_t *)&heights[i], heights[i]);
			ret = write_bytes(tmp, heights, sizeof(float) * w * h);
		} else {
			ret = write_geotiff(tmp, f, level, heights, w, h);
		}
		ret = cli_replace_end(tmp, out, ret);
	}
	if (ret < 0) {
		fprintf(stderr, "relief unpack: cannot write %s: %s\n", out, strerror(-ret));
		goto out;
	}
	if (mask_path && ((ret = cli_replace_begin(mask_path, &tmp)) < 0 ||
	                  (ret = cli_replace_end(tmp, mask_path, write_bytes(tmp, mask, (size_t)w * h))) < 0)) {
		fprintf(stderr, "relief unpack: cannot write %s: %s\n", mask_path, strerror(-ret));
		goto out;
	}
	status = 0;
out:
	free(heights);
	free(mask);
	relief_file_close(f);
	return status;
}
