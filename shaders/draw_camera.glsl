// The camera a view's picture is drawn with (binding 15, struct draw_camera in
// common/gpu/terrain_internal.h): its view-projection, equal to pc.vp unless the level of
// detail was chosen for another camera (relief_draw_options.lod_view; pc.vp stays the
// LOD's), draw_eye(): the drawing camera's eye (lod_eye.glsl, back faces), w the
// clip-space z 0.1 % nearer than the far plane (lod_factors.comp, block_clip()), and
// draw_cull(): what the back-face decision needs besides (lod_eye.glsl, eye_decide()).
// Read as six RGBA32F texels of a uniform texel buffer, not as a storage buffer: every lane
// reads the same words, and lavapipe (Mesa 22.3) loads a storage buffer lane by lane even
// at a uniform address, 20 scalar loads per lane where a texel fetch is one gather per
// texel (docs/lod-performance.md, "The draw camera and the per-patch tables read as
// texels"). Only the frame's transfer writes it.
layout(binding = 15) uniform samplerBuffer draw_camera;

mat4 draw_vp()
{
	return mat4(texelFetch(draw_camera, 0), texelFetch(draw_camera, 1), texelFetch(draw_camera, 2),
	            texelFetch(draw_camera, 3));
}

vec4 draw_eye() { return texelFetch(draw_camera, 4); }

vec4 draw_cull() { return texelFetch(draw_camera, 5); }
