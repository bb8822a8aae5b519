// The job record of the patch passes (patch_decode.comp, patch_normals.comp,
// patch_strips.comp): one per patch of a batch, written by patch_gpu_submit() (struct
// job_params, common/gpu/patch_cache_internal.h; the layouts must match). Each pass is one
// dispatch for the batch, workgroup z the job.
struct Job {
	int layer;      // the patch's layer (the decode writes it)
	int parent_layer;
	int quadrant;   // bit 0 east, bit 1 south
	int ratio;      // k
	uint slot;      // first int of the staging slot
	uint flag;      // index into flags
	int mode;       // 0 decode from parent, 1 copy values (root), 2 nothing (warm-up)
	int P;          // samples per side
	uint mask;      // staging int offset of the patch's validity bytes, or ~0u: all valid
	float q2;       // metres per quantum at the patch's level (2 delta_l)
	float inv_2sx;  // 1 / (2 x spacing) at the patch's level, 1/m
	float inv_2sy;
	int finest;     // 1: the patch is at the file's finest level
	float e0;       // above it, how far the patch at full detail can lie from the finest
	                // surface (E0(P)), metres, or infinity if the file does not say
};
layout(std430, binding = 4) readonly buffer Jobs { Job jobs[]; };
layout(push_constant) uniform Push { uint first_job; } push;
Job pc;

// Loads this workgroup's job into pc; false when there is nothing to do (warm-up).
bool job_begin()
{
	pc = jobs[push.first_job + gl_WorkGroupID.z];
	return pc.mode != 2;
}
