/* relief hello: the foundation's end-to-end check. Renders a displaced, tessellated grid
 * headless through the Vulkan engine and writes a PNG. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "grid.h"
#include "mat4.h"
#include "vk.h"

static void hello_usage(FILE *f)
{
	fprintf(f,
		"usage: relief hello [-o FILE.png] [--size WxH] [--device DEV] [--validation]\n"
		"Renders a displaced, tessellated 16x16-patch grid headless and writes a PNG.\n"
		"  -o, --output FILE   PNG to write (default out/hello.png)\n"
		"      --size WxH      image size in pixels (default 1280x720)\n"
		"      --device DEV    Vulkan device: name substring, deviceUUID or render node\n"
		"      --validation    enable the Khronos validation layer\n");
}

int cmd_hello(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "output", required_argument, NULL, 'o' },
		{ "size", required_argument, NULL, 's' },
		{ "device", required_argument, NULL, 'd' },
		{ "validation", no_argument, NULL, 'V' },
		{ "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	const char *output = "out/hello.png", *device = NULL;
	uint32_t width = 1280, height = 720;
	bool validation = false;
	int c;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":o:h", opts, NULL)) != -1) {
		switch (c) {
		case 'o': output = optarg; break;
		case 's':
			if (!cli_parse_size("hello", "--size", optarg, &width, &height))
				return EXIT_USAGE;
			break;
		case 'd': device = optarg; break;
		case 'V': validation = true; break;
		case 'h': hello_usage(stdout); return 0;
		case ':':
		default:
			return cli_option_error("hello", c, argv);
		}
	}
	if (optind != argc) {
		fprintf(stderr, "relief hello: unexpected argument '%s'\n", argv[optind]);
		return EXIT_USAGE;
	}

	struct relief_vk_options vo = { .device = device, .validation = validation, .log = &cli_log };
	struct relief_vk *vk = NULL;
	struct relief_vk_target target = { 0 };
	struct relief_grid *grid = NULL;
	int status = 1, ret;
	if ((ret = relief_vk_create(&vo, &vk)) < 0 || (ret = relief_vk_target_init(vk, &target, width, height)) < 0 ||
	    (ret = relief_grid_create(vk, &target, &grid)) < 0) {
		fprintf(stderr, "relief hello: Vulkan setup failed: %s\n", strerror(-ret));
		goto out;
	}

	const double size = 1000.0, amp = 90.0;
	struct relief_mat4 view, proj, mvp;
	relief_mat4_look_at((struct relief_vec3){ -250.0, -420.0, 520.0 }, (struct relief_vec3){ 520.0, 480.0, 0.0 },
	                    (struct relief_vec3){ 0.0, 0.0, 1.0 }, &view);
	proj = relief_mat4_perspective(50.0 * M_PI / 180.0, (double)width / height, 10.0, 5000.0);
	mvp = relief_mat4_mul(&proj, &view);
	struct relief_grid_params p = {
		.patches_per_side = 16, .size = size, .factor = 32, .amplitude = amp,
		.sun = { 0.48f, 0.36f, 0.8f }, .shaded = true,
	};
	relief_mat4_to_float(&mvp, p.mvp);
	struct relief_grid_stats stats;
	if ((ret = relief_grid_render(grid, &p, &stats)) < 0) {
		fprintf(stderr, "relief hello: render failed: %s\n", strerror(-ret));
		goto out;
	}
	if ((ret = cli_make_parent_dir(output)) < 0 ||
	    (ret = png_write_rgba(output, target.color_readback.map, width, height)) < 0) {
		fprintf(stderr, "relief hello: cannot write %s: %s\n", output, strerror(-ret));
		goto out;
	}
	printf("relief hello: wrote %s (%ux%u) on %s: %u patches x factor %u in %u draws, "
	       "%llu TES invocations, GPU %.2f ms, %u validation messages\n",
	       output, width, height, vk->props.deviceName, p.patches_per_side * p.patches_per_side, p.factor,
	       stats.draws, (unsigned long long)stats.tes_invocations, stats.gpu_ns / 1e6,
	       atomic_load(&vk->validation_messages));
	status = atomic_load(&vk->validation_messages) ? 1 : 0;
out:
	relief_grid_destroy(grid);
	if (vk)
		relief_vk_target_finish(vk, &target);
	relief_vk_destroy(vk);
	return status;
}
