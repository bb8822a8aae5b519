/* Little-endian loads and stores that work on any host and any alignment. */
#pragma once

#include <stdint.h>
#include <string.h>

static inline void le_put_u32(uint8_t *p, uint32_t v)
{
	p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); p[2] = (uint8_t)(v >> 16); p[3] = (uint8_t)(v >> 24);
}

static inline uint32_t le_get_u32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline void le_put_u64(uint8_t *p, uint64_t v)
{
	le_put_u32(p, (uint32_t)v);
	le_put_u32(p + 4, (uint32_t)(v >> 32));
}

static inline uint64_t le_get_u64(const uint8_t *p)
{
	return (uint64_t)le_get_u32(p) | (uint64_t)le_get_u32(p + 4) << 32;
}

static inline void le_put_f64(uint8_t *p, double v)
{
	uint64_t u;
	memcpy(&u, &v, 8);
	le_put_u64(p, u);
}

static inline double le_get_f64(const uint8_t *p)
{
	uint64_t u = le_get_u64(p);
	double v;
	memcpy(&v, &u, 8);
	return v;
}

static inline void le_put_f32(uint8_t *p, float v)
{
	uint32_t u;
	memcpy(&u, &v, 4);
	le_put_u32(p, u);
}

static inline float le_get_f32(const uint8_t *p)
{
	uint32_t u = le_get_u32(p);
	float v;
	memcpy(&v, &u, 4);
	return v;
}
