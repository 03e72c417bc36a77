// One tile per instance as a quad: in the atlas (colour matrix, floor) or on the screen (composite).
#include "tiles.glsl"
uniform int instanceBase;
uniform vec2 atlasSize;            // px
uniform int onScreen;              // 0: the tile's atlas rectangle; 1: its screen rectangle
// The composite order (back to front); binding kOrderBinding (compositor.cpp).
layout(std430) readonly buffer Order { int order[]; };
uniform int useOrder;
flat out int tileIndex;
out vec2 atlasCoord;               // px in the atlas
// Screen NDC (onScreen) as x, y, w, interpolated perspective-correct: the fragment's NDC is
// xy / w. (A noperspective NDC of a quad whose w varies, a reused tile's, is interpolated anew
// in screen space at the vertices where the view's edges clip the quad; llvmpipe's is NaN over
// part of such a quad, and a NaN fraction in front of the host's depth draws the tile whole over
// near geometry.)
out vec3 ndcH;
flat out vec4 atlasRect;           // the tile's x, y, size (px) and layer
// onScreen: the frame's NDC rectangle the viewport holds (a cloud impostor's pixels while it is
// made, EllipsoidSettings::cloudLod); the whole view by default.
uniform vec4 targetRect = vec4(-1.0, -1.0, 1.0, 1.0);
vec2 toTarget(vec2 xy, float w) {
    return (xy - 0.5 * (targetRect.xy + targetRect.zw) * w) / (0.5 * (targetRect.zw - targetRect.xy));
}
void main() {
    int k = instanceBase + gl_InstanceID;
    tileIndex = useOrder == 1 ? order[k] : k;
    Tile t = tiles[tileIndex];
    atlasRect = t.atlasRect;
    vec2 corner = vec2(gl_VertexID & 1, (gl_VertexID >> 1) & 1);
    atlasCoord = t.atlasRect.xy + corner * t.atlasRect.z;
    if (onScreen == 1 && t.params.z > 0.5) {
        // A reused tile: its plane reprojected to this frame (tile_reuse.hpp), the atlas read
        // perspective-correct across it; depth 0 keeps it from the near and far planes.
        vec4 clip = t.reproject * vec4(corner * 2.0 - 1.0, 0.0, 1.0);
        ndcH = clip.xyw;
        gl_Position = vec4(toTarget(clip.xy, clip.w), 0.0, clip.w);
        return;
    }
    vec2 ndc = mix(t.screenRect.xy, t.screenRect.zw, corner);
    ndcH = vec3(ndc, 1.0);
    gl_Position = vec4(onScreen == 1 ? toTarget(ndc, 1.0) : atlasCoord / atlasSize * 2.0 - 1.0, 0.0, 1.0);
}
