/* "At equal measured error" (relief bench lod): for one configuration of relief's LOD, the
 * baseline configuration to compare it with is that baseline's cheapest one whose measured
 * error is no larger. A baseline run at a few parameters seldom lands on relief's error
 * exactly; taking its cheapest configuration that is at least as accurate never flatters
 * relief (a configuration with a larger error is never chosen, however cheap). */
#pragma once

/* One measured configuration: its largest error (pixels; NaN or negative where not measured)
 * and its median frame time (ms). */
struct bench_point {
	double err, ms;
};

/* The index in points[0 .. n) of the point with the least ms among those whose err is at
 * most err_max (ties: the smaller err, then the first), or -1 when none is. */
int bench_match_cheapest(const struct bench_point *points, int n, double err_max);
