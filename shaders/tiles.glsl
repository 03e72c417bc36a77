// Per-ellipsoid data of one frame, shared by the compositor's shaders (std430; filled by
// ellipsoid/src/compositor.cpp, struct GpuTile). Positions are camera-relative (eye at 0).
struct Tile {
    vec4 centerSigma;   // xyz: centre - eye (m); w: extinction * density (1/m)
    vec4 axes0;         // columns of R diag(r): unit sphere -> world offset (m)
    vec4 axes1;
    vec4 axes2;
    vec4 unit0;         // rows of M = diag(1/r) R^T: world offset -> unit sphere
    vec4 unit1;
    vec4 unit2;
    vec4 eyeUnitAc;     // xyz: M (eye - c); w: Ac, the largest opacity
    mat4 tileViewProj;  // camera-relative world -> tile clip space ([-1,1]^2 = the tile)
    vec4 atlasRect;     // x, y, size (px) in the atlas; w: layer (pass)
    vec4 screenRect;    // NDC x0, y0, x1, y1 on the frame
    vec4 params;        // x: 1 if cut by the near plane (or the eye inside); y: cloud index; z: 1 if reused
                        // (drawn through reproject, not screenRect); w: unused
    vec4 noiseOffset;   // xyz: offset in noise texture coordinates
    vec4 rayCentre;     // xyz: camera-relative direction through the tile's centre (unnormalised, m)
    vec4 rayX;          // xyz: its change per unit of tile clip x (tile clip space [-1,1]^2)
    vec4 rayY;          // xyz: its change per unit of tile clip y
    vec4 skyChroma;     // rgb: the sky light's colour at the ellipsoid (model::skyChroma)
    mat4 reproject;     // params.z = 1 (a reused tile): tile clip (x, y, 0, 1) -> the frame's clip space
};
layout(std430) readonly buffer Tiles { Tile tiles[]; };  // binding kTilesBinding (compositor.cpp)

mat3 tileAxes(Tile t) { return mat3(t.axes0.xyz, t.axes1.xyz, t.axes2.xyz); }
vec3 toUnit(Tile t, vec3 v) { return vec3(dot(t.unit0.xyz, v), dot(t.unit1.xyz, v), dot(t.unit2.xyz, v)); }

// The atlas's light scalars (green, blue): as they are in a float atlas; x / (1 + x) in an
// 8-bit one (ATLAS_UNORM8), which holds only [0, 1] (forward-scattered sunlight exceeds 1).
float encodeLight(float x) {
#ifdef ATLAS_UNORM8
    return x / (1.0 + x);
#else
    return x;
#endif
}
float decodeLight(float e) {
#ifdef ATLAS_UNORM8
    return e / max(1.0 - e, 1.0 / 255.0);
#else
    return e;
#endif
}
