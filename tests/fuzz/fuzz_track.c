/* The flight track parser of relief fly (tools/track.c), and what is made of a parsed track:
 * poses sampled along it, their views and side channels. A parsed track must give finite
 * poses and views that relief_view_check() accepts. */
#include <math.h>
#include <stdlib.h>

#include "fuzz.h"
#include "track.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct track t;
	char err[256];
	if (track_parse((const char *)data, size, &t, err, sizeof(err)) < 0)
		return 0;
	double t0 = t.keys[0].t, t1 = t.keys[t.n - 1].t;
	for (int i = 0; i <= 8; i++) {
		struct track_key k;
		track_at(&t, t0 + (t1 - t0) * i / 8.0, &k);
		struct relief_view v = { .fovy = 1, .width = 64, .height = 36, .znear = 1, .zfar = 1e9, .tau = 1 };
		track_key_view(&k, &v);
		struct relief_view side;
		track_channel_view(&v, 0.7, &side);
		const char *why;
		/* Keys within TRACK_MAX_COORD give valid views, look point and side channels included. */
		if (relief_view_check(&v, &why) < 0 || relief_view_check(&side, &why) < 0)
			abort();
	}
	track_finish(&t);
	return 0;
}
