// A view's counters (binding 5, struct counters in common/gpu/terrain_internal.h) as the
// passes that write them declare them; the drawing stages and the factor pass read words of
// them as texels (terrain_draw.glsl).
layout(std430, binding = 5) buffer Counters {
	uint drawn; uint draws; uint wants; uint curtains;
	uvec4 factor_groups, border_groups; // VkDispatchIndirectCommand of lod_factors.comp, lod_borders.comp
	// Back faces (lod_eye.glsl): culled in this frame; a drawn block holds the eye; the
	// highest block near it, an ordered key (height_key()) while the selection raises it,
	// metres (float bits) once lod_borders.comp has decided; the decision the draws use.
	uint face_culled; uint found; uint near_high; uint draw_culled;
	// Draw records of the shown list's quads without seals for the culling pipeline, for
	// the other, of the clipped list's, and the quads in the clipped list; draw_sealed the
	// same for the quads with seals, but its last word the shown list's records of them;
	// the quads with seals (lod_commands.comp).
	uvec4 draw_split, draw_sealed;
	uint sealed_quads;
} counters;
