/* relief: the command-line front end. Thin: parses the subcommand and hands over. */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "heap.h"
#include "relief_version.h"

static const struct relief_command commands[] = {
	{ "pack", "compress an elevation model into a .relief file", cmd_pack },
	{ "unpack", "write the reconstructed heights of one level", cmd_unpack },
	{ "info", "describe a .relief file", cmd_info },
	{ "snap", "render one frame of a .relief file headless", cmd_snap },
	{ "fly", "fly a camera along a track through a cold GPU cache and report the frames", cmd_fly },
	{ "bench", "measure the codec, GPU decoding and the LOD, with JSON output", cmd_bench },
	{ "hello", "render a displaced, tessellated test grid headless to a PNG", cmd_hello },
};

static void usage(FILE *f)
{
	fprintf(f, "usage: relief [--version] [--help] COMMAND [ARGS]\n\ncommands:\n");
	for (size_t i = 0; i < sizeof(commands) / sizeof(commands[0]); i++)
		fprintf(f, "  %-8s %s\n", commands[i].name, commands[i].summary);
	fprintf(f, "\n'relief COMMAND --help' describes one command.\n");
}

int main(int argc, char **argv)
{
	relief_heap_keep_freed(); /* the driver's per-draw buffers stay mapped (heap.h) */
	const char *level = getenv("RELIEF_LOG");
	if (level) {
		static const char *const names[] = { "error", "warn", "info", "debug" };
		int i = 0;
		while (i < 4 && strcmp(level, names[i]) != 0)
			i++;
		if (i < 4)
			cli_log_set_level((enum relief_log_level)i);
		else
			fprintf(stderr, "relief: RELIEF_LOG='%s' is not error, warn, info or debug: logging at warn\n", level);
	}
	if (argc < 2) {
		usage(stderr);
		return EXIT_USAGE;
	}
	bool version = strcmp(argv[1], "--version") == 0, help = strcmp(argv[1], "--help") == 0 || !strcmp(argv[1], "-h");
	if ((version || help) && argc > 2) {
		fprintf(stderr, "relief: %s takes nothing after it (got '%s')\n", argv[1], argv[2]);
		return EXIT_USAGE;
	}
	if (version) {
		printf("relief %s\n", RELIEF_VERSION);
		return 0;
	}
	if (help) {
		usage(stdout);
		return 0;
	}
	for (size_t i = 0; i < sizeof(commands) / sizeof(commands[0]); i++)
		if (strcmp(argv[1], commands[i].name) == 0)
			return commands[i].run(argc - 1, argv + 1);
	fprintf(stderr, "relief: '%s' is not a command (see 'relief --help')\n", argv[1]);
	return EXIT_USAGE;
}
