/* Table-driven CRC-32C, byte at a time. Written here because Debian 12 packages no
 * CRC-32C library; the table is built once, thread-safely, on first use. */
#include <pthread.h>

#include "crc32c.h"

static uint32_t table[256];
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

static void table_init(void)
{
	for (uint32_t i = 0; i < 256; i++) {
		uint32_t c = i;
		for (int k = 0; k < 8; k++)
			c = c & 1 ? (c >> 1) ^ 0x82F63B78u : c >> 1;
		table[i] = c;
	}
}

uint32_t relief_crc32c(uint32_t crc, const void *data, size_t size)
{
	pthread_once(&table_once, table_init);
	const uint8_t *p = data;
	crc = ~crc;
	while (size--)
		crc = table[(crc ^ *p++) & 0xff] ^ (crc >> 8);
	return ~crc;
}
