/* The Vulkan context shared by reliefd and the in-process tools (relief snap, bench).
 *
 * Ownership: struct relief_vk owns the instance, the debug messenger, the logical device and
 * its command pool; they are destroyed by relief_vk_destroy() in reverse order. `phys` and
 * `queue` are handles owned by the instance and the device (never destroyed on their own).
 * Objects made with the helpers below (buffers, images, timers) belong to whoever called the
 * init function and must be finished before the context is destroyed.
 *
 * Threading: the context may be shared; `queue` and `cmd_pool` are externally synchronised
 * (the caller serialises submissions), as in the Vulkan spec.
 *
 * Errors: every function returns 0 or a negative errno. A VkResult becomes an errno in one
 * place only, relief_vk_check() (vk_result.c), which also logs the failing call by name.
 */
#pragma once

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <vulkan/vulkan.h>

#include "../log.h"

struct relief_vk_options {
	/* Which device. NULL or "" means the default order (discrete, integrated, virtual, CPU).
	 * Otherwise: a deviceUUID (32 hex digits, dashes allowed), a DRM render node path
	 * ("/dev/dri/renderD128", matched through VK_EXT_physical_device_drm), or a substring of
	 * the device name ("llvmpipe", "AMD"). The environment variable RELIEF_DEVICE overrides. */
	const char *device;
	/* Enable VK_LAYER_KHRONOS_validation with synchronisation validation. Its messages go
	 * to the logger and are counted in validation_messages. RELIEF_VALIDATION=0|1 overrides.
	 * Asking for it when the layer is not installed is an error (-ENOENT). With validation
	 * on, RELIEF_GPU_AV=1 adds GPU-assisted validation (struct relief_vk's gpu_av). */
	bool validation;
	const struct relief_logger *log;
	/* Enable what the terrain's mesh capture needs (geometry shaders that store to
	 * buffers; relief_terrain_view_mesh_enable()) where the device has it: has.mesh_capture.
	 * Off unless asked for: with vertex-pipeline stores enabled, GPU-assisted validation
	 * instruments every vertex, tessellation and geometry shader, which on lavapipe made
	 * the GPU tests several times slower under it. */
	bool mesh_capture;
};

#define RELIEF_VK_CAPTURE_FENCES 32
/* Distinct shader codes a device keeps modules of (relief_vk_shader_module()). */
#define RELIEF_VK_MAX_MODULES 48
/* Kinds of object a device keeps for its life and shares (relief_vk_shared()). */
#define RELIEF_VK_MAX_SHARED 8

struct relief_vk;
/* A kind of object that does not depend on who uses it, made once per device and shared
 * by every user (relief_vk_shared()): one static const instance per kind, its address the
 * key. */
struct relief_vk_shared_kind {
	const char *name; /* for messages */
	size_t size;      /* bytes of the object, zeroed before create() */
	/* 0 or a negative errno; on failure destroy() still runs on what was made */
	int (*create)(struct relief_vk *vk, void *obj);
	/* undoes create(), whole or partial (handles are VK_NULL_HANDLE where not made) */
	void (*destroy)(struct relief_vk *vk, void *obj);
};

struct relief_vk {
	VkInstance instance;
	VkDebugUtilsMessengerEXT messenger;
	VkPhysicalDevice phys;
	VkDevice device;
	VkQueue queue;
	uint32_t queue_family;
	VkCommandPool cmd_pool;

	VkPhysicalDeviceProperties props;
	VkPhysicalDeviceMemoryProperties mem;
	uint32_t timestamp_valid_bits;
	bool validation;
	/* GPU-assisted validation is on (RELIEF_GPU_AV): the layer instruments the shaders and
	 * checks what only the device sees, such as draw records a compute pass wrote. Its
	 * checks of indirect draws insert draws of its own, which lavapipe counts into (or
	 * resets) pipeline statistics, so has.pipeline_statistics is false then. */
	bool gpu_av;
	struct {
		bool pipeline_statistics;
		bool fill_mode_non_solid;
		bool draw_indirect_count;
		/* geometry shaders that store to buffers, enabled (relief_vk_options.mesh_capture):
		 * the terrain's mesh capture */
		bool mesh_capture;
		bool external_memory_fd;
	} has;

	struct relief_logger log;
	/* Validation-layer messages of severity warning or error since creation. Tests assert it
	 * stays 0. Written from the layer's callback, hence atomic. */
	atomic_uint validation_messages;
	/* Device memory allocations alive (common/gpu/vk_mem.c makes and frees them all). A
	 * device may allow as few as 4,096 (maxMemoryAllocationCount), which a daemon drawing
	 * many clients' views must stay well under. */
	atomic_uint allocations;
	/* Tests (relief_vk_capture_begin()): the command buffer frames and patch cache batches
	 * are recorded into, and the fences its submission is to signal, in order. */
	VkCommandBuffer capture;
	VkFence capture_fences[RELIEF_VK_CAPTURE_FENCES];
	uint32_t capture_n_fences;
	/* Shader modules made so far, one per code (the embedded SPIR-V, by address), kept for
	 * the device's life: every pipeline made from that code on this device, by any patch
	 * cache or terrain, uses the same module. GPU-assisted validation instruments each
	 * module it sees as a new shader, so a module made per pipeline made lavapipe compile
	 * the decode passes again for every patch cache (docs/testing.md). Under modules_lock. */
	struct {
		const uint32_t *code;
		VkShaderModule module;
	} modules[RELIEF_VK_MAX_MODULES];
	uint32_t n_modules;
	pthread_mutex_t modules_lock;
	/* Objects kept for the device's life (relief_vk_shared()), destroyed in reverse order
	 * before the device. Under shared_lock. */
	struct {
		const struct relief_vk_shared_kind *kind;
		void *obj;
	} shared[RELIEF_VK_MAX_SHARED];
	uint32_t n_shared;
	pthread_mutex_t shared_lock;
};

int relief_vk_create(const struct relief_vk_options *opts, struct relief_vk **out);
void relief_vk_destroy(struct relief_vk *vk);

/* The device's object of `kind`, made by kind->create() at the first call and returned
 * by every later one, from any thread (a caller arriving while it is being made waits for
 * it). For what every user would make alike and what takes long to make: a CPU
 * implementation compiles a pipeline at each vkCreate*Pipelines (lavapipe took 0.8 s for
 * the patch cache's strip bounds, docs/architecture.md), so a pipeline made per user made
 * every patch cache pay that again. A failed creation is not kept: the next call tries
 * again. The object lives until relief_vk_destroy(); users must not destroy it. -ENOSPC
 * beyond RELIEF_VK_MAX_SHARED kinds. */
int relief_vk_shared(struct relief_vk *vk, const struct relief_vk_shared_kind *kind, void **out);

/* The one VkResult -> errno mapping. On failure logs "<what>: <VkResult name>" and returns
 * the negative errno; VK_SUCCESS (and other non-negative results) return 0. */
int relief_vk_check(const struct relief_vk *vk, VkResult r, const char *what);
int relief_vk_errno(VkResult r);
const char *relief_vk_result_name(VkResult r);

/* ---- device selection (vk_select.c): pure, so it is unit-tested without a GPU ---- */

struct relief_vk_device_desc {
	char name[VK_MAX_PHYSICAL_DEVICE_NAME_SIZE];
	uint8_t uuid[VK_UUID_SIZE];
	VkPhysicalDeviceType type;
	bool has_render_node; /* VK_EXT_physical_device_drm reported a render node */
	int64_t render_major, render_minor;
	bool usable; /* API >= 1.2, a graphics+compute queue, tessellation shaders, multiDrawIndirect,
	              * a D32_SFLOAT depth attachment that can be copied out */
};

enum relief_vk_query_kind {
	RELIEF_VK_QUERY_DEFAULT,
	RELIEF_VK_QUERY_NAME,
	RELIEF_VK_QUERY_UUID,
	RELIEF_VK_QUERY_RENDER_NODE,
};

struct relief_vk_query {
	enum relief_vk_query_kind kind;
	char name[VK_MAX_PHYSICAL_DEVICE_NAME_SIZE];
	uint8_t uuid[VK_UUID_SIZE];
	int64_t render_major, render_minor;
};

/* Parses a device string (see relief_vk_options.device). A path is resolved with libdrm:
 * it must be a DRM render node, else -EINVAL/-ENOENT. */
int relief_vk_query_parse(const char *want, struct relief_vk_query *q);
/* Picks among `devs`; writes the index. -ENODEV when nothing usable matches. Among several
 * matches the default order breaks ties (discrete > integrated > virtual > CPU > other). */
int relief_vk_pick_device(const struct relief_vk_device_desc *devs, size_t n,
                          const struct relief_vk_query *q, size_t *index);
const char *relief_vk_device_type_name(VkPhysicalDeviceType type);

/* ---- memory (vk_mem.c) ---- */

/* What memory is for: who writes it, who reads it, how often. relief_vk_memory_pick()
 * turns it into a memory type; on a discrete GPU the answers differ (video memory, system
 * memory the CPU caches or not, the small window of video memory the CPU can map), on a
 * unified-memory device or lavapipe they coincide. */
enum relief_vk_memory_use {
	RELIEF_VK_MEMORY_DEVICE,   /* the device alone: pools, images, per-view work buffers */
	RELIEF_VK_MEMORY_UPLOAD,   /* the host writes, the device reads once: staging, job records */
	RELIEF_VK_MEMORY_READBACK, /* the device writes, the host reads: frames, counters, requests */
	RELIEF_VK_MEMORY_SHARED,   /* the host edits, the device reads or updates every frame: small tables */
};

/* The memory type for `use` among those allowed by type_bits, by rank:
 * - never a type whose use needs a feature relief does not enable (protected memory,
 *   VK_AMD_device_coherent_memory's device-coherent or uncached types: allocating one is
 *   invalid without the feature, and some drivers list them first) or lazily allocated;
 * - required: DEVICE_LOCAL for DEVICE (any allowed type if none is), HOST_VISIBLE and
 *   HOST_COHERENT for the others (Vulkan guarantees such a type for every buffer);
 * - preferred: DEVICE keeps off host-visible types (the mappable window of video memory is
 *   small: 224 MiB of 8 GiB on one listed discrete GPU), UPLOAD off device-local ones (for
 *   the same reason; the device reads each staged value once), READBACK on host-cached
 *   ones (the CPU reads them: uncached reads are slow), SHARED on device-local ones (the
 *   device reads them every frame, and updates some with atomics);
 * - among equals, the lowest index (the driver's order).
 * Pure, for unit tests with other devices' tables. 0, or -ENOMEM when no type qualifies. */
int relief_vk_memory_pick(const VkPhysicalDeviceMemoryProperties *mem, uint32_t type_bits,
                          enum relief_vk_memory_use use, uint32_t *index);

/* A buffer with its own allocation, or one of a group's (memory VK_NULL_HANDLE then).
 * Buffers of every use but RELIEF_VK_MEMORY_DEVICE stay mapped (`map`) and coherent. */
struct relief_vk_buffer {
	VkBuffer buffer;
	VkDeviceMemory memory;
	VkDeviceSize size;
	void *map;
};
int relief_vk_buffer_init(struct relief_vk *vk, struct relief_vk_buffer *b, VkDeviceSize size,
                          VkBufferUsageFlags usage, enum relief_vk_memory_use use);
/* Copies `size` bytes from `data` to offset 0 of `b` (made with TRANSFER_DST usage) through
 * a temporary upload buffer, and waits: for data a device-local buffer gets once. */
int relief_vk_buffer_upload(struct relief_vk *vk, const struct relief_vk_buffer *b, const void *data,
                            VkDeviceSize size);
/* Destroys the buffer, and frees its memory if it has its own. */
void relief_vk_buffer_finish(struct relief_vk *vk, struct relief_vk_buffer *b);

/* A view of the whole of buffer b as texels of `format` (4 bytes a component, `components`
 * a texel), for shaders that read it as a texel buffer of kind `feature`
 * (VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT or _STORAGE_): a CPU implementation gathers
 * a texel buffer's reads for all lanes, where it reads a storage buffer lane by lane
 * (docs/platform.md). -ENOTSUP where the format lacks the feature or b holds more than
 * maxTexelBufferElements texels, logged to `log` as an error naming `what` and the limit;
 * destroy with vkDestroyBufferView(). */
int relief_vk_texel_view_create(struct relief_vk *vk, const struct relief_vk_buffer *b, VkFormat format,
                                uint32_t components, VkFormatFeatureFlags feature, const struct relief_logger *log,
                                const char *what, VkBufferView *out);

/* Several buffers bound at aligned offsets of one allocation: a terrain view's fifteen
 * buffers take two allocations (device, readback), not fifteen. The group owns the
 * memory; finish its buffers (relief_vk_buffer_finish()) before the group. */
struct relief_vk_buffer_spec {
	struct relief_vk_buffer *buffer;
	VkDeviceSize size;
	VkBufferUsageFlags usage;
};
struct relief_vk_buffer_group {
	VkDeviceMemory memory;
	VkDeviceSize size;
};
#define RELIEF_VK_BUFFER_GROUP_MAX 16u /* buffers per group (-EINVAL beyond, and for none) */
int relief_vk_buffer_group_init(struct relief_vk *vk, struct relief_vk_buffer_group *g,
                                const struct relief_vk_buffer_spec *specs, size_t n, enum relief_vk_memory_use use);
void relief_vk_buffer_group_finish(struct relief_vk *vk, struct relief_vk_buffer_group *g);

/* A 2D (array) image with its own allocation and one view over all layers, of view_type
 * VK_IMAGE_VIEW_TYPE_2D or VK_IMAGE_VIEW_TYPE_2D_ARRAY. */
struct relief_vk_image {
	VkImage image;
	VkDeviceMemory memory;
	VkImageView view;
	VkFormat format;
	uint32_t width, height, layers;
};
int relief_vk_image_init(struct relief_vk *vk, struct relief_vk_image *img, VkFormat format,
                         uint32_t width, uint32_t height, uint32_t layers, VkImageViewType view_type,
                         VkImageUsageFlags usage, VkImageAspectFlags aspect);
/* Bytes an image of these parameters needs (vkGetImageMemoryRequirements), 0 on failure. */
VkDeviceSize relief_vk_image_bytes(struct relief_vk *vk, VkFormat format, uint32_t width, uint32_t height,
                                   uint32_t layers, VkImageUsageFlags usage);
void relief_vk_image_finish(struct relief_vk *vk, struct relief_vk_image *img);

/* The device's module of `code` (size bytes), made on first use and kept until
 * relief_vk_destroy(): callers do not destroy it. -ENOSPC past RELIEF_VK_MAX_MODULES codes.
 * Thread-safe. */
int relief_vk_shader_module(struct relief_vk *vk, const uint32_t *code, size_t size,
                            VkShaderModule *out);

/* ---- commands and timing (vk_cmd.c) ---- */

/* Allocates and begins a one-time primary command buffer. */
int relief_vk_cmd_begin(struct relief_vk *vk, VkCommandBuffer *cmd);
/* relief_vk_cmd_begin(), or the capture's command buffer while there is one (below): for
 * the work that is submitted and waited for later (frames, patch cache batches). */
int relief_vk_cmd_record(struct relief_vk *vk, VkCommandBuffer *cmd);
/* Ends `cmd` and submits it, `fence` (may be VK_NULL_HANDLE) signalled when it completes;
 * the caller frees it (relief_vk_cmd_free()) once it has. On failure `cmd` is freed here.
 * The capture's command buffer is not submitted: its fence is kept (-ENOSPC beyond
 * RELIEF_VK_CAPTURE_FENCES). */
int relief_vk_cmd_submit(struct relief_vk *vk, VkCommandBuffer cmd, VkFence fence);
/* A command buffer the caller keeps and records again (a patch cache batch's, `own`),
 * reset and begun, or the capture's while there is one: *cmd is the one to record into. */
int relief_vk_cmd_reuse(struct relief_vk *vk, VkCommandBuffer own, VkCommandBuffer *cmd);
/* relief_vk_cmd_submit() without freeing `cmd` on failure: for relief_vk_cmd_reuse()'s. */
int relief_vk_cmd_submit_kept(struct relief_vk *vk, VkCommandBuffer cmd, VkFence fence);
/* Frees a command buffer of relief_vk_cmd_begin() or _record(); not the capture's. */
void relief_vk_cmd_free(struct relief_vk *vk, VkCommandBuffer cmd);
/* Tests: between relief_vk_capture_begin() and relief_vk_capture_end(), frames and patch
 * cache batches are recorded into one command buffer instead of a submission each, so that
 * the validation layer's synchronisation checks, which do not look across submissions,
 * check the barriers between them. _end() submits it, then signals the kept fences in
 * order, and waits for the queue. One-shot work that waits (relief_vk_cmd_submit_wait())
 * is not captured: do none in between. */
int relief_vk_capture_begin(struct relief_vk *vk);
int relief_vk_capture_end(struct relief_vk *vk);
/* Ends, submits, waits for completion and frees `cmd` (also on failure). */
int relief_vk_cmd_submit_wait(struct relief_vk *vk, VkCommandBuffer cmd);

/* GPU timestamps: `count` slots; relief_vk_timer_reset() records the reset into a command
 * buffer before any relief_vk_timer_write(); relief_vk_timer_ns() reads the elapsed time
 * between two slots after the command buffer completed, in nanoseconds. init returns
 * -ENOTSUP when the queue has no timestamp support and leaves a timer without a pool, for
 * which reset and write record nothing and relief_vk_timer_ns() returns -ENOTSUP. */
struct relief_vk_timer {
	VkQueryPool pool;
	uint32_t count;
};
int relief_vk_timer_init(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t count);
void relief_vk_timer_finish(struct relief_vk *vk, struct relief_vk_timer *t);
void relief_vk_timer_reset(struct relief_vk_timer *t, VkCommandBuffer cmd);
void relief_vk_timer_write(struct relief_vk_timer *t, VkCommandBuffer cmd, uint32_t slot,
                           VkPipelineStageFlagBits stage);
int relief_vk_timer_ns(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t from,
                       uint32_t to, uint64_t *ns);
/* The raw timestamp in `slot` (masked to the queue's valid bits), for comparing timers
 * written on one queue; relief_vk_ticks_ns() is the signed time in nanoseconds from one
 * such stamp to another, across the counter's wrap (while they are less than half its
 * range apart). */
int relief_vk_timer_ticks(struct relief_vk *vk, struct relief_vk_timer *t, uint32_t slot, uint64_t *ticks);
int64_t relief_vk_ticks_ns(const struct relief_vk *vk, uint64_t from, uint64_t to);
/* The same for stamps in queue order: not negative (0 if they are not in order). */
uint64_t relief_vk_ticks_elapsed_ns(const struct relief_vk *vk, uint64_t from, uint64_t to);
