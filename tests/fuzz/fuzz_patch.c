/* The patch stream decoder and the mask decoder on arbitrary bytes. The first byte picks
 * the case: bit 0 root or child, bits 1-2 quadrant, bit 3 ratio 2 or 3, bit 4 mask, bit 5
 * a window (format version 3) given by the next three bytes: x1, y1, and the ring flags
 * (bit 0 west, bit 1 north); x0 = y0 = 0 for the root, -1 otherwise. */
#include <stdlib.h>
#include <string.h>

#include "codec.h"
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 1)
		return 0;
	uint8_t sel = data[0];
	data++;
	size--;
	struct relief_window win, *wp = NULL;
	if (sel & 32) {
		if (size < 3)
			return 0;
		int32_t start = (sel & 1) ? 0 : -1; /* the root's windows start at 0 */
		win = (struct relief_window){ start, start, data[0], data[1], data[2] & 1, (data[2] & 2) != 0 };
		wp = &win;
		data += 3;
		size -= 3;
	}
	struct relief_patch_geom g;
	relief_patch_geom_init(&g, 65);
	size_t EE = (size_t)g.E * g.E;
	if (sel & 16) {
		uint8_t *mask = malloc(65 * 65);
		relief_mask_decode(65, data, size, mask);
		free(mask);
		return 0;
	}
	int8_t *labels = malloc(g.n_labels);
	int32_t *res = malloc(sizeof(int32_t) * EE);
	int32_t *parent = calloc(EE, sizeof(int32_t));
	int32_t *out = malloc(sizeof(int32_t) * EE);
	bool root = sel & 1;
	if (relief_patch_decode_symbols(&g, root, wp, data, size, labels, res) == 0) {
		if (root)
			relief_root_reconstruct(&g, res, out);
		else
			relief_patch_reconstruct(&g, sel & 8 ? 3 : 2, (sel >> 1) & 3, parent, labels, res, out);
	}
	free(labels);
	free(res);
	free(parent);
	free(out);
	return 0;
}
