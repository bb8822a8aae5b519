#include "log.h"

#include <stdio.h>

void relief_log(const struct relief_logger *log, enum relief_log_level level, const char *fmt, ...)
{
	if (!log || !log->fn)
		return;
	va_list ap;
	va_start(ap, fmt);
	log->fn(log->data, level, fmt, ap);
	va_end(ap);
}

void relief_log_stderr(void *data, enum relief_log_level level, const char *fmt, va_list ap)
{
	static const char *const names[] = { "error", "warning", "info", "debug" };
	const enum relief_log_level *max = data;
	if (max && level > *max)
		return;
	fprintf(stderr, "relief: %s: ", names[level]);
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
}
