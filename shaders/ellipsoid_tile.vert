// The ellipsoid pass: one ellipsoid per instance, drawn by its back faces (a circumscribed
// mesh, so that it covers the exact silhouette even with the eye inside), in its tile.
#include "tiles.glsl"
layout(location = 0) in vec3 position;   // on the circumscribed unit-sphere mesh
uniform int instanceBase;                // first tile of this draw
uniform vec2 atlasSize;                  // px
uniform int foldAtlas;                   // 1: the tile's place is folded into the projection (instanced)
                                         // 0: the caller set the viewport to the tile (one draw per ellipsoid)
flat out int tileIndex;
out vec3 relPosition;                    // camera-relative world position
void main() {
    tileIndex = instanceBase + gl_InstanceID;
    Tile t = tiles[tileIndex];
    vec3 world = t.centerSigma.xyz + tileAxes(t) * position;
    vec4 clip = t.tileViewProj * vec4(world, 1.0);
    // Keep the ellipsoid inside its tile even where its rectangle was clipped to the view.
    gl_ClipDistance[0] = clip.w + clip.x;
    gl_ClipDistance[1] = clip.w - clip.x;
    gl_ClipDistance[2] = clip.w + clip.y;
    gl_ClipDistance[3] = clip.w - clip.y;
    if (foldAtlas == 1) {
        vec2 scale = vec2(t.atlasRect.z) / atlasSize;
        vec2 offset = (2.0 * t.atlasRect.xy + t.atlasRect.z) / atlasSize - 1.0;
        clip.xy = clip.xy * scale + offset * clip.w;
    }
    relPosition = world;
    gl_Position = clip;
}
