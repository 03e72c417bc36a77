// Eq. (2)'s terms and the colour of one ellipsoid per pixel of its tile, the ray per pixel
// (EllipsoidSettings::geometry = Polygon): the same terms as ellipsoid_tile.frag, blended
// the same way into the cleared (T2, 1, 1, T1 / D), but with the opacity, the shading point
// and its noise evaluated exactly per pixel, as `gardner-exact` does, and the chord's light
// from the radiance grid per pixel, instead of interpolated from a mesh's vertices. Outside
// the ellipse (the polygon circumscribes it) eq. (2) is non-positive.
// CUT: ellipsoids cut by the near plane (or around the eye): the chord beyond the near plane.
#define MODEL_FN
#include "gardner_model.glsl"
#include "detail.glsl"
#include "tiles.glsl"
#include "cloud_light_grid.glsl"
in vec3 ray;                           // camera-relative point on the ray (m)
in vec3 rayUnit;                       // M ray
flat in vec4 instance;                 // Ac, sigma (1/m), unused, cut
flat in vec3 eyeUnit;
flat in vec3 unitRow0, unitRow1, unitRow2;
flat in vec3 noiseBase;
flat in int cloud;
out vec4 terms;
uniform vec3 forward;                  // unit view direction
uniform float nearClip;                // m
uniform float noisePeriod;             // m
uniform sampler3D noiseVolume;         // tileable fBm, [-1, 1]
uniform float noiseAmp;                // medium.noise
uniform DetailParams detail;           // medium.detail (detail.erosion 0: off)
uniform sampler3D detailVolume;        // the nephele kind's texture
uniform int detailPieces;              // as ellipsoid_tile.frag
uniform vec3 sunDirection;             // unit, towards the sun
uniform float hgG;                     // medium.hg_g

void main() {
    float ac = instance.x;
    float invRay = inversesqrt(dot(ray, ray));
    vec3 d = ray * invRay;
    vec3 du = rayUnit * invRay;          // M d
    float len = length(du);
    vec3 dn = du / len;
    vec3 o = eyeUnit;
    float tc = -dot(o, dn);              // closest approach to the centre, unit-space arc length
    vec3 perp = o + tc * dn;
    float h2 = 1.0 - dot(perp, perp);    // 1 - b^2
#ifdef CUT
    float tStart = nearClip / dot(d, forward);
    float depth = segmentDepth(o, du, tStart, 1e30);
#else
    const float tStart = 0.0;
    float depth = kChordScale * radialProfile(1.0 - h2) / len;
#endif
    // The shading point: the ray's closest approach to the centre, within its chord.
    float h = sqrt(max(h2, 0.0));
    float tIn = (tc - h) / len, tOut = (tc + h) / len;
    float tShade = clamp(tc / len, max(tIn, tStart), max(tOut, tStart));
    vec3 shade = tShade * d;
    float n = texture(noiseVolume, shade / noisePeriod + noiseBase).r;
    float grow = 1.0;  // the light follows the eroded chord
#ifdef DETAIL
    if (depth > 0.0) depth = erodedSegmentDepth(detailVolume, detail, o, du, d, tStart, 1e30, detailPieces);
    grow = erodedGrowth(detailVolume, detail, o, du, d, tStart);
#endif
    vec2 light = chordLightAt(cloud, o * grow, du * grow, d, tStart, instance.y, sunDirection, hgG);
    // Outside the silhouette: no matter (A = 0) makes eq. (2) zero whatever Ac and n are; the colour
    // terms go on smoothly, so that filtering at the rim mixes in no foreign colour.
    bool inside = depth > 0.0;
    float a = opacityOf(instance.y * depth);
    vec2 eq2 = gardnerTerms(ac, inside ? a : 0.0, noiseAmp, n);
    terms = vec4(kTranslucence * eq2.y, 1.0 - encodeLight(light.x), 1.0 - encodeLight(light.y), eq2.x);
}
