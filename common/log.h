/* Logging callback shared by the libraries in common/.
 *
 * Libraries never print: they report through a struct relief_logger the caller installed.
 * A NULL logger (or a NULL fn) drops messages. Only the programs' top layers (tools/,
 * daemon/) decide where messages go.
 */
#pragma once

#include <stdarg.h>

enum relief_log_level {
	RELIEF_LOG_ERROR = 0,
	RELIEF_LOG_WARN = 1,
	RELIEF_LOG_INFO = 2,
	RELIEF_LOG_DEBUG = 3,
};

struct relief_logger {
	void (*fn)(void *data, enum relief_log_level level, const char *fmt, va_list ap);
	void *data;
};

__attribute__((format(printf, 3, 4)))
void relief_log(const struct relief_logger *log, enum relief_log_level level, const char *fmt, ...);

/* A ready logger for programs: writes "relief: LEVEL: message" lines to stderr and drops
 * messages above max_level. data must point to an enum relief_log_level (the max level). */
void relief_log_stderr(void *data, enum relief_log_level level, const char *fmt, va_list ap);
