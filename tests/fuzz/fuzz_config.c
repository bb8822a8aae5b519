/* reliefd's INI configuration parser. */
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *text = malloc(size + 1);
	memcpy(text, data, size);
	text[size] = '\0';
	struct reliefd_config c;
	char err[256];
	reliefd_config_defaults(&c);
	reliefd_config_parse_string(&c, text, err, sizeof(err));
	free(text);
	return 0;
}
