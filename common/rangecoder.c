#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "rangecoder.h"

void rc_encoder_init(struct rc_encoder *e)
{
	memset(e, 0, sizeof(*e));
	e->range = 0xffffffffu;
	e->cache_size = 1;
}

void rc_encoder_finish(struct rc_encoder *e)
{
	free(e->buf);
	memset(e, 0, sizeof(*e));
}

static void put_byte(struct rc_encoder *e, uint8_t b)
{
	if (e->size == e->cap) {
		size_t cap = e->cap ? e->cap * 2 : 4096;
		uint8_t *nb = realloc(e->buf, cap);
		if (!nb) {
			e->oom = true;
			return;
		}
		e->buf = nb;
		e->cap = cap;
	}
	e->buf[e->size++] = b;
}

/* Carry propagation: bytes equal to 0xff are held back (cache_size) until a carry is known. */
static void shift_low(struct rc_encoder *e)
{
	if ((uint32_t)e->low < 0xff000000u || (e->low >> 32) != 0) {
		uint8_t carry = (uint8_t)(e->low >> 32);
		uint8_t temp = e->cache;
		do {
			put_byte(e, (uint8_t)(temp + carry));
			temp = 0xff;
		} while (--e->cache_size != 0);
		e->cache = (uint8_t)(e->low >> 24);
	}
	e->cache_size++;
	e->low = (e->low & 0x00ffffffu) << 8;
}

void rc_encode_bit(struct rc_encoder *e, rc_prob *p, unsigned bit)
{
	uint32_t bound = (e->range >> RC_PROB_BITS) * *p;
	if (!bit) {
		e->range = bound;
		*p = (rc_prob)(*p + (((1u << RC_PROB_BITS) - *p) >> RC_ADAPT_SHIFT));
	} else {
		e->low += bound;
		e->range -= bound;
		*p = (rc_prob)(*p - (*p >> RC_ADAPT_SHIFT));
	}
	while (e->range < (1u << 24)) {
		e->range <<= 8;
		shift_low(e);
	}
}

/* Raw bits go in chunks of up to 16: the range is split into 2^n equal parts. */
void rc_encode_direct(struct rc_encoder *e, uint32_t value, unsigned n)
{
	while (n) {
		unsigned k = n > 16 ? 16 : n;
		n -= k;
		e->range >>= k;
		e->low += (uint64_t)((value >> n) & ((1u << k) - 1)) * e->range;
		while (e->range < (1u << 24)) {
			e->range <<= 8;
			shift_low(e);
		}
	}
}

int rc_encoder_flush(struct rc_encoder *e)
{
	for (int i = 0; i < 5; i++)
		shift_low(e);
	return e->oom ? -ENOMEM : 0;
}

void rc_decoder_init(struct rc_decoder *d, const uint8_t *buf, size_t size)
{
	d->p = buf;
	d->end = buf + size;
	d->overrun = false;
	d->range = 0xffffffffu;
	d->code = 0;
	for (int i = 0; i < 5; i++)
		d->code = (d->code << 8) | rc_next_byte(d);
}

uint32_t rc_decode_direct(struct rc_decoder *d, unsigned n)
{
	uint32_t v = 0;
	while (n) {
		unsigned k = n > 16 ? 16 : n;
		n -= k;
		d->range >>= k;
		uint32_t part = d->code / d->range;
		if (part >= (1u << k)) /* only in a corrupt stream */
			part = (1u << k) - 1;
		d->code -= part * d->range;
		v = (v << k) | part;
		while (d->range < (1u << 24)) {
			d->range <<= 8;
			d->code = (d->code << 8) | rc_next_byte(d);
		}
	}
	return v;
}

/* Lane 0 stays 0: its target is 0 and it starts at 0. */
#define T(i, s) (int16_t)((i) <= (s) ? 2 * (i) : (1 << RC_CDF_BITS) - 2 * (16 - (i)))
#define ROW(s) { T(0, s), T(1, s), T(2, s), T(3, s), T(4, s), T(5, s), T(6, s), T(7, s), \
                 T(8, s), T(9, s), T(10, s), T(11, s), T(12, s), T(13, s), T(14, s), T(15, s) }
const int16_t rc_cdf16_target[16][16] = {
	ROW(0), ROW(1), ROW(2), ROW(3), ROW(4), ROW(5), ROW(6), ROW(7),
	ROW(8), ROW(9), ROW(10), ROW(11), ROW(12), ROW(13), ROW(14), ROW(15),
};
#undef ROW
#undef T

void rc_cdf16_init(struct rc_cdf16 *m)
{
	for (unsigned i = 0; i < 16; i++)
		m->c[i] = (int16_t)(i << (RC_CDF_BITS - 4));
}

void rc_encode_sym16(struct rc_encoder *e, struct rc_cdf16 *m, unsigned s)
{
	uint32_t r = e->range >> RC_CDF_BITS;
	uint32_t lo = (uint32_t)m->c[s] * r;
	uint32_t hi = s == 15 ? e->range : (uint32_t)m->c[s + 1] * r;
	e->low += lo;
	e->range = hi - lo;
	while (e->range < (1u << 24)) {
		e->range <<= 8;
		shift_low(e);
	}
	rc_cdf16_update(m, s);
}
