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

#ifdef __SSE2__
#include <emmintrin.h>
#endif

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

/* Restores range >= 2^24 after a step that left range >= 2^8 (at most two byte shifts),
 * without a data-dependent branch: two bytes are peeked and the shift count selects how
 * many are used. Near the end of the buffer it falls back to the bounded loop. */
static inline void rc_normalize2(struct rc_decoder *d)
{
	if (__builtin_expect(d->end - d->p >= 2, 1)) {
		unsigned sh = (d->range < (1u << 24)) + (d->range < (1u << 16));
		uint64_t c = ((uint64_t)d->code << 16 | (uint32_t)d->p[0] << 8 | d->p[1]) >> (8 * (2 - sh));
		d->code = (uint32_t)c;
		d->range <<= 8 * sh;
		d->p += sh;
		return;
	}
	while (d->range < (1u << 24)) {
		d->range <<= 8;
		d->code = (d->code << 8) | rc_next_byte(d);
	}
}

/* n raw bits, n in [0, 16], with one division and no branch on the data. */
static inline uint32_t rc_decode_bits16(struct rc_decoder *d, unsigned n)
{
	d->range >>= n;
	uint32_t part = d->code / d->range;
	uint32_t max = (1u << n) - 1;
	part = part > max ? max : part; /* only a corrupt stream exceeds it */
	d->code -= part * d->range;
	rc_normalize2(d);
	return part;
}

/* Adaptive 16-symbol model: a cumulative distribution with a fixed total of 2^14, so coding
 * needs multiplications and a short search but no division. After each symbol s the CDF
 * moves 1/2^RC_CDF_RATE of the way towards a target that puts (almost) all mass on s:
 *   t[i] = 2i for i <= s, 2^14 - 2(16 - i) for i > s.
 * Invariant (by induction, using floor rounding of the arithmetic shift): every symbol
 * keeps a frequency >= 1, because the targets are spaced >= 2 apart and each c[i] moves
 * monotonically towards t[i] without passing it. So every symbol stays codable.
 * The total of 2^14 keeps every t - c within int16, so the update vectorises. */
#define RC_CDF_BITS 14
#define RC_CDF_RATE 5

struct rc_cdf16 {
	int16_t c[16]; /* c[0] = 0 < c[1] < ... < c[15] < 2^14 (the implicit c[16]) */
};

void rc_cdf16_init(struct rc_cdf16 *m);
void rc_encode_sym16(struct rc_encoder *e, struct rc_cdf16 *m, unsigned s);

/* rc_cdf16_target[s] is the target CDF after symbol s (see above). */
extern const int16_t rc_cdf16_target[16][16];

static inline void rc_cdf16_update(struct rc_cdf16 *m, unsigned s)
{
	const int16_t *t = rc_cdf16_target[s];
#ifdef __SSE2__
	for (int h = 0; h < 16; h += 8) {
		__m128i c = _mm_loadu_si128((const __m128i *)&m->c[h]);
		__m128i d = _mm_srai_epi16(_mm_sub_epi16(_mm_loadu_si128((const __m128i *)&t[h]), c), RC_CDF_RATE);
		_mm_storeu_si128((__m128i *)&m->c[h], _mm_add_epi16(c, d));
	}
#else
	for (int i = 0; i < 16; i++)
		m->c[i] = (int16_t)(m->c[i] + ((int16_t)(t[i] - m->c[i]) >> RC_CDF_RATE));
#endif
}

/* The symbol s with c[s] <= v < c[s + 1] (c[16] = 2^14), v >= 0: branch-free. */
__attribute__((always_inline)) static inline unsigned rc_cdf16_find(const struct rc_cdf16 *m, int16_t vq)
{
#ifdef __SSE2__
	__m128i q = _mm_set1_epi16(vq);
	__m128i gt0 = _mm_cmpgt_epi16(_mm_loadu_si128((const __m128i *)&m->c[0]), q);
	__m128i gt1 = _mm_cmpgt_epi16(_mm_loadu_si128((const __m128i *)&m->c[8]), q);
	/* c is increasing, so the lanes with c > v form a suffix: the first set bit of the
	 * mask is lane s + 1 (none set: s = 15). */
	unsigned mask = (unsigned)_mm_movemask_epi8(_mm_packs_epi16(gt0, gt1));
	return (unsigned)__builtin_ctz(mask | 0x10000u) - 1u;
#else
	unsigned s = 0;
	for (int i = 1; i < 16; i++)
		s += m->c[i] <= vq;
	return s;
#endif
}

__attribute__((always_inline)) static inline unsigned rc_decode_sym16(struct rc_decoder *d, struct rc_cdf16 *m)
{
	uint32_t r = d->range >> RC_CDF_BITS;
	/* c[i] * r <= code  <=>  c[i] <= code / r: one division, then a branch-free count
	 * (c[0] = 0 always counts, so s = count - 1). A corrupt stream may give code >= range;
	 * the quotient is clamped and the result is garbage, never out of bounds. */
	uint32_t v = d->code / r;
	unsigned s = rc_cdf16_find(m, (int16_t)(v > 0x7fff ? 0x7fff : v));
	uint32_t lo = (uint32_t)m->c[s] * r;
	uint32_t hi = s == 15 ? d->range : (uint32_t)m->c[s + 1] * r;
	d->code -= lo;
	d->range = hi - lo;
	rc_normalize2(d); /* a frequency of 1 leaves range >= 2^10 */
	rc_cdf16_update(m, s);
	return s;
}
