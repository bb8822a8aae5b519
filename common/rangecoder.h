/* Binary adaptive range coder (the LZMA family of coders): each binary decision is coded
 * with an adaptive probability (11 bits, adapted by 1/32 of the error after each bit).
 * Chosen over a multi-symbol frequency-table coder because it needs no division per
 * symbol, which keeps the CPU entropy stage of decoding well above 40 MSamples/s.
 *
 * The decoder reads only inside the buffer it was given: past the end it feeds zeros and
 * sets `overrun`, so a truncated or hostile stream yields garbage values and a flag, never
 * an out-of-bounds read. Callers check the flag (and their own value bounds). */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define RC_PROB_BITS 11
#define RC_PROB_INIT (1u << (RC_PROB_BITS - 1))
#define RC_ADAPT_SHIFT 5

typedef uint16_t rc_prob;

struct rc_encoder {
	uint64_t low;
	uint32_t range;
	uint8_t cache;
	uint64_t cache_size;
	uint8_t *buf;
	size_t size, cap;
	bool oom;
};

void rc_encoder_init(struct rc_encoder *e);
void rc_encoder_finish(struct rc_encoder *e); /* frees buf */
void rc_encode_bit(struct rc_encoder *e, rc_prob *p, unsigned bit);
/* `n` equiprobable bits, most significant first (n <= 24). */
void rc_encode_direct(struct rc_encoder *e, uint32_t value, unsigned n);
/* Flushes; afterwards buf/size hold the stream. Returns -ENOMEM if any growth failed. */
int rc_encoder_flush(struct rc_encoder *e);

struct rc_decoder {
	uint32_t range, code;
	const uint8_t *p, *end;
	bool overrun;
};

void rc_decoder_init(struct rc_decoder *d, const uint8_t *buf, size_t size);

static inline uint8_t rc_next_byte(struct rc_decoder *d)
{
	if (d->p < d->end)
		return *d->p++;
	d->overrun = true;
	return 0;
}

static inline unsigned rc_decode_bit(struct rc_decoder *d, rc_prob *p)
{
	uint32_t bound = (d->range >> RC_PROB_BITS) * *p;
	unsigned bit;
	if (d->code < bound) {
		d->range = bound;
		*p = (rc_prob)(*p + (((1u << RC_PROB_BITS) - *p) >> RC_ADAPT_SHIFT));
		bit = 0;
	} else {
		d->range -= bound;
		d->code -= bound;
		*p = (rc_prob)(*p - (*p >> RC_ADAPT_SHIFT));
		bit = 1;
	}
	/* One shift always restores range >= 2^24: probabilities stay in [31, 2017] (the
	 * adaptation stalls at those bounds), so a bit keeps at least 31/2048 > 2^-7 of a
	 * range >= 2^24. The encoder's loop therefore also shifts exactly once. */
	if (d->range < (1u << 24)) {
		d->range <<= 8;
		d->code = (d->code << 8) | rc_next_byte(d);
	}
	return bit;
}

uint32_t rc_decode_direct(struct rc_decoder *d, unsigned n);
