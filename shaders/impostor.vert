// A cloud impostor (EllipsoidSettings::cloudLod) as a quad over the frame: its image's clip
// space (x, y) in [-1, 1]^2 taken to the frame's clip space by `reproject` (cloud_impostors.hpp),
// its image read perspective-correct across it; depth 0 keeps it from the near and far planes.
uniform mat4 reproject;
uniform vec4 imageRect;            // texels: x, y of its corner in the atlas layer, w, h
out vec2 texel;                    // texels in the atlas layer
out vec3 ndcH;                     // the frame's NDC as x, y, w (xy / w), as tile_quad.vert's
void main() {
    vec2 corner = vec2(gl_VertexID & 1, (gl_VertexID >> 1) & 1);
    vec4 clip = reproject * vec4(corner * 2.0 - 1.0, 0.0, 1.0);
    texel = imageRect.xy + corner * imageRect.zw;
    ndcH = clip.xyw;
    gl_Position = vec4(clip.xy, 0.0, clip.w);
}
