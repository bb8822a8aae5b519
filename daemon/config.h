/* reliefd configuration (INI, parsed with inih). Every key has a default; unknown sections
 * or keys and out-of-range values are errors that name the line, so a typo never silently
 * falls back to a default. */
#pragma once

#include <stdbool.h>
#include <stdint.h>

struct reliefd_config {
	char device[256];      /* [gpu] device: name substring, deviceUUID or render node; "" = default */
	bool validation;       /* [gpu] validation */
	uint32_t budget_mib;   /* [gpu] budget_mib: GPU memory for the patch cache */
	uint32_t decode_workers; /* [gpu] decode_workers: the cache's entropy-decoding threads */
};

#define RELIEFD_MAX_DECODE_WORKERS 8u /* = RELIEF_PATCH_CACHE_MAX_WORKERS */

void reliefd_config_defaults(struct reliefd_config *c);
/* Parses INI text over the current values. Returns 0, or -EINVAL with a message in `err`. */
int reliefd_config_parse_string(struct reliefd_config *c, const char *text, char *err, size_t err_size);
/* Same for a file; -errno when it cannot be read. */
int reliefd_config_load(struct reliefd_config *c, const char *path, char *err, size_t err_size);
