/* CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), as used by iSCSI, ext4 and
 * Btrfs. Check value: crc32c("123456789") == 0xE3069283. */
#pragma once

#include <stddef.h>
#include <stdint.h>

uint32_t relief_crc32c(uint32_t crc, const void *data, size_t size);
