/* rANS with adaptive models (the rc_cdf16 models of rangecoder.h, total 2^14), plus a raw
 * bit stream, for the patch codec's hot path.
 *
 * Why rANS: decoding a symbol needs a mask, a search of the model's CDF (SIMD), one
 * multiplication and a conditional 16-bit refill, and no division, unlike range decoding.
 * The models stay adaptive: the encoder runs them forward over the symbols in decoding
 * order, records each symbol's (start, frequency), then encodes in reverse, as rANS needs.
 *
 * State x lies in [2^16, 2^32) between symbols; the encoder starts at 2^16 and the decoder
 * of a valid stream ends there with every word consumed, a cheap integrity check on top of
 * the patch CRC. Words are 16-bit little-endian. Hostile input cannot overflow: with
 * freq <= 2^14 and x >> 14 < 2^18 the update stays below 2^32, and reads past the end
 * return zeros and set `overrun`. */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rangecoder.h"

#define RANS_L (1u << 16)

/* ---- encoder side ---- */

struct rans_sym {
	uint16_t start, freq;
};

/* Symbols of one stream, recorded forward. */
struct rans_record {
	struct rans_sym *sym;
	size_t n, cap;
	bool oom;
};

static inline void rans_record_put(struct rans_record *r, struct rc_cdf16 *m, unsigned s)
{
	if (r->n == r->cap) {
		size_t cap = r->cap ? 2 * r->cap : 4096;
		struct rans_sym *ns = realloc(r->sym, cap * sizeof(*ns));
		if (!ns) {
			r->oom = true;
			rc_cdf16_update(m, s);
			return;
		}
		r->sym = ns;
		r->cap = cap;
	}
	uint16_t lo = (uint16_t)m->c[s], hi = s == 15 ? (uint16_t)(1u << RC_CDF_BITS) : (uint16_t)m->c[s + 1];
	r->sym[r->n++] = (struct rans_sym){ lo, (uint16_t)(hi - lo) };
	rc_cdf16_update(m, s);
}

/* Encodes the recorded symbols (in reverse); returns a malloc'ed buffer of 16-bit words in
 * decoding order, the final state first. */
int rans_encode(const struct rans_record *r, uint8_t **out, size_t *out_size);

struct bitwriter {
	uint64_t acc;
	unsigned n;
	uint8_t *buf;
	size_t size, cap;
	bool oom;
};

void bitwriter_put(struct bitwriter *w, uint32_t value, unsigned bits); /* bits <= 24 */
void bitwriter_flush(struct bitwriter *w);

/* ---- decoder side ---- */

struct rans_dec {
	uint32_t x;
	const uint8_t *p, *end;
	bool overrun;
};

static inline uint32_t rans_read16(struct rans_dec *d)
{
	if (__builtin_expect(d->end - d->p >= 2, 1)) {
		uint32_t w = (uint32_t)d->p[0] | (uint32_t)d->p[1] << 8;
		return w;
	}
	return 0;
}

static inline void rans_dec_init(struct rans_dec *d, const uint8_t *buf, size_t size)
{
	d->p = buf;
	d->end = buf + size;
	d->overrun = size < 4;
	uint32_t hi = rans_read16(d);
	d->p += d->end - d->p >= 2 ? 2 : 0;
	uint32_t lo = rans_read16(d);
	d->p += d->end - d->p >= 2 ? 2 : 0;
	d->x = hi << 16 | lo;
}

__attribute__((always_inline)) static inline unsigned rans_decode_sym16(struct rans_dec *d, struct rc_cdf16 *m)
{
	uint32_t slot = d->x & ((1u << RC_CDF_BITS) - 1);
	unsigned s = rc_cdf16_find(m, (int16_t)slot);
	uint32_t lo = (uint32_t)m->c[s];
	uint32_t hi = s == 15 ? (1u << RC_CDF_BITS) : (uint32_t)m->c[s + 1];
	uint32_t x = (hi - lo) * (d->x >> RC_CDF_BITS) + slot - lo;
	/* Refill without a data-dependent branch: the word is read anyway, used if needed. A
	 * refill is about as likely as not (a 16-bit word per ~1-2 symbols), so a branch would be
	 * mispredicted often; written as shifts and masks, which compilers do not turn back into
	 * one (a conditional expression here compiled to a branch). */
	uint32_t need = x < RANS_L;
	uint32_t w = rans_read16(d);
	d->overrun |= need & (d->end - d->p < 2);
	x = (x << (need << 4)) | (w & (0u - need));
	d->p += need << 1;
	d->x = x;
	rc_cdf16_update(m, s);
	return s;
}

/* True when a valid stream was decoded completely. */
static inline bool rans_dec_done(const struct rans_dec *d)
{
	return !d->overrun && d->x == RANS_L && d->p == d->end;
}

/* Bits are taken from the low end of acc, which holds n of them; p is the next byte to
 * load. Reads past the end load zeros and count them in `phantom`, so that the bits used
 * are known without a per-read counter: bitreader_consumed(). */
struct bitreader {
	uint64_t acc;
	unsigned n;
	const uint8_t *p, *end, *start;
	uint64_t phantom; /* zero bits loaded past the end */
};

static inline void bitreader_init(struct bitreader *b, const uint8_t *buf, size_t size)
{
	b->acc = 0;
	b->n = 0;
	b->p = buf;
	b->end = buf + size;
	b->start = buf;
	b->phantom = 0;
}

/* Bits read so far, and bits in the stream. */
static inline uint64_t bitreader_consumed(const struct bitreader *b)
{
	return (uint64_t)(b->p - b->start) * 8 + b->phantom - b->n;
}

static inline uint64_t bitreader_available(const struct bitreader *b)
{
	return (uint64_t)(b->end - b->start) * 8;
}

static inline uint32_t bitreader_get(struct bitreader *b, unsigned bits) /* bits <= 24 */
{
	if (b->n < bits) {
		if (__builtin_expect(b->end - b->p >= 8, 1)) {
			/* Branch-free refill to 56..63 bits from an unaligned little-endian load. */
			uint64_t w = (uint64_t)b->p[0] | (uint64_t)b->p[1] << 8 | (uint64_t)b->p[2] << 16 |
			             (uint64_t)b->p[3] << 24 | (uint64_t)b->p[4] << 32 | (uint64_t)b->p[5] << 40 |
			             (uint64_t)b->p[6] << 48 | (uint64_t)b->p[7] << 56;
			b->acc |= w << b->n;
			b->p += (63 - b->n) >> 3;
			b->n |= 56;
		} else {
			while (b->n <= 56) {
				if (b->p < b->end)
					b->acc |= (uint64_t)*b->p++ << b->n;
				else
					b->phantom += 8;
				b->n += 8;
			}
		}
	}
	uint32_t v = (uint32_t)(b->acc & ((1ull << bits) - 1));
	b->acc >>= bits;
	b->n -= bits;
	return v;
}
