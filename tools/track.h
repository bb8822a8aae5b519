/* Flight tracks for `relief fly`: camera keys in time, sampled at a frame rate.
 *
 * Text format, one key per line:
 *   t x y z heading pitch roll
 * t in seconds, strictly increasing; x, y, z world metres (the file's coordinates, as in
 * relief snap); heading in degrees clockwise from north (+y) towards east (+x); pitch in
 * degrees up from the horizontal, within [-90, 90]; roll in degrees, an aircraft's right
 * bank (relief_view.roll). Numbers are separated by spaces, tabs or one comma (with blanks
 * around it if wanted; an empty comma-separated field is an error); '#' starts a comment;
 * blank lines are skipped. This is the pose record an image generator receives
 * from a flight model, so a recorded flight can be replayed as it is. */
#pragma once

#include <stddef.h>

#include "lod.h"

struct track_key {
	double t, x, y, z, heading, pitch, roll;
};

struct track {
	struct track_key *keys; /* n >= 1, t strictly increasing */
	size_t n;
};

#define TRACK_MAX_KEYS 1000000u
/* |x|, |y|, |z| of a key at most (metres): its views, look point 1 km ahead included, then
 * stay within RELIEF_VIEW_MAX_COORD. */
#define TRACK_MAX_COORD 1e11
#define TRACK_MAX_BYTES (64u << 20)

/* Parses len bytes of text (need not be NUL-terminated). 0, or -EINVAL with a message naming
 * the line and the problem in err (a bad number, a wrong count, time not increasing, pitch
 * out of range, a position beyond TRACK_MAX_COORD, no keys, too many keys), or -ENOMEM. *out is untouched on error. */
int track_parse(const char *text, size_t len, struct track *out, char *err, size_t errlen);
/* Reads and parses a file (at most TRACK_MAX_BYTES). Errors as track_parse, or -errno of
 * opening or reading it, with a message. */
int track_load(const char *path, struct track *out, char *err, size_t errlen);
/* Frees the keys; accepts a zeroed or finished track. */
void track_finish(struct track *t);

/* The pose at time `time` (clamped to the track's ends): position and pitch linear between
 * the two keys around it, heading and roll along the shorter way round. */
void track_at(const struct track *t, double time, struct track_key *out);

/* Sets v's eye, target and roll from a key (the rest of v is left alone). Pitch is kept
 * within 1e-4 degrees of the vertical, so that heading still says where the top of the
 * picture points when looking straight down or up (relief_view_axes()). */
void track_key_view(const struct track_key *k, struct relief_view *v);

/* Channel `yaw` radians to the right of `centre` in the camera's own frame (a multi-channel
 * image generator's side windows): turned about centre's up axis, so a banked aircraft's
 * side channels bank with it. out is centre with eye, target and roll replaced. */
void track_channel_view(const struct relief_view *centre, double yaw, struct relief_view *out);
