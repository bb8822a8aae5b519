/* The benchmark flight of `relief bench lod`, and popping over every frame of it
 * (--every-frame).
 *
 * The flight is a straight, low line across the terrain's middle, north-east over a tenth
 * of the map, looking ahead and down, flown at BENCH_FLIGHT_SPEED and seen at
 * BENCH_FRAME_RATE. The usual benchmark takes key poses along it, each with the frame
 * after it (a pair), which samples the popping between consecutive frames at a few places.
 * A method whose level of detail changes in a small share of frames (chunked LOD: its
 * selection changes in about 0.1 % of them) has none of its changes in such a sample, and
 * its popping comes out as the measure's floor however large those changes are.
 *
 * With --every-frame the flight is every frame of the line. Each method's level of detail
 * is chosen for all of them in order (drawing nothing: relief_draw_options.lod_only), so
 * that its view's hysteresis is the one a real flight has, and the pairs whose drawn
 * patches change are its LOD-change pairs. The pairs measured are every method's
 * LOD-change pairs and an even sample of all pairs; a method's popping over the flight is
 * then the stratified mean: its LOD-change pairs counted once each, its other pairs by the
 * sampled ones that are not LOD-change pairs of its own, each standing for (pairs -
 * LOD-change pairs) / that many. Unbiased for any per-pair quantity (the sample is
 * systematic, from a fixed offset); the standard error is the sampled stratum's. Changes
 * of the fine level of detail alone (block factors) do not make a LOD-change pair: they are
 * in the sampled stratum. */
#pragma once

#include <stdbool.h>
#include <stdint.h>

#include "lod.h"

struct relief_file;
struct relief_terrain;
struct relief_terrain_view;
struct relief_draw_options;

#define BENCH_FLIGHT_SPEED 250.0 /* m/s */
#define BENCH_FRAME_RATE 60.0    /* Hz */

/* The camera at t along the flight of `keys` key poses: key pose i at t = i, the line's
 * end at t = keys (so keys = 1 measures t as a share of the line). It starts a fraction of
 * a sample off the patch grid, away from the planes of patch borders. tau 1. */
struct relief_view bench_flight_view(const struct relief_file *f, uint32_t w, uint32_t h, uint32_t keys, double t);
/* One frame's step along the flight of `keys` key poses, in its t. */
double bench_flight_step(const struct relief_file *f, uint32_t keys);

/* Frames of the whole line, one frame step apart (pairs: one fewer). */
uint32_t bench_flight_frames(const struct relief_file *f);
/* Frame j's camera, with view's tau, morph and transitions (its pose ignored). */
struct relief_view bench_flight_frame_view(const struct relief_file *f, const struct relief_view *like, uint32_t j);

/* Chooses the level of detail of frames [from, to) in order with `opts` and lod_only for
 * view tv, carrying its hysteresis along the line (from 0: frame 0 twice, as
 * a view's first frame settles). 0 or a negative errno. */
int bench_flight_replay(const struct relief_file *f, struct relief_terrain *t, struct relief_terrain_view *tv,
                       const struct relief_view *like, const struct relief_draw_options *opts, uint32_t from,
                       uint32_t to);
/* The same over the whole line for a new view tv, marking in changed[] (one byte per
 * pair) the pairs j - 1 where frame j draws other patches than frame j - 1. */
int bench_flight_events(const struct relief_file *f, struct relief_terrain *t, struct relief_terrain_view *tv,
                       const struct relief_view *like, const struct relief_draw_options *opts, uint8_t *changed);

/* The pairs to measure: every pair some method's `changed` marks (n arrays of pairs
 * bytes) and `sample` pairs evenly spread, ascending, at most cap: their first frames go to
 * at[], and sampled[k] says whether at[k] is in the even sample. Returns their count, or
 * -E2BIG when more than cap are needed. */
int bench_flight_choose(uint32_t pairs, const uint8_t *const *changed, uint32_t n, uint32_t sample, uint32_t *at,
                       uint8_t *sampled, uint32_t cap);

/* A method's stratified mean over the line's pairs of a per-pair value (v[k] for chosen
 * pair at[k]; NaN where not measured: no terrain in view) and its standard error. */
struct bench_flight_mean {
	double mean, se;
	uint32_t events;  /* LOD-change pairs: those whose drawn patches change, all measured */
	uint32_t sampled; /* sampled pairs standing for the rest */
};
struct bench_flight_mean bench_flight_mean(uint32_t pairs, const uint8_t *changed, const uint32_t *at,
                                         const uint8_t *sampled, uint32_t chosen, const double *v);
