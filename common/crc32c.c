/* CRC-32C. Written here because Debian 12 packages no CRC-32C library. Two paths with one
 * result: the SSE4.2 crc32 instruction computes exactly this polynomial (three interleaved
 * streams would go further; one is enough here: the CRC is no longer visible in decoding
 * profiles), used when the CPU has it; elsewhere a table-driven loop, slicing by 8 (eight
 * bytes per step, 8 KiB of tables, built once, thread-safely, on first use). */
#include <pthread.h>
#include <stdbool.h>

#include "crc32c.h"

static uint32_t table[8][256];
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

static void table_init(void)
{
	for (uint32_t i = 0; i < 256; i++) {
		uint32_t c = i;
		for (int k = 0; k < 8; k++)
			c = c & 1 ? (c >> 1) ^ 0x82F63B78u : c >> 1;
		table[0][i] = c;
	}
	for (uint32_t i = 0; i < 256; i++)
		for (int t = 1; t < 8; t++)
			table[t][i] = (table[t - 1][i] >> 8) ^ table[0][table[t - 1][i] & 0xff];
}

uint32_t relief_crc32c_portable(uint32_t crc, const void *data, size_t size)
{
	pthread_once(&table_once, table_init);
	const uint8_t *p = data;
	crc = ~crc;
	while (size >= 8) {
		uint32_t lo = crc ^ ((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
		uint32_t hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 | (uint32_t)p[7] << 24;
		crc = table[7][lo & 0xff] ^ table[6][(lo >> 8) & 0xff] ^ table[5][(lo >> 16) & 0xff] ^ table[4][lo >> 24] ^
		      table[3][hi & 0xff] ^ table[2][(hi >> 8) & 0xff] ^ table[1][(hi >> 16) & 0xff] ^ table[0][hi >> 24];
		p += 8;
		size -= 8;
	}
	while (size--)
		crc = table[0][(crc ^ *p++) & 0xff] ^ (crc >> 8);
	return ~crc;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <nmmintrin.h>
#include <string.h>

__attribute__((target("sse4.2"))) static uint32_t crc32c_sse42(uint32_t crc, const void *data, size_t size)
{
	const uint8_t *p = data;
	uint64_t c = ~crc;
	for (; size >= 8; p += 8, size -= 8) {
		uint64_t w;
		memcpy(&w, p, 8); /* little-endian, as the instruction expects */
		c = _mm_crc32_u64(c, w);
	}
	uint32_t c32 = (uint32_t)c;
	while (size--)
		c32 = _mm_crc32_u8(c32, *p++);
	return ~c32;
}

bool relief_crc32c_hardware(void)
{
	return __builtin_cpu_supports("sse4.2");
}

uint32_t relief_crc32c(uint32_t crc, const void *data, size_t size)
{
	return relief_crc32c_hardware() ? crc32c_sse42(crc, data, size) : relief_crc32c_portable(crc, data, size);
}
#else
bool relief_crc32c_hardware(void)
{
	return false;
}

uint32_t relief_crc32c(uint32_t crc, const void *data, size_t size)
{
	return relief_crc32c_portable(crc, data, size);
}
#endif
