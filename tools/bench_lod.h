/* relief bench lod's parts (tools/bench_lod.c: the command, its configurations and output;
 * bench_lod_measure.c: one configuration rendered over the flight and measured). What each
 * measure means is said at the top of bench_lod.c. */
#ifndef RELIEF_TOOLS_BENCH_LOD_H
#define RELIEF_TOOLS_BENCH_LOD_H

#include <stdbool.h>
#include <stdint.h>

#include "bench_flight.h"
#include "format.h"
#include "mesh_cover.h"
#include "mesh_diff.h"
#include "renderer.h"
#include "terrain.h"
#include "vk.h"

struct config {
	const char *method;
	double param; /* tau_px, or target_px for distance */
	struct relief_draw_options opts;
	bool reference; /* the full-resolution render: fills run.ref_err */
	bool morph;     /* the views geomorph (relief_view.morph) */
	bool loose;     /* the views' transition strips unbounded (relief_view.loose_transitions) */
	uint8_t *changed; /* --every-frame: per pair of the line, whether this method's drawn patches change */
};

/* The full grid, then up to 8 values each for relief, distance, chunked and the --unculled
 * (two), --morphed and --loose methods. */
#define MAX_CONFIGS (1 + 8 * 7)

struct result {
	double ms_median, ms_p95, select_ms, lod_ms, triangles, quads, patches, max_err, p999_err, rms_err, popping;
	/* --passes: the median of each LOD pass and of their sum over the run with pass timing */
	double pass_ms[RELIEF_LOD_PASSES], profiled_lod_ms;
	double camera_popping;
	double popping_median, popping_max; /* over the pairs: the mean above is made by a few */
	/* The pairs in which some pixel's error changed by more than POP_EVENT_PX (events), the
	 * pixels that did in all of them, and the largest single pixel's change. */
	uint32_t pop_events;
	uint64_t pop_event_pixels;
	uint64_t pop_excluded; /* pixel-pairs left out of popping as the full grid's own changes (run.pop_noise) */
	double pop_pixel_max;
	/* In those events' pairs, the quads whose factors or presence the change of LOD alone
	 * changed (mesh_diff.h); pop_quads_measured false where not measured (no capture). */
	struct mesh_quad_changes pop_quads;
	bool pop_quads_measured;
	double shade_popping;               /* colour change of the LOD change alone, 8-bit steps */
	double shade_err;                   /* colour difference from the full-resolution render */
	double max_err_3x, recheck_diff;    /* rechecked maximum (top of the file), -1 if not rechecked */
	double recheck_rms;                 /* RMS of the changes rechecks made */
	uint64_t pixels, excluded; /* pixel-frames measured, and left out as reference noise */
	uint64_t curtain;          /* pixel-frames left out as terrain-edge curtains the reference does not show there */
	uint64_t over_tau, unresolved; /* pixel-frames rechecked, and those a recheck could not resolve */
	uint32_t face_culled;          /* timed frames of the first run drawn with back faces culled */
	/* Triangle by triangle (relief_mesh_error(), over the analysed run's frames): the
	 * largest error, that of transition triangles, that of regular triangles above full
	 * resolution against the worse diagonal; transition triangles per frame; -1 where not
	 * measured (no capture on this device, or a frame drew more than run.mesh_cap triangles);
	 * the largest error of the kinds COARSE_EDGE, FINE_EDGE and FAN, and the triangles of
	 * kind OTHER or UNKNOWN over all frames */
	double mesh_max, mesh_transition, mesh_regular_worse, transitions;
	double mesh_kind[3], mesh_other;
	double mesh_seams; /* split positions and T-junctions over the frames (relief_mesh_seams()) */
	/* Where the captured triangles fall (mesh_cover.h), summed over the analysed frames
	 * (valid where mesh_max >= 0) */
	struct mesh_cover cover;
	/* --every-frame: popping, camera popping and shade popping over every pair of the line */
	struct bench_flight_mean every[3];
};
/* Triangles one frame's mesh capture holds at most (64 bytes each on the device, 96 on the
 * CPU); less where the device's storage buffers hold less (run.mesh_cap). */
#define MESH_CAP (1u << 22)

/* The full-resolution render's own error at a pixel is 0.01 px or less at 99.9 % of pixels;
 * beyond this it is rasterisation noise (see the top of the file). */
#define REF_NOISE_PX 0.1

struct run {
	struct tool_renderer gpu;
	const struct relief_file *f;
	/* the finest level, every sample's decoded height (no-data ones too), and which are
	 * valid: what the errors are measured against (relief_surface_vertical_error(),
	 * relief_mesh_error()) */
	const float *drawn;
	const uint8_t *valid;
	uint32_t fw, fh, frames;
	struct relief_view *views;
	/* the mesh capture's triangles (mesh_cap: MESH_CAP, or relief_terrain_mesh_limit() if
	 * less), or NULL when the device has no capture */
	struct relief_mesh_vertex *mesh;
	struct relief_mesh_quad *mesh_quads;
	uint32_t mesh_cap;
	/* three times the frame's width and height, for rechecks; recheck_all: every pixel */
	struct relief_vk_target fine;
	bool recheck_all;
	bool trace_events; /* each popping event's changed quads to stderr */
	/* --every-frame: pair i is the line's pair flight_at[i] (frames flight_at[i] and + 1), of
	 * flight_pairs; flight_sampled[i]: in the even sample (bench_flight.h). NULL otherwise. */
	const uint32_t *flight_at;
	const uint8_t *flight_sampled;
	uint32_t flight_pairs;
	/* |error| in px per frame and pixel of the reference render (NaN: no terrain), or NULL
	 * while the reference itself is measured */
	float *ref_err;
	/* per pair and pixel: the full-resolution render's own error changed there by more than
	 * POP_EVENT_PX between the frozen and the own frame (its level of detail never changes:
	 * the rasteriser, drawing from the other camera's origin); left out of every other
	 * method's popping */
	uint8_t *pop_noise;
	/* the reference render's pictures and depths per frame (RGBA8, reversed Z), for
	 * shade_err */
	uint8_t *ref_rgba;
	float *ref_depth;
};

/* Per frame of one run (2 x run.frames): GPU ms, the LOD compute's and the selection's
 * part of it, and with `pass` non-NULL (the frames then drawn with pass timing) each LOD
 * pass's, pass by pass (pass p of frame i at p x 2 x run.frames + i). */
struct frame_times {
	double *ms, *sel, *lod, *pass;
};

/* Pose `pose` as configuration c draws it: the tessellator's tau, morphing, strips. */
struct relief_view bench_lod_config_view(const struct config *c, const struct relief_view *pose);

/* Renders the flight once with configuration c; the times of its timed frames go to *t.
 * With `analyse`, also the errors and popping (into *res). Negative errno on failure. */
int bench_lod_measure(struct run *r, const struct config *c, bool analyse, const struct frame_times *t,
                      struct result *res);

#endif
