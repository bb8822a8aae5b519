/* CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), as used by iSCSI, ext4 and
 * Btrfs. Check value: crc32c("123456789") == 0xE3069283. */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* The fastest path this CPU has (the SSE4.2 instruction on x86-64, else the table). */
uint32_t relief_crc32c(uint32_t crc, const void *data, size_t size);

/* The table-driven path alone, and whether relief_crc32c() uses the instruction: for tests
 * that hold the two paths to the same results. */
uint32_t relief_crc32c_portable(uint32_t crc, const void *data, size_t size);
bool relief_crc32c_hardware(void);
