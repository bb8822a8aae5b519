/* reliefd: the terrain daemon. At this stage it reads its configuration and brings up the
 * Vulkan device (--check); the socket, the cache and the service loop arrive with the
 * daemon issues. main() stays thin: parse arguments, load config, act. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "format.h"
#include "heap.h"
#include "log.h"
#include "patch_cache.h"
#include "relief_version.h"
#include "vk.h"

_Static_assert(RELIEFD_MAX_DECODE_WORKERS == RELIEF_PATCH_CACHE_MAX_WORKERS, "config and cache limits differ");

/* Opens the terrain, builds the patch cache within the configured budget, decodes the two
 * coarsest levels and reports the cache. */
static int check_terrain(struct relief_vk *vk, const struct reliefd_config *cfg, const char *path,
                         const struct relief_logger *log)
{
	char err[512];
	struct relief_file *f;
	if (relief_file_open(path, &f, err, sizeof(err)) < 0) {
		fprintf(stderr, "reliefd: %s: %s\n", path, err);
		return 1;
	}
	struct relief_patch_cache_options o = { .budget_bytes = (uint64_t)cfg->budget_mib << 20,
	                                        .workers = cfg->decode_workers };
	struct relief_patch_cache *c;
	int ret = relief_patch_cache_create(vk, f, &o, log, &c);
	if (ret < 0) {
		fprintf(stderr, "reliefd: %s: patch cache: %s\n", path, strerror(-ret));
		relief_file_close(f);
		return 1;
	}
	uint32_t last = relief_level_first_id(f->hdr.levels > 1 ? 2 : 1);
	for (int pass = 0; pass < 2 && ret >= 0; pass++) {
		for (uint32_t id = 0; id < last; id++)
			relief_patch_cache_request(c, id, (float)id);
		ret = relief_patch_cache_flush(c, 1);
	}
	struct relief_patch_cache_stats s;
	relief_patch_cache_stats(c, &s);
	printf("reliefd: terrain %s: %u levels of %u-sample patches; cache %u layers (%llu bytes, %llu per patch, "
	       "budget %u MiB), %llu decoded on the GPU, %llu bad\n", path, f->hdr.levels, f->hdr.patch_size, s.layers,
	       (unsigned long long)s.bytes, (unsigned long long)s.bytes_per_layer, cfg->budget_mib,
	       (unsigned long long)s.decoded, (unsigned long long)s.bad);
	relief_patch_cache_destroy(c);
	relief_file_close(f);
	return ret < 0 ? 1 : 0;
}

static void usage(FILE *f)
{
	fprintf(f,
		"usage: reliefd [--config FILE] [--device DEV] [--check [--terrain FILE.relief]] [--version]\n"
		"  -c, --config FILE  INI configuration (see config/reliefd.conf)\n"
		"      --device DEV   Vulkan device: name substring, deviceUUID or render node\n"
		"                     (overrides the config; RELIEF_DEVICE overrides both)\n"
		"      --check        bring up the Vulkan device, report it and exit; with --terrain,\n"
		"                     also build the GPU patch cache from [gpu] budget_mib and decode\n"
		"                     the terrain's two coarsest levels on the GPU\n"
		"  -v, --verbose      log more (repeat for debug)\n"
		"      --version      print the version\n");
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "config", required_argument, NULL, 'c' },
		{ "device", required_argument, NULL, 'd' },
		{ "check", no_argument, NULL, 'C' },
		{ "terrain", required_argument, NULL, 't' },
		{ "verbose", no_argument, NULL, 'v' },
		{ "version", no_argument, NULL, 'V' },
		{ "help", no_argument, NULL, 'h' },
		{ 0 },
	};
	relief_heap_keep_freed(); /* the driver's per-draw buffers stay mapped (heap.h) */
	struct reliefd_config cfg;
	reliefd_config_defaults(&cfg);
	const char *config_path = NULL, *device = NULL, *terrain = NULL;
	bool check = false;
	enum relief_log_level level = RELIEF_LOG_WARN;
	int c;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":c:vh", opts, NULL)) != -1) {
		switch (c) {
		case 'c': config_path = optarg; break;
		case 'd': device = optarg; break;
		case 'C': check = true; break;
		case 't': terrain = optarg; break;
		case 'v': if (level < RELIEF_LOG_DEBUG) level++; break;
		case 'V': printf("reliefd %s\n", RELIEF_VERSION); return 0;
		case 'h': usage(stdout); return 0;
		case ':':
			fprintf(stderr, "reliefd: %s needs a value\n", argv[optind - 1]);
			return 2;
		default:
			fprintf(stderr, "reliefd: unknown option '%s' (see 'reliefd --help')\n", argv[optind - 1]);
			return 2;
		}
	}
	if (optind != argc) {
		fprintf(stderr, "reliefd: unexpected argument '%s'\n", argv[optind]);
		return 2;
	}
	struct relief_logger log = { relief_log_stderr, &level };
	if (config_path) {
		char err[512];
		if (reliefd_config_load(&cfg, config_path, err, sizeof(err)) < 0) {
			fprintf(stderr, "reliefd: config %s: %s\n", config_path, err);
			return 1;
		}
	}
	if (device)
		snprintf(cfg.device, sizeof(cfg.device), "%s", device);
	if (!check) {
		fprintf(stderr, "reliefd: the service loop is not built yet; use --check to test the device\n");
		return 2;
	}
	if (level < RELIEF_LOG_INFO)
		level = RELIEF_LOG_INFO; /* --check reports the chosen device */
	struct relief_vk_options vo = { .device = cfg.device, .validation = cfg.validation, .log = &log };
	struct relief_vk *vk;
	int ret = relief_vk_create(&vo, &vk);
	if (ret < 0) {
		fprintf(stderr, "reliefd: no Vulkan device: %s\n", strerror(-ret));
		return 1;
	}
	printf("reliefd: device ok: %s, budget %u MiB, tessellation yes, indirect count %s, "
	       "pipeline statistics %s, external memory fd %s\n",
	       vk->props.deviceName, cfg.budget_mib, vk->has.draw_indirect_count ? "yes" : "no",
	       vk->has.pipeline_statistics ? "yes" : "no", vk->has.external_memory_fd ? "yes" : "no");
	int status = 0;
	if (terrain)
		status = check_terrain(vk, &cfg, terrain, &log);
	relief_vk_destroy(vk);
	return status;
}
