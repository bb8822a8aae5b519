/* Shared plumbing of the `relief` subcommands. Each subcommand is a function
 * int cmd_NAME(int argc, char **argv) returning the process exit status:
 * 0 success, 1 failure while working, 2 bad usage (unknown option, bad argument). */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "log.h"

#define EXIT_USAGE 2

/* What snap and fly print for the triangle count on a device without pipeline statistics
 * (GPU-assisted validation turns them off), not 0; test_cli looks for it. */
#define CLI_TRIANGLES_UNCOUNTED "triangles not counted (no pipeline statistics)"
/* And for GPU times on a queue without timestamps (timestampValidBits 0). */
#define CLI_GPU_UNTIMED "GPU time not measured (no timestamps on this queue)"

struct relief_command {
	const char *name;
	const char *summary;
	int (*run)(int argc, char **argv);
};

/* The program's logger: stderr, level from -v/--verbose or RELIEF_LOG (error|warn|info|debug). */
extern struct relief_logger cli_log;
void cli_log_set_level(enum relief_log_level level);

/* Argument parsers: return false (after printing "relief CMD: OPTION: why") on bad input.
 * Whole numbers and sizes are plain digits: no sign, no spaces, no leading "+". */
bool cli_parse_double(const char *cmd, const char *opt, const char *s, double *out);
bool cli_parse_u32(const char *cmd, const char *opt, const char *s, uint32_t min, uint32_t max, uint32_t *out);
/* WIDTHxHEIGHT, both in [1, max]. */
bool cli_parse_dims(const char *cmd, const char *opt, const char *s, uint32_t max, uint32_t *w, uint32_t *h);
/* A viewport: cli_parse_dims() with the viewport's limit, 16384 pixels a side. */
bool cli_parse_size(const char *cmd, const char *opt, const char *s, uint32_t *w, uint32_t *h);
bool cli_parse_vec3(const char *cmd, const char *opt, const char *s, double out[3]);
/* Comma-separated finite numbers, each in [min, max]: 1 to cap of them into out[], *n the
 * count. Refused: an empty value (no two commas in a row, none at either end), more than
 * cap values, anything cli_parse_double() refuses. After a refusal out[] and *n are
 * unspecified. */
bool cli_parse_list(const char *cmd, const char *opt, const char *s, double min, double max, double *out,
                    uint32_t cap, uint32_t *n);
/* The usage error for getopt_long's ':' (missing value) or '?' (unknown option) return,
 * run with opterr = 0 and an optstring starting with ':'. Prints it and returns EXIT_USAGE. */
int cli_option_error(const char *cmd, int c, char **argv);
/* Writes s as a JSON string, quotes included (", \\ and control characters escaped). */
void cli_json_string(FILE *f, const char *s);
/* False (after printing why) when an output would overwrite one of the inputs, being the
 * same file under any name, or two outputs are one file; NULL entries are skipped
 * (options not given). Check before writing anything. */
bool cli_outputs_ok(const char *cmd, const char *const *outs, size_t nouts, const char *const *ins, size_t nins);
/* Replacing `out` only once its new content is complete: cli_replace_begin() creates an
 * empty file beside it (*tmp, to be written by any means), cli_replace_end() renames it
 * over `out` if ret is 0, removes it otherwise, frees *tmp and returns ret or -errno. */
int cli_replace_begin(const char *out, char **tmp);
int cli_replace_end(char *tmp, const char *out, int ret);
/* Creates the parent directory of `path` if needed (one level, like out/). */
int cli_make_parent_dir(const char *path);

/* Writes RGBA8 pixels (row-major from the top row) as an 8-bit RGB PNG. 0 or -errno. */
int png_write_rgba(const char *path, const uint8_t *rgba, uint32_t width, uint32_t height);

int cmd_hello(int argc, char **argv);
int cmd_pack(int argc, char **argv);
int cmd_unpack(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_snap(int argc, char **argv);
int cmd_fly(int argc, char **argv);
