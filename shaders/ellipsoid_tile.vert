// The ellipsoid pass: one ellipsoid per instance, drawn by its back faces (a circumscribed
// mesh, so that it covers the exact silhouette even with the eye inside), in its tile.
// What varies slowly over the ellipse is evaluated per vertex, as the paper's Gouraud-lit,
// texture-mapped ellipsoids are: the light the vertex's chord sends to the eye (from the
// cloud's radiance grid, cloud_light_grid.glsl), the noise coordinates of its shading point,
// and the 1/|M d| scale of the chord. What shapes the
// ellipse is per pixel: the projective falloff coordinates are linear in the vertex
// position and divided per fragment, as OpenGL's projective texturing does.
// CUT (a second program): ellipsoids cut by the near plane, or around the eye, whose
// opacity is the exact chord beyond the near plane per pixel; they need the ray instead.
#define MODEL_FN
#include "gardner_model.glsl"
#include "detail.glsl"
#include "tiles.glsl"
#include "cloud_light_grid.glsl"
layout(location = 0) in vec3 position;   // on the circumscribed unit-sphere mesh
uniform int instanceBase;                // first tile of this draw
uniform vec2 atlasSize;                  // px
uniform int foldAtlas;                   // 1: the tile's place is folded into the projection (instanced)
                                         // 0: the caller set the viewport to the tile (one draw per ellipsoid)
uniform float nearClip;                  // m
uniform vec3 forward;                    // unit view direction
uniform vec3 eyeNoise;                   // fract(eye / noisePeriod)
uniform float noisePeriod;               // m
uniform vec3 sunDirection;               // unit, towards the sun
uniform float hgG;                       // medium.hg_g
uniform DetailParams detail;             // medium.detail (erosion 0: off), as the fragment shader's
uniform sampler3D detailVolume;
flat out int tileIndex;
#ifdef CUT
out vec3 relPosition;                    // camera-relative world position (the ray)
#else
out vec3 projCoord;                      // projective falloff coordinates (x, y, w)
out vec3 rayRel;                         // camera-relative world position: the ray, for the detail
#endif
out float invLen;                        // 1 / |M d|: metres of ray per unit of unit space
out vec3 noiseCoord;                     // shading point in noise texture coordinates
#ifndef CUT
out vec2 light;                          // the chord's light scalars: sun, sky (chordLightAt)
#endif
flat out vec4 instance;                  // Ac, sigma (1/m), L^2 = |M (eye - c)|^2, 1 if cut by the near plane

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
    gl_Position = clip;
#ifdef CUT
    relPosition = world;
#else
    rayRel = world;
#endif
    instance = vec4(t.eyeUnitAc.w, t.centerSigma.w, dot(t.eyeUnitAc.xyz, t.eyeUnitAc.xyz), t.params.x);

    // The ray through this vertex, in unit space: o + s du.
    vec3 o = t.eyeUnitAc.xyz;
    vec3 d = normalize(world);
    vec3 du = toUnit(t, d);
    float len = length(du);
    invLen = 1.0 / len;
    // Projective coordinates: where the ray meets the plane through the centre facing the
    // eye, p = o + s du with p.c = 0, in homogeneous form (linear in the vertex position).
#ifndef CUT
    vec3 c = -normalize(o);
    vec3 e1 = normalize(cross(c, abs(c.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    vec3 e2 = cross(c, e1);
    float w = dot(du, c);
    vec3 ph = o * w - du * dot(o, c);
    projCoord = vec3(dot(ph, e1), dot(ph, e2), w);
#endif

    // The shading point: the ray's closest approach to the centre, within its chord.
    vec3 dn = du / len;
    float tc = -dot(o, dn);
    vec3 perp = o + tc * dn;
    float h = sqrt(max(1.0 - dot(perp, perp), 0.0));
    float tStart = t.params.x > 0.5 ? nearClip / max(dot(d, forward), 1e-6) : 0.0;
    float tIn = (tc - h) / len, tOut = (tc + h) / len;
    float tShade = clamp(tc / len, max(tIn, tStart), max(tOut, tStart));
    vec3 shade = tShade * d;
    noiseCoord = shade / noisePeriod + eyeNoise + t.noiseOffset.xyz;
#ifndef CUT
    // With the detail, the light follows the eroded chord (erodedGrowth, detail.glsl).
    float grow = 1.0;
#if defined(DETAIL) && !defined(FALLOFF_TEXTURE)
    grow = erodedGrowth(detailVolume, detail, o, du, d, tStart);
#endif
    light = chordLightAt(int(t.params.y), o * grow, du * grow, d, tStart, t.centerSigma.w, sunDirection, hgG);
#endif
}
