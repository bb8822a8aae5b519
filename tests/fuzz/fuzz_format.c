/* The .relief parser and everything a reader does after a successful open: records, block
 * errors, masks, the selection's error (with the gaps derived at open) and full decoding,
 * NaN-marked and drawn (small files only, to bound memory). */
#include <stdlib.h>
#include <string.h>

#include "decode.h"
#include "format.h"
#include "fuzz.h"
#include "lod.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct relief_file *f;
	char err[256];
	if (relief_file_open_memory(data, size, &f, err, sizeof(err)) < 0)
		return 0;
	size_t P = f->hdr.patch_size;
	float *eps = malloc(sizeof(float) * relief_block_errors_per_patch(f->hdr.patch_size));
	uint8_t *mask = malloc(P * P);
	for (uint32_t id = 0; id < f->hdr.patch_count && id < 64; id++) {
		struct relief_patch_record r;
		relief_file_record(f, id, &r);
		float e = relief_patch_select_error(f, id, &r);
		if (!(e >= 0.0f)) /* finite or infinite, never negative or NaN */
			abort();
		relief_file_block_errors(f, id, eps);
		relief_file_mask(f, id, mask);
	}
	if (f->hdr.levels <= 3) {
		uint32_t w, h;
		relief_level_extent(&f->hdr, f->hdr.levels - 1, &w, &h);
		float *heights = malloc(sizeof(float) * w * h);
		uint8_t *valid = malloc((size_t)w * h);
		if (heights && valid) {
			relief_decode_level(f, f->hdr.levels - 1, 1, heights, valid);
			relief_decode_level_drawn(f, f->hdr.levels - 1, 1, heights, valid);
		}
		free(heights);
		free(valid);
	}
	free(eps);
	free(mask);
	relief_file_close(f);
	return 0;
}
