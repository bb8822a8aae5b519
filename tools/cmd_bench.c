/* relief bench MODE ...: benchmarks with JSON output (docs/benchmarks.md). */
#include <stdio.h>
#include <string.h>

#include "bench.h"
#include "cli.h"

int cmd_bench(int argc, char **argv)
{
	static const struct { const char *name, *what; int (*run)(int, char **); } modes[] = {
		{ "codec", "compressed size and codec speed against the tolerance, with zstd baselines", bench_codec },
		{ "decode", "GPU decoding through the patch cache against the CPU reference decoder", bench_decode },
		{ "lod", "what accuracy costs in time: LOD against tau, with three baselines", bench_lod },
	};
	if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
		FILE *f = argc < 2 ? stderr : stdout;
		fprintf(f, "usage: relief bench MODE [ARGS] (relief bench MODE --help)\nmodes:\n");
		for (size_t i = 0; i < sizeof(modes) / sizeof(modes[0]); i++)
			fprintf(f, "  %-7s %s\n", modes[i].name, modes[i].what);
		return argc < 2 ? EXIT_USAGE : 0;
	}
	for (size_t i = 0; i < sizeof(modes) / sizeof(modes[0]); i++)
		if (!strcmp(argv[1], modes[i].name))
			return modes[i].run(argc - 1, argv + 1);
	fprintf(stderr, "relief bench: '%s' is not a mode (see 'relief bench --help')\n", argv[1]);
	return EXIT_USAGE;
}
