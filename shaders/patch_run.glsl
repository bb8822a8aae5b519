// Work split of the patch passes (patch_decode.comp, patch_normals.comp): the side x side
// items of one patch, in raster order, are cut into gl_NumWorkGroups.x equal runs, one per
// workgroup, and each of the RUN_LANES lanes takes every RUN_LANES-th item of its run.
// Few, long workgroups: a CPU implementation (lavapipe) pays a fixed cost per workgroup
// that dwarfed the work itself with one 8 x 8 workgroup per 64 items (docs/benchmarks.md),
// and a GPU still gets (runs x patches) workgroups of 64 lanes per dispatch.
const int RUN_LANES = 64; // == local_size_x

// This workgroup's run [first, end) of `total` items.
void patch_run(int total, out int first, out int end)
{
	int n = int(gl_NumWorkGroups.x), per = (total + n - 1) / n;
	first = min(int(gl_WorkGroupID.x) * per, total);
	end = min(first + per, total);
}

// The lane's first item of a run starting at `first`, as (x, y) in a side-wide raster.
ivec2 patch_run_start(int first, int side)
{
	int i = first + int(gl_LocalInvocationID.x);
	return ivec2(i % side, i / side);
}

// The item RUN_LANES further on in raster order (side >= 1).
ivec2 patch_run_next(ivec2 g, int side)
{
	g.x += RUN_LANES;
	while (g.x >= side) {
		g.x -= side;
		g.y++;
	}
	return g;
}
