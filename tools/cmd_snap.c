/* relief snap FILE.relief --camera X,Y,Z --look X,Y,Z ...: one frame rendered in-process
 * through the GPU cache, compute LOD and indirect tessellated draws. Patches are decoded
 * until the view asks for no more; that frame is drawn once more, warm, and written. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "decode.h"
#include "format.h"
#include "le.h"
#include "lod.h"
#include "mesh_error.h"
#include "mesh_seams.h"
#include "patch_cache.h"
#include "renderer.h"
#include "terrain.h"
#include "vk.h"

static void snap_usage(FILE *f)
{
	fprintf(f,
		"usage: relief snap FILE.relief --camera X,Y,Z --look X,Y,Z -o OUT.png [options]\n"
		"Renders one frame headless. Positions are world coordinates (metres; see relief info).\n"
		"  -o, --output FILE    PNG to write\n"
		"      --camera X,Y,Z   eye position\n"
		"      --look X,Y,Z     a point the camera looks at\n"
		"      --roll DEG       bank about the viewing direction, positive to the right (default 0);\n"
		"                       looking straight down or up, north is at the top at roll 0\n"
		"      --fov DEG        vertical field of view (default 50)\n"
		"      --size WxH       viewport (default 1280x720)\n"
		"      --tau PX         screen-space error threshold in pixels (default 1)\n"
		"      --wire           overlay the wireframe\n"
		"      --morph          geomorph changes of level (a blend, not a pop; finer levels: more triangles)\n"
		"      --loose          leave the tessellator's transition strips unbounded: fewer\n"
		"                       triangles, which may exceed tau (docs/lod.md)\n"
		"      --depth FILE     distance along the view axis per pixel: little-endian float32,\n"
		"                       row-major from the top row, +infinity where no terrain is seen\n"
		"      --exact          also measure the frame triangle by triangle against the finest\n"
		"                       decoded surface (decodes the whole finest level; docs/lod.md)\n"
		"                       and check its mesh for cracks and T-junctions\n"
		"      --budget MIB     GPU memory for the patch cache (default 256)\n"
		"      --device DEV     Vulkan device: name substring, deviceUUID or render node\n"
		"      --validation     enable the Khronos validation layer\n");
}

/* The finest level larger than this is not decoded for --exact (4 GiB of heights). */
#define EXACT_MAX_SAMPLES (1ull << 30)

/* --exact: the converged frame drawn once more with its triangles captured (selecting again
 * for the same camera keeps the LOD), each measured against the finest decoded surface
 * (relief_mesh_error()), and the mesh checked for seams (relief_mesh_seams()); prints the
 * results (a mesh with seams is reported, not an error: the picture was written).
 * `triangles`: the frame's count, 0 if unknown. */
static int snap_exact(const struct relief_file *f, struct tool_renderer *g, struct relief_terrain_view *tv,
                      const struct relief_view *view, uint64_t frame, uint64_t triangles)
{
	uint32_t fw, fh;
	relief_level_extent(&f->hdr, f->hdr.levels - 1, &fw, &fh);
	if ((uint64_t)fw * fh > EXACT_MAX_SAMPLES) {
		fprintf(stderr, "relief snap: --exact: the finest level has %llu samples, more than the %llu it decodes\n",
		        (unsigned long long)fw * fh, (unsigned long long)EXACT_MAX_SAMPLES);
		return -EFBIG;
	}
	if (!g->vk->has.mesh_capture) {
		fprintf(stderr, "relief snap: --exact: this device has no geometry shaders that store to buffers\n");
		return -ENOTSUP;
	}
	const uint32_t limit = relief_terrain_mesh_limit(g->vk); /* the device's storage buffers */
	uint32_t cap = triangles > 0 && triangles < (1u << 26) ? (uint32_t)triangles + 1024 : 1u << 22;
	cap = cap < limit ? cap : limit;
	float *finest = malloc(sizeof(float) * fw * fh);
	uint8_t *valid = malloc((size_t)fw * fh);
	struct relief_mesh_vertex *tri = NULL;
	struct relief_mesh_quad *quads = NULL;
	int64_t n = 0;
	int ret = finest && valid ? relief_decode_level_drawn(f, f->hdr.levels - 1, 0, finest, valid) : -ENOMEM;
	for (int pass = 0; ret >= 0 && pass < 2; pass++) { /* again with room for all if they did not fit */
		const struct relief_draw_options dopt = { .mesh = true };
		struct relief_terrain_stats st;
		free(tri);
		free(quads);
		tri = malloc(sizeof(*tri) * 3 * (size_t)cap);
		quads = malloc(sizeof(*quads) * (size_t)cap);
		if (!tri || !quads) {
			ret = -ENOMEM;
			break;
		}
		if ((ret = relief_terrain_view_mesh_enable(tv, cap)) < 0 ||
		    (ret = relief_terrain_draw(g->terrain, tv, view, &g->target, frame + pass, &dopt, &st)) < 0 ||
		    (n = relief_terrain_view_mesh(tv, tri, quads, cap)) < 0)
			break;
		if (n <= cap)
			break;
		if (cap == limit)
			break; /* no more room on this device: -E2BIG below */
		cap = n < limit ? (uint32_t)n : limit;
	}
	if (ret >= 0 && n < 0)
		ret = (int)n;
	if (ret >= 0 && n > cap) {
		fprintf(stderr, "relief snap: --exact: the frame draws %lld triangles, more than one capture holds on this device (%u)\n",
		        (long long)n, cap);
		ret = -E2BIG;
	}
	if (ret < 0) {
		fprintf(stderr, "relief snap: --exact: %s\n", strerror(-ret));
	} else {
		struct relief_mesh_error e;
		relief_mesh_error(f, view, finest, valid, fw, fh, tri, quads, (uint64_t)n, &e);
		printf("relief snap: exact: %lld triangles (%llu transition, %llu vertical) measured at %llu points: "
		       "max %.3f px (%.2f m) at (%.1f, %.1f, %.1f), patch %u; regular triangles %.3f px against either "
		       "diagonal, transition triangles %.3f px: along coarser edges %.3f px (%llu), finer edges %.3f px "
		       "(%llu), fans %.3f px (%llu), other %llu\n",
		       (long long)n, (unsigned long long)e.transition, (unsigned long long)e.vertical,
		       (unsigned long long)e.points, e.max_px, e.max_m, e.worst.x, e.worst.y, e.worst.z, e.worst_tri[0].patch,
		       e.max_px_regular_worse, e.max_px_transition, e.kind_max_px[RELIEF_MESH_COARSE_EDGE],
		       (unsigned long long)e.kind_triangles[RELIEF_MESH_COARSE_EDGE], e.kind_max_px[RELIEF_MESH_FINE_EDGE],
		       (unsigned long long)e.kind_triangles[RELIEF_MESH_FINE_EDGE], e.kind_max_px[RELIEF_MESH_FAN],
		       (unsigned long long)e.kind_triangles[RELIEF_MESH_FAN],
		       (unsigned long long)(e.kind_triangles[RELIEF_MESH_OTHER] + e.kind_triangles[RELIEF_MESH_UNKNOWN]));
		struct relief_mesh_seams m;
		if ((ret = relief_mesh_seams(tri, (uint64_t)n, RELIEF_MESH_SEAM_TOL_M, &m)) < 0)
			fprintf(stderr, "relief snap: --exact: %s\n", strerror(-ret));
		else if (m.split + m.junctions == 0)
			printf("relief snap: exact: watertight: %llu corners, none drawn at two heights, no T-junction\n",
			       (unsigned long long)m.positions);
		else
			printf("relief snap: exact: NOT watertight: %llu positions drawn at two heights (first at sample "
			       "%lld, %lld), %llu T-junctions (%llu off their edge by more than %g m, the largest %.3f m at "
			       "sample %lld, %lld)\n",
			       (unsigned long long)m.split, (long long)m.split_at.col, (long long)m.split_at.row,
			       (unsigned long long)m.junctions, (unsigned long long)m.open, RELIEF_MESH_SEAM_TOL_M, m.max_gap_m,
			       (long long)m.worst.col, (long long)m.worst.row);
	}
	free(tri);
	free(quads);
	free(finest);
	free(valid);
	return ret;
}

int cmd_snap(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "output", required_argument, NULL, 'o' }, { "camera", required_argument, NULL, 'c' },
		{ "look", required_argument, NULL, 'l' },   { "fov", required_argument, NULL, 'f' },
		{ "size", required_argument, NULL, 's' },   { "tau", required_argument, NULL, 't' },
		{ "wire", no_argument, NULL, 'w' },         { "depth", required_argument, NULL, 'D' },
		{ "budget", required_argument, NULL, 'b' }, { "device", required_argument, NULL, 'd' },
		{ "validation", no_argument, NULL, 'V' },   { "help", no_argument, NULL, 'h' },
		{ "roll", required_argument, NULL, 'r' },   { "morph", no_argument, NULL, 'M' },
		{ "exact", no_argument, NULL, 'E' },        { "loose", no_argument, NULL, 'L' },
		{ 0 },
	};
	const char *output = NULL, *depth_path = NULL, *device = NULL;
	double cam[3], look[3], fov = 50.0, tau = 1.0, roll = 0.0;
	bool have_cam = false, have_look = false, wire = false, validation = false, morph = false, exact = false,
	     loose = false;
	uint32_t width = 1280, height = 720, budget = 256;
	int c;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":o:h", opts, NULL)) != -1) {
		switch (c) {
		case 'o': output = optarg; break;
		case 'c':
			if (!cli_parse_vec3("snap", "--camera", optarg, cam))
				return EXIT_USAGE;
			have_cam = true;
			break;
		case 'l':
			if (!cli_parse_vec3("snap", "--look", optarg, look))
				return EXIT_USAGE;
			have_look = true;
			break;
		case 'r':
			if (!cli_parse_double("snap", "--roll", optarg, &roll))
				return EXIT_USAGE;
			break;
		case 'f':
			if (!cli_parse_double("snap", "--fov", optarg, &fov))
				return EXIT_USAGE;
			break;
		case 's':
			if (!cli_parse_size("snap", "--size", optarg, &width, &height))
				return EXIT_USAGE;
			break;
		case 't':
			if (!cli_parse_double("snap", "--tau", optarg, &tau))
				return EXIT_USAGE;
			break;
		case 'w': wire = true; break;
		case 'M': morph = true; break;
		case 'L': loose = true; break;
		case 'E': exact = true; break;
		case 'D': depth_path = optarg; break;
		case 'b':
			if (!cli_parse_u32("snap", "--budget", optarg, 1, 1048576, &budget))
				return EXIT_USAGE;
			break;
		case 'd': device = optarg; break;
		case 'V': validation = true; break;
		case 'h': snap_usage(stdout); return 0;
		default: return cli_option_error("snap", c, argv);
		}
	}
	if (argc - optind != 1) {
		fprintf(stderr, "relief snap: expected one FILE.relief (see 'relief snap --help')\n");
		return EXIT_USAGE;
	}
	if (!have_cam || !have_look || !output) {
		fprintf(stderr, "relief snap: --camera, --look and -o are required\n");
		return EXIT_USAGE;
	}
	const char *path = argv[optind];
	const char *outs[] = { output, depth_path };
	if (!cli_outputs_ok("snap", outs, 2, &path, 1))
		return EXIT_USAGE;
	char err[512];
	struct relief_file *f;
	if (relief_file_open(path, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "relief snap: %s: %s\n", path, err);
		return 1;
	}
	/* Far plane: beyond the terrain seen from the camera; near: small against it. */
	const struct relief_header *h = &f->hdr;
	double ex = h->spacing_x * (h->size - 1), ey = h->spacing_y * (h->size - 1), ez = h->height_max - h->height_min;
	double cx = h->origin_x + 0.5 * ex, cy = h->origin_y - 0.5 * ey;
	double reach = sqrt(ex * ex + ey * ey + ez * ez) +
	               sqrt((cam[0] - cx) * (cam[0] - cx) + (cam[1] - cy) * (cam[1] - cy) + cam[2] * cam[2]);
	struct relief_view view = {
		.eye = { cam[0], cam[1], cam[2] },
		.target = { look[0], look[1], look[2] },
		.roll = roll * M_PI / 180.0,
		.fovy = fov * M_PI / 180.0,
		.width = width,
		.height = height,
		.znear = fmax(0.05, reach * 2e-6),
		.zfar = 2.0 * reach,
		.tau = tau,
		.morph = morph,
		.loose_transitions = loose,
	};
	const char *why;
	if (relief_view_check(&view, &why) < 0) {
		fprintf(stderr, "relief snap: bad camera: %s\n", why);
		relief_file_close(f);
		return EXIT_USAGE;
	}
	struct relief_vk_options vo = { .device = device, .validation = validation, .log = &cli_log, .mesh_capture = exact };
	struct tool_renderer g;
	struct relief_terrain_view *tv = NULL;
	struct relief_patch_cache_options co = { .budget_bytes = (uint64_t)budget << 20 };
	int status = 1, ret;
	if ((ret = tool_renderer_init(&g, &vo, f, &co, width, height)) < 0 ||
	    (ret = relief_terrain_view_create(g.terrain, &tv)) < 0) {
		fprintf(stderr, "relief snap: GPU setup failed: %s\n", strerror(-ret));
		goto out;
	}
	relief_patch_cache_request(g.cache, 0, 0.0f);
	struct relief_terrain_stats st = { 0 };
	const struct relief_draw_options dopt = { .wire = wire };
	uint32_t frames = 0;
	uint64_t frame = 1;
	for (; frame <= 4u * h->levels + 4u; frame++) {
		if ((ret = relief_patch_cache_flush(g.cache, frame)) < 0 && ret != -ENOSPC)
			break;
		if ((ret = relief_terrain_draw(g.terrain, tv, &view, &g.target, frame, &dopt, &st)) < 0)
			break;
		frames++;
		if (st.requests == 0)
			break; /* nothing more wanted: this is the frame */
	}
	/* The picture and the numbers are the converged view's drawn once more: a frame that
	 * is the first to use a pipeline or a buffer carries the driver's first-use costs
	 * (lavapipe compiles shader variants at their first draw), and a view that converged
	 * in one frame reported those (Puget Sound's root alone from 120 km: 34.6 ms against
	 * 3.7 ms warm). Selecting again for the same camera keeps the level of detail. */
	if (ret >= 0 || ret == -ENOSPC)
		ret = relief_terrain_draw(g.terrain, tv, &view, &g.target, frame + 1, &dopt, &st);
	if (ret < 0 && ret != -ENOSPC) {
		fprintf(stderr, "relief snap: rendering failed: %s\n", strerror(-ret));
		goto out;
	}
	/* Each output replaces what was there only once it is complete. */
	char *tmp;
	if ((ret = cli_make_parent_dir(output)) < 0 || (ret = cli_replace_begin(output, &tmp)) < 0 ||
	    (ret = cli_replace_end(tmp, output, png_write_rgba(tmp, g.target.color_readback.map, width, height))) < 0) {
		fprintf(stderr, "relief snap: cannot write %s: %s\n", output, strerror(-ret));
		goto out;
	}
	if (depth_path) {
		size_t n = (size_t)width * height;
		float *dist = malloc(sizeof(float) * n);
		const float *d = g.target.depth_readback.map;
		for (size_t i = 0; i < n && dist; i++)
			le_put_f32((uint8_t *)&dist[i], (float)relief_view_depth_distance(&view, d[i]));
		ret = dist ? cli_replace_begin(depth_path, &tmp) : -ENOMEM;
		if (ret == 0) {
			FILE *df = fopen(tmp, "wbe");
			ret = !df ? -errno : fwrite(dist, sizeof(float), n, df) == n ? 0 : -EIO;
			if (df && fclose(df) != 0 && ret == 0)
				ret = -errno;
			ret = cli_replace_end(tmp, depth_path, ret);
		}
		free(dist);
		if (ret < 0) {
			fprintf(stderr, "relief snap: cannot write %s: %s\n", depth_path, strerror(-ret));
			goto out;
		}
	}
	struct relief_patch_cache_stats cs;
	relief_patch_cache_stats(g.cache, &cs);
	/* What the device cannot count or time is said so, not printed as 0. */
	char tri[64], gpu[96];
	if (g.vk->has.pipeline_statistics)
		snprintf(tri, sizeof(tri), "%llu triangles", (unsigned long long)st.triangles);
	else
		snprintf(tri, sizeof(tri), CLI_TRIANGLES_UNCOUNTED);
	if (g.vk->timestamp_valid_bits)
		snprintf(gpu, sizeof(gpu), "GPU %.2f ms (LOD compute %.2f ms, of which selection %.2f ms)", st.gpu_ns / 1e6,
		         st.lod_ns / 1e6, st.select_ns / 1e6);
	else
		snprintf(gpu, sizeof(gpu), CLI_GPU_UNTIMED);
	printf("relief snap: wrote %s (%ux%u), tau %g px: %u patches in %u draws, %s, %s, back faces %s (%u quads the "
	       "rasteriser may clip kept them), %u frames to converge, %llu patches decoded, %u requests left\n",
	       output, width, height, tau, st.patches, st.draws, tri, gpu,
	       st.face_culled ? "culled" : "drawn (the camera may be below the surface)", st.clipped_quads, frames,
	       (unsigned long long)cs.decoded, st.requests);
	if (exact && (ret = snap_exact(f, &g, tv, &view, frame + 2, st.triangles)) < 0)
		goto out;
	status = g.vk->validation && atomic_load(&g.vk->validation_messages) ? 1 : 0;
out:
	relief_terrain_view_destroy(tv);
	tool_renderer_finish(&g);
	relief_file_close(f);
	return status;
}
