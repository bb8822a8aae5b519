#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "rans.h"

int rans_encode(const struct rans_record *r, uint8_t **out, size_t *out_size)
{
	if (r->oom)
		return -ENOMEM;
	/* At most one word per symbol, plus the final state. */
	uint16_t *words = malloc(sizeof(uint16_t) * (r->n + 2));
	if (!words)
		return -ENOMEM;
	size_t nw = 0;
	uint32_t x = RANS_L;
	for (size_t i = r->n; i-- > 0;) {
		uint32_t freq = r->sym[i].freq;
		/* Keep x / freq * 2^14 + ... below 2^32: x < freq << (32 - 14). One word always
		 * suffices because x < 2^32 and the bound is at least 2^18. */
		if (x >= freq << (32 - RC_CDF_BITS)) {
			words[nw++] = (uint16_t)x;
			x >>= 16;
		}
		x = ((x / freq) << RC_CDF_BITS) + (x % freq) + r->sym[i].start;
	}
	words[nw++] = (uint16_t)x;
	words[nw++] = (uint16_t)(x >> 16);
	uint8_t *buf = malloc(2 * nw);
	if (!buf) {
		free(words);
		return -ENOMEM;
	}
	/* Emitted last-to-first; the decoder reads first-to-last. */
	for (size_t i = 0; i < nw; i++) {
		uint16_t w = words[nw - 1 - i];
		buf[2 * i] = (uint8_t)w;
		buf[2 * i + 1] = (uint8_t)(w >> 8);
	}
	free(words);
	*out = buf;
	*out_size = 2 * nw;
	return 0;
}

static void bitwriter_byte(struct bitwriter *w, uint8_t b)
{
	if (w->size == w->cap) {
		size_t cap = w->cap ? 2 * w->cap : 1024;
		uint8_t *nb = realloc(w->buf, cap);
		if (!nb) {
			w->oom = true;
			return;
		}
		w->buf = nb;
		w->cap = cap;
	}
	w->buf[w->size++] = b;
}

void bitwriter_put(struct bitwriter *w, uint32_t value, unsigned bits)
{
	w->acc |= (uint64_t)(value & ((1ull << bits) - 1)) << w->n;
	w->n += bits;
	while (w->n >= 8) {
		bitwriter_byte(w, (uint8_t)w->acc);
		w->acc >>= 8;
		w->n -= 8;
	}
}

void bitwriter_flush(struct bitwriter *w)
{
	if (w->n)
		bitwriter_byte(w, (uint8_t)w->acc);
	w->acc = 0;
	w->n = 0;
}
