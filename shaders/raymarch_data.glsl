// The ray-marcher's per-frame data (std430; filled by volume/src/raymarch.cpp, structs
// GpuEllipsoid and GpuCloud). Positions are camera-relative (eye at 0), lengths in metres.
#ifndef MAX_CANDIDATES
#define MAX_CANDIDATES 32   // ellipsoids of one cloud held per gather (more: gathered again)
#endif
#ifndef MAX_CLOUD_HITS
#define MAX_CLOUD_HITS 8    // clouds sorted per batch (more: further batches)
#endif

struct RmEllipsoid {
    vec4 eyeUnitSigma;  // xyz: M (eye - c), the eye in the unit sphere's space; w: extinction * density (1/m)
    vec4 unit0;         // rows of M = diag(1/r) R^T: world offset -> unit sphere
    vec4 unit1;
    vec4 unit2;
};
struct RmCloud {
    vec4 boxMin;        // xyz: the cloud's box (raymarchCloudBox), camera-relative
    vec4 boxMax;
    ivec4 range;        // x: first ellipsoid, y: count, z: the scene cloud (its radiance grid)
};
// The bindings are raymarch.cpp's (buildMarch), said there once.
layout(std430) readonly buffer RmEllipsoids { RmEllipsoid ellipsoids[]; };
layout(std430) readonly buffer RmClouds { RmCloud clouds[]; };
// The clouds each screen tile of RM_TILE x RM_TILE pixels must test (indices into clouds[],
// from raymarch.cpp's binning of the boxes' projections): tile t's are
// tileClouds[tileFirst[t] .. tileFirst[t + 1]); the first tileFirst[0] entries are the clouds
// every pixel tests (boxes that reach behind the near plane).
#ifndef RM_TILE  // raymarch.cpp's kTile, given when it builds the program
#error "RM_TILE: build with raymarch.cpp's defines"
#endif
// (Bindings 5 and 6: 3 is cloud_light_grid.glsl's boxes; raymarch.cpp binds these two.)
layout(std430) readonly buffer RmTileFirst { int tileFirst[]; };
layout(std430) readonly buffer RmTileClouds { int tileClouds[]; };
