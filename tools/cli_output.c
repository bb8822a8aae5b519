/* Writing a command's outputs without losing what is already stored: an output may not
 * be one of the command's inputs (or another of its outputs) under any name, and a file
 * is written beside its final name and renamed over it only when complete. */
#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"

/* Where path would live: its inode if it exists, otherwise its canonical name (the real
 * path of its directory and its base name). */
struct file_key {
	bool exists;
	dev_t dev;
	ino_t ino;
	char name[2 * PATH_MAX + 2];
};

static void file_key(const char *path, struct file_key *k)
{
	struct stat st;
	memset(k, 0, sizeof(*k));
	if (stat(path, &st) == 0) {
		k->exists = true;
		k->dev = st.st_dev;
		k->ino = st.st_ino;
		return;
	}
	char dir[PATH_MAX], base[PATH_MAX], real[PATH_MAX];
	snprintf(dir, sizeof(dir), "%s", path);
	snprintf(base, sizeof(base), "%s", path);
	if (realpath(dirname(dir), real))
		snprintf(k->name, sizeof(k->name), "%s/%s", real, basename(base));
	else
		snprintf(k->name, sizeof(k->name), "%s", path);
}

static bool same_file(const struct file_key *a, const struct file_key *b)
{
	if (a->exists != b->exists)
		return false;
	return a->exists ? a->dev == b->dev && a->ino == b->ino : strcmp(a->name, b->name) == 0;
}

/* The first of paths[from..n) (NULL entries skipped) that is the file k names, or NULL. */
static const char *same_as(const struct file_key *k, const char *const *paths, size_t from, size_t n)
{
	struct file_key other;
	for (size_t i = from; i < n; i++) {
		if (!paths[i])
			continue;
		file_key(paths[i], &other);
		if (same_file(k, &other))
			return paths[i];
	}
	return NULL;
}

bool cli_outputs_ok(const char *cmd, const char *const *outs, size_t nouts, const char *const *ins, size_t nins)
{
	for (size_t o = 0; o < nouts; o++) {
		if (!outs[o])
			continue;
		struct file_key k;
		file_key(outs[o], &k);
		const char *in = same_as(&k, ins, 0, nins), *out = same_as(&k, outs, o + 1, nouts);
		if (in)
			fprintf(stderr, "relief %s: %s is the input %s: writing it would destroy it\n", cmd, outs[o], in);
		else if (out)
			fprintf(stderr, "relief %s: %s and %s are one file: each output needs its own\n", cmd, outs[o], out);
		if (in || out)
			return false;
	}
	return true;
}

int cli_replace_begin(const char *out, char **tmp)
{
	size_t n = strlen(out) + 16;
	*tmp = malloc(n);
	if (!*tmp)
		return -ENOMEM;
	snprintf(*tmp, n, "%s.tmpXXXXXX", out);
	int fd = mkostemp(*tmp, O_CLOEXEC);
	if (fd < 0) {
		int e = errno;
		free(*tmp);
		*tmp = NULL;
		return -e;
	}
	/* mkostemp makes it 0600; what the final file would get under the umask */
	mode_t mask = umask(0);
	umask(mask);
	int ret = fchmod(fd, 0666 & ~mask) < 0 ? -errno : 0;
	close(fd);
	if (ret < 0) {
		unlink(*tmp);
		free(*tmp);
		*tmp = NULL;
	}
	return ret;
}

int cli_replace_end(char *tmp, const char *out, int ret)
{
	if (!tmp)
		return ret;
	if (ret == 0 && rename(tmp, out) < 0)
		ret = -errno;
	if (ret < 0)
		unlink(tmp);
	free(tmp);
	return ret;
}
