/* Instance and device creation: headless (no surface extensions), validation routed to
 * the logger, one device chosen by relief_vk_pick_device(). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk.h"

#define VALIDATION_LAYER "VK_LAYER_KHRONOS_validation"

static VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT types,
                                                     const VkDebugUtilsMessengerCallbackDataEXT *data,
                                                     void *user)
{
	struct relief_vk *vk = user;
	enum relief_log_level level = RELIEF_LOG_INFO;
	if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT)
		level = RELIEF_LOG_ERROR;
	else if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT)
		level = RELIEF_LOG_WARN;
	if (level <= RELIEF_LOG_WARN &&
	    (types & (VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
	              VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT)))
		atomic_fetch_add(&vk->validation_messages, 1);
	relief_log(&vk->log, level, "vulkan: %s", data->pMessage ? data->pMessage : "(no message)");
	return VK_FALSE;
}

static bool env_flag(const char *name, bool fallback)
{
	const char *v = getenv(name);
	if (!v || !*v)
		return fallback;
	return strcmp(v, "0") != 0 && strcmp(v, "no") != 0 && strcmp(v, "false") != 0;
}

static bool layer_available(const char *name)
{
	uint32_t n = 0;
	if (vkEnumerateInstanceLayerProperties(&n, NULL) != VK_SUCCESS || n == 0)
		return false;
	VkLayerProperties *props = calloc(n, sizeof(*props));
	bool found = false;
	if (props && vkEnumerateInstanceLayerProperties(&n, props) == VK_SUCCESS)
		for (uint32_t i = 0; i < n && !found; i++)
			found = strcmp(props[i].layerName, name) == 0;
	free(props);
	return found;
}

static bool device_extension(VkPhysicalDevice phys, const char *name)
{
	uint32_t n = 0;
	if (vkEnumerateDeviceExtensionProperties(phys, NULL, &n, NULL) != VK_SUCCESS)
		return false;
	VkExtensionProperties *props = calloc(n ? n : 1, sizeof(*props));
	bool found = false;
	if (props && vkEnumerateDeviceExtensionProperties(phys, NULL, &n, props) == VK_SUCCESS)
		for (uint32_t i = 0; i < n && !found; i++)
			found = strcmp(props[i].extensionName, name) == 0;
	free(props);
	return found;
}

/* A queue family that does graphics and compute, preferring one with timestamps. */
static int pick_queue_family(VkPhysicalDevice phys, uint32_t *family, uint32_t *ts_bits)
{
	uint32_t n = 0;
	vkGetPhysicalDeviceQueueFamilyProperties(phys, &n, NULL);
	VkQueueFamilyProperties *q = calloc(n ? n : 1, sizeof(*q));
	if (!q)
		return -ENOMEM;
	vkGetPhysicalDeviceQueueFamilyProperties(phys, &n, q);
	int best = -1;
	for (uint32_t i = 0; i < n; i++) {
		VkQueueFlags want = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
		if ((q[i].queueFlags & want) != want)
			continue;
		if (best < 0 || (q[best].timestampValidBits == 0 && q[i].timestampValidBits > 0))
			best = (int)i;
	}
	if (best >= 0) {
		*family = (uint32_t)best;
		*ts_bits = q[best].timestampValidBits;
	}
	free(q);
	return best >= 0 ? 0 : -ENODEV;
}

static void describe_device(VkPhysicalDevice phys, bool drm_ext, struct relief_vk_device_desc *d)
{
	VkPhysicalDeviceIDProperties id = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES };
	VkPhysicalDeviceDrmPropertiesEXT drm = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRM_PROPERTIES_EXT };
	if (drm_ext)
		id.pNext = &drm;
	VkPhysicalDeviceProperties2 props = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &id };
	vkGetPhysicalDeviceProperties2(phys, &props);
	VkPhysicalDeviceFeatures feats;
	vkGetPhysicalDeviceFeatures(phys, &feats);

	memset(d, 0, sizeof(*d));
	snprintf(d->name, sizeof(d->name), "%s", props.properties.deviceName);
	memcpy(d->uuid, id.deviceUUID, VK_UUID_SIZE);
	d->type = props.properties.deviceType;
	if (drm_ext && drm.hasRender) {
		d->has_render_node = true;
		d->render_major = drm.renderMajor;
		d->render_minor = drm.renderMinor;
	}
	/* The render target's reversed-Z depth is 32-bit float and read back (target.c); Vulkan
	 * guarantees a depth attachment in D32_SFLOAT or X8_D24_UNORM_PACK32, not both. */
	VkFormatProperties depth;
	vkGetPhysicalDeviceFormatProperties(phys, VK_FORMAT_D32_SFLOAT, &depth);
	const VkFormatFeatureFlags need =
		VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_FORMAT_FEATURE_TRANSFER_SRC_BIT;
	uint32_t family, ts;
	d->usable = props.properties.apiVersion >= VK_API_VERSION_1_2 && feats.tessellationShader &&
	            feats.multiDrawIndirect && (depth.optimalTilingFeatures & need) == need &&
	            pick_queue_family(phys, &family, &ts) == 0;
}

static int create_instance(struct relief_vk *vk)
{
	const char *exts[1];
	uint32_t n_ext = 0;
	const char *layers[1];
	uint32_t n_layers = 0;
	if (vk->validation) {
		layers[n_layers++] = VALIDATION_LAYER;
		exts[n_ext++] = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
	}
	VkApplicationInfo app = {
		.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
		.pApplicationName = "relief",
		.pEngineName = "relief",
		.apiVersion = VK_API_VERSION_1_2,
	};
	/* Synchronisation checks always; GPU-assisted validation with vk->gpu_av (much slower;
	 * scripts/test runs the GPU tests so once). */
	VkValidationFeatureEnableEXT enables[] = {
		VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT,
		VK_VALIDATION_FEATURE_ENABLE_GPU_ASSISTED_EXT,
	};
	VkValidationFeaturesEXT features = {
		.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT,
		.enabledValidationFeatureCount = vk->gpu_av ? 2 : 1,
		.pEnabledValidationFeatures = enables,
	};
	VkDebugUtilsMessengerCreateInfoEXT messenger = {
		.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
		.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
		                   VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
		.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
		               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
		               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
		.pfnUserCallback = debug_callback,
		.pUserData = vk,
	};
	if (vk->validation) {
		/* Chained so that instance creation and destruction are validated too. */
		features.pNext = &messenger;
	}
	VkInstanceCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
		.pNext = vk->validation ? &features : NULL,
		.pApplicationInfo = &app,
		.enabledLayerCount = n_layers,
		.ppEnabledLayerNames = layers,
		.enabledExtensionCount = n_ext,
		.ppEnabledExtensionNames = exts,
	};
	int ret = relief_vk_check(vk, vkCreateInstance(&info, NULL, &vk->instance), "vkCreateInstance");
	if (ret < 0)
		return ret;
	if (vk->validation) {
		PFN_vkCreateDebugUtilsMessengerEXT create = (PFN_vkCreateDebugUtilsMessengerEXT)
			vkGetInstanceProcAddr(vk->instance, "vkCreateDebugUtilsMessengerEXT");
		if (!create)
			return -ENOTSUP;
		ret = relief_vk_check(vk, create(vk->instance, &messenger, NULL, &vk->messenger),
		                      "vkCreateDebugUtilsMessengerEXT");
	}
	return ret;
}

static int choose_device(struct relief_vk *vk, const char *want)
{
	struct relief_vk_query query;
	int ret = relief_vk_query_parse(want, &query);
	if (ret < 0) {
		relief_log(&vk->log, RELIEF_LOG_ERROR, "device '%s': %s", want, strerror(-ret));
		return ret;
	}
	uint32_t n = 0;
	ret = relief_vk_check(vk, vkEnumeratePhysicalDevices(vk->instance, &n, NULL), "vkEnumeratePhysicalDevices");
	if (ret < 0)
		return ret;
	VkPhysicalDevice *phys = calloc(n ? n : 1, sizeof(*phys));
	struct relief_vk_device_desc *desc = calloc(n ? n : 1, sizeof(*desc));
	if (!phys || !desc) {
		ret = -ENOMEM;
		goto out;
	}
	ret = relief_vk_check(vk, vkEnumeratePhysicalDevices(vk->instance, &n, phys), "vkEnumeratePhysicalDevices");
	if (ret < 0)
		goto out;
	for (uint32_t i = 0; i < n; i++) {
		describe_device(phys[i], device_extension(phys[i], VK_EXT_PHYSICAL_DEVICE_DRM_EXTENSION_NAME), &desc[i]);
		relief_log(&vk->log, RELIEF_LOG_DEBUG, "vulkan device %u: %s (%s)%s", i, desc[i].name,
		           relief_vk_device_type_name(desc[i].type), desc[i].usable ? "" : ", unusable");
	}
	size_t index;
	ret = relief_vk_pick_device(desc, n, &query, &index);
	if (ret < 0) {
		relief_log(&vk->log, RELIEF_LOG_ERROR, "no usable Vulkan device%s%s (%u found; need Vulkan 1.2, "
		           "tessellation, multi-draw indirect, a D32_SFLOAT depth attachment, a graphics+compute queue)", want && *want ? " matches " : "",
		           want && *want ? want : "", n);
		goto out;
	}
	vk->phys = phys[index];
	relief_log(&vk->log, RELIEF_LOG_INFO, "vulkan: using %s (%s)%s%s", desc[index].name,
	           relief_vk_device_type_name(desc[index].type), want && *want ? ", asked for " : ", default order",
	           want && *want ? want : "");
out:
	free(phys);
	free(desc);
	return ret;
}

static int create_device(struct relief_vk *vk, bool mesh_capture)
{
	int ret = pick_queue_family(vk->phys, &vk->queue_family, &vk->timestamp_valid_bits);
	if (ret < 0)
		return ret;
	vkGetPhysicalDeviceProperties(vk->phys, &vk->props);
	vkGetPhysicalDeviceMemoryProperties(vk->phys, &vk->mem);

	VkPhysicalDeviceVulkan12Features have12 = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES };
	VkPhysicalDeviceFeatures2 have = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &have12 };
	vkGetPhysicalDeviceFeatures2(vk->phys, &have);

	const VkBool32 capture =
		mesh_capture && have.features.geometryShader && have.features.vertexPipelineStoresAndAtomics;
	VkPhysicalDeviceVulkan12Features want12 = {
		.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
		.drawIndirectCount = have12.drawIndirectCount,
	};
	VkPhysicalDeviceFeatures2 want = {
		.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
		.pNext = &want12,
		.features = {
			.tessellationShader = VK_TRUE,
			.pipelineStatisticsQuery = have.features.pipelineStatisticsQuery,
			.fillModeNonSolid = have.features.fillModeNonSolid,
			.shaderStorageImageWriteWithoutFormat = have.features.shaderStorageImageWriteWithoutFormat,
			.shaderStorageImageExtendedFormats = have.features.shaderStorageImageExtendedFormats,
			.multiDrawIndirect = VK_TRUE, /* a usable device has it (describe_device()) */
			/* for the mesh capture only, when asked for (relief_vk_options.mesh_capture) */
			.geometryShader = capture,
			.vertexPipelineStoresAndAtomics = capture,
		},
	};
	vk->has.pipeline_statistics = have.features.pipelineStatisticsQuery && !vk->gpu_av;
	vk->has.fill_mode_non_solid = have.features.fillModeNonSolid;
	vk->has.draw_indirect_count = have12.drawIndirectCount;
	vk->has.mesh_capture = capture;
	vk->has.external_memory_fd = device_extension(vk->phys, VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME);

	const char *exts[1];
	uint32_t n_ext = 0;
	if (vk->has.external_memory_fd)
		exts[n_ext++] = VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME;

	float priority = 1.0f;
	VkDeviceQueueCreateInfo queue = {
		.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
		.queueFamilyIndex = vk->queue_family,
		.queueCount = 1,
		.pQueuePriorities = &priority,
	};
	VkDeviceCreateInfo info = {
		.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
		.pNext = &want,
		.queueCreateInfoCount = 1,
		.pQueueCreateInfos = &queue,
		.enabledExtensionCount = n_ext,
		.ppEnabledExtensionNames = exts,
	};
	ret = relief_vk_check(vk, vkCreateDevice(vk->phys, &info, NULL, &vk->device), "vkCreateDevice");
	if (ret < 0)
		return ret;
	vkGetDeviceQueue(vk->device, vk->queue_family, 0, &vk->queue);

	VkCommandPoolCreateInfo pool = {
		.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
		.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
		.queueFamilyIndex = vk->queue_family,
	};
	return relief_vk_check(vk, vkCreateCommandPool(vk->device, &pool, NULL, &vk->cmd_pool), "vkCreateCommandPool");
}

int relief_vk_create(const struct relief_vk_options *opts, struct relief_vk **out)
{
	struct relief_vk *vk = calloc(1, sizeof(*vk));
	if (!vk)
		return -ENOMEM;
	if (opts->log)
		vk->log = *opts->log;
	atomic_init(&vk->validation_messages, 0);
	atomic_init(&vk->allocations, 0);
	pthread_mutex_init(&vk->modules_lock, NULL);
	pthread_mutex_init(&vk->shared_lock, NULL);
	vk->validation = env_flag("RELIEF_VALIDATION", opts->validation);
	vk->gpu_av = vk->validation && env_flag("RELIEF_GPU_AV", false);

	int ret;
	if (vk->validation && !layer_available(VALIDATION_LAYER)) {
		relief_log(&vk->log, RELIEF_LOG_ERROR, "validation requested but %s is not installed "
		           "(Debian package vulkan-validationlayers)", VALIDATION_LAYER);
		ret = -ENOENT;
		goto fail;
	}
	const char *env_device = getenv("RELIEF_DEVICE");
	const char *want = env_device && *env_device ? env_device : opts->device;

	if ((ret = create_instance(vk)) < 0 || (ret = choose_device(vk, want)) < 0 ||
	    (ret = create_device(vk, opts->mesh_capture)) < 0)
		goto fail;
	*out = vk;
	return 0;
fail:
	relief_vk_destroy(vk);
	return ret;
}

void relief_vk_destroy(struct relief_vk *vk)
{
	if (!vk)
		return;
	if (vk->device) {
		vkDeviceWaitIdle(vk->device);
		if (vk->cmd_pool)
			vkDestroyCommandPool(vk->device, vk->cmd_pool, NULL);
		for (uint32_t i = vk->n_shared; i-- > 0;) {
			vk->shared[i].kind->destroy(vk, vk->shared[i].obj);
			free(vk->shared[i].obj);
		}
		for (uint32_t i = 0; i < vk->n_modules; i++)
			vkDestroyShaderModule(vk->device, vk->modules[i].module, NULL);
		vkDestroyDevice(vk->device, NULL);
	}
	pthread_mutex_destroy(&vk->modules_lock);
	pthread_mutex_destroy(&vk->shared_lock);
	if (vk->messenger) {
		PFN_vkDestroyDebugUtilsMessengerEXT destroy = (PFN_vkDestroyDebugUtilsMessengerEXT)
			vkGetInstanceProcAddr(vk->instance, "vkDestroyDebugUtilsMessengerEXT");
		if (destroy)
			destroy(vk->instance, vk->messenger, NULL);
	}
	if (vk->instance)
		vkDestroyInstance(vk->instance, NULL);
	free(vk);
}

int relief_vk_shared(struct relief_vk *vk, const struct relief_vk_shared_kind *kind, void **out)
{
	int ret = 0;
	pthread_mutex_lock(&vk->shared_lock);
	uint32_t i = 0;
	while (i < vk->n_shared && vk->shared[i].kind != kind)
		i++;
	if (i == vk->n_shared) {
		void *obj = NULL;
		if (i == RELIEF_VK_MAX_SHARED)
			ret = -ENOSPC;
		else if (!(obj = calloc(1, kind->size)))
			ret = -ENOMEM;
		else if ((ret = kind->create(vk, obj)) < 0) {
			kind->destroy(vk, obj);
			free(obj);
		} else {
			vk->shared[i].kind = kind;
			vk->shared[i].obj = obj;
			vk->n_shared++;
		}
		if (ret < 0)
			relief_log(&vk->log, RELIEF_LOG_ERROR, "%s: %s", kind->name, strerror(-ret));
	}
	if (ret == 0)
		*out = vk->shared[i].obj;
	pthread_mutex_unlock(&vk->shared_lock);
	return ret;
}
