// Eq. (2)'s terms and the colour of one ellipsoid, per fragment of its tile, into one
// attachment blended reverse-subtractively (rgb) and subtractively (alpha) into the
// cleared (T2, 1, 1, T1 / D):
//   red   = T2 - T2 g      (g from the projective radial falloff texture)
//   green = 1 - (1 - sun) = sun         (the chord's light scalars, cloud_light.glsl,
//   blue  = 1 - (1 - sky) = sky          encodeLight'ed in an 8-bit atlas)
//   alpha = I / D - T1 / D (I the noise-textured ellipsoid: gardner_model.glsl)
// CUT (cut by the near plane, or around the eye): the light too per pixel from the exact chord
// beyond the near plane. Such an ellipsoid fills much of the view and its chords change fast
// across it (a few metres ahead to hundreds): Gouraud light is visibly off there.
#define MODEL_FN
#include "gardner_model.glsl"
#include "detail.glsl"
#include "tiles.glsl"
#ifdef CUT
#include "cloud_light_grid.glsl"
uniform vec3 sunDirection;             // unit, towards the sun
uniform float hgG;                     // medium.hg_g
#endif
flat in int tileIndex;
#ifdef CUT
in vec3 relPosition;
#else
in vec3 projCoord;
in vec3 rayRel;
#endif
in float invLen;
in vec3 noiseCoord;
#ifndef CUT
in vec2 light;
#endif
flat in vec4 instance;                 // Ac, sigma, L^2, cut (per ellipsoid: no storage read per fragment)
out vec4 terms;
uniform vec3 forward;                  // unit view direction
uniform float nearClip;                // m
#ifdef FALLOFF_TEXTURE
uniform sampler2D falloff;             // projective radial falloff: F(b) = (1 - b^2)^(5/2) over [-1,1]^2
#endif
uniform sampler3D noiseVolume;         // tileable fBm, [-1, 1]
uniform float noiseAmp;                // medium.noise
uniform DetailParams detail;           // medium.detail (detail.erosion 0: off)
uniform sampler3D detailVolume;        // the nephele kind's texture
// The chord's eroded depth is followed in detailPieces pieces (DetailTexture::kTilePieces), each
// eroded by the detail at its middle (in closed form, detail.glsl): a chord near the rim keeps
// matter only where its pieces' erosion leaves the shrunk ellipsoid reaching it. A uniform, not a
// constant, so that the compiler keeps one copy of the octave loop instead of one per piece.
uniform int detailPieces;
#ifndef CUT
vec3 rayOf() { return rayRel; }
#else
vec3 rayOf() { return relPosition; }
#endif

void main() {
    float ac = instance.x;
#ifdef CUT
    // Cut by the near plane, or the eye inside: the exact chord beyond the near plane.
    Tile t = tiles[tileIndex];
    vec3 d = normalize(relPosition);
    float tStart = nearClip / dot(d, forward);
    float depth = segmentDepth(t.eyeUnitAc.xyz, toUnit(t, d), tStart, 1e30);
    float grow = 1.0;  // the light follows the eroded chord (erodedGrowth, detail.glsl)
#if defined(DETAIL) && !defined(FALLOFF_TEXTURE)
    grow = erodedGrowth(detailVolume, detail, t.eyeUnitAc.xyz, toUnit(t, d), d, tStart);
#endif
    vec2 light = chordLightAt(int(t.params.y), t.eyeUnitAc.xyz * grow, toUnit(t, d) * grow, d, tStart, instance.y,
                              sunDirection, hgG);
#else
    // The plane point at radius rho lies on the ray with impact parameter
    // b = rho L / sqrt(L^2 + rho^2) (L: the eye's unit-space distance to the centre):
    // the texture is read at radius b, in the direction of the plane point. FALLOFF_TEXTURE:
    // from the paper's projective radial texture (256^2, bilinear); else F(b) in closed form,
    // the same function without the texture's resampling, and cheaper on llvmpipe, where a
    // texture lookup costs more than the few multiplications.
    vec2 st = projCoord.xy / projCoord.z;
    float l2 = instance.z;
    st *= sqrt(l2 / (l2 + dot(st, st)));
#ifdef FALLOFF_TEXTURE
    float depth = kChordScale * texture(falloff, st * 0.5 + 0.5).r * invLen;
#else
    float depth = kChordScale * radialProfile(dot(st, st)) * invLen;  // the texture's F in closed form
#endif
#endif
    if (depth <= 0.0) {
        // Outside the silhouette (the circumscribed mesh is larger): no matter (A = 0) makes eq. (2)
        // zero whatever Ac is, and saves the noise lookup.
        vec2 eq2 = gardnerTerms(ac, 0.0, noiseAmp, 0.0);
        terms = vec4(kTranslucence * eq2.y, 1.0 - encodeLight(light.x), 1.0 - encodeLight(light.y), eq2.x);
        return;
    }
    float n = texture(noiseVolume, noiseCoord).r;
    // The paper's falloff-texture variant (EllipsoidSettings::falloffTexture) draws no detail:
    // llvmpipe's LLVM 15 aborted compiling it with the detail (stack smashing in EarlyCSE).
#if defined(DETAIL) && !defined(FALLOFF_TEXTURE)
    {  // the exact chord of this pixel's ray, eroded (detail.glsl)
        Tile tile = tiles[tileIndex];
        vec3 dr = normalize(rayOf());
        float t0 = instance.w > 0.5 ? nearClip / dot(dr, forward) : 0.0;
        depth =
            erodedSegmentDepth(detailVolume, detail, tile.eyeUnitAc.xyz, toUnit(tile, dr), dr, t0, 1e30, detailPieces);
    }
#endif
    float a = opacityOf(instance.y * depth);
    vec2 eq2 = gardnerTerms(ac, a, noiseAmp, n);
    terms = vec4(kTranslucence * eq2.y, 1.0 - encodeLight(light.x), 1.0 - encodeLight(light.y), eq2.x);
}
