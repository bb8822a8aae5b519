/* The import sidecar parser (INPUT.relief-import). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "import_opts.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *text = malloc(size + 1);
	memcpy(text, data, size);
	text[size] = '\0';
	struct dem_import_options o;
	int line;
	FILE *saved = stderr; /* import_option reports bad values on stderr; keep the log short */
	stderr = fopen("/dev/null", "w");
	import_sidecar_parse("fuzz", text, &o, &line);
	fclose(stderr);
	stderr = saved;
	free(text);
	return 0;
}
