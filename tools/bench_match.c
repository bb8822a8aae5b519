/* relief bench lod's comparison at equal measured error (bench_match.h). */
#include "bench_match.h"

#include <math.h>

int bench_match_cheapest(const struct bench_point *points, int n, double err_max)
{
	int best = -1;
	for (int i = 0; i < n; i++) {
		const struct bench_point *p = &points[i];
		if (!(p->err >= 0.0) || !(p->err <= err_max) || !isfinite(p->ms))
			continue; /* not measured, less accurate, or no time */
		if (best < 0 || p->ms < points[best].ms || (p->ms == points[best].ms && p->err < points[best].err))
			best = i;
	}
	return best;
}
