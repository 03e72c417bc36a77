// Compositing (section 3.6): the tile as a textured rectangle at its screen place, "over".
// Variants by #define (llvmpipe runs both sides of every branch, so what a frame does not
// need is compiled out rather than skipped at run time):
//   FUSED     the colour-matrix copy is applied here as the atlas is read (no pass of its own)
//   FRACTION  objects inside clouds: weight by the optical depth in front of the opaque depth
//   WEIGHTED  order-independent: instead of "over", accumulate w a c and w a (attachment 0,
//             additive) and a (attachment 1, which keeps prod(1 - a)); composite_resolve.frag
//             puts the result over the frame. w = compositeWeight of this pixel's shading depth.
//   MOMENTS   (with WEIGHTED) the moment composite's second pass: w = the transmittance in front
//             of this contribution, from the pixel's moments (momentTransmittance)
//   MOMENTS_PASS (with WEIGHTED) its first: the absorbance A = -ln(1 - a) times (z, z^2, z^3,
//             z^4) (attachment 0) and A (attachment 1), both added
#define MODEL_FN
#include "gardner_model.glsl"
#include "tiles.glsl"
#include "view_frame.glsl"
flat in int tileIndex;
flat in vec4 atlasRect;
in vec2 atlasCoord;
in vec3 ndcH;                         // the frame's NDC: xy / z (tile_quad.vert)
uniform sampler2DArray atlasTerms;    // green, blue: the light scalars (sun, sky; encodeLight), alpha: eq. (2)
#ifdef FUSED
uniform mat4 colourMatrix;            // red / D -> alpha (what the colour-matrix pass would subtract)
#endif
uniform vec3 sunIrradiance;           // sun.color * sun.intensity
uniform float albedo;
uniform vec2 atlasSize;
#if defined(FRACTION) || defined(WEIGHTED)
uniform vec3 forward;                 // unit view axis
uniform vec3 rayCentre, rightScaled, upScaled;  // the ray through NDC (x, y): rayCentre + x rightScaled + y upScaled
uniform float nearClip;               // m
#endif
#ifdef FRACTION
uniform sampler2D sceneDepth;         // the frame's depth (view_frame.glsl)
#endif
#ifdef WEIGHTED
uniform float weightExponent;         // k of w = (tRef / tShade)^k
uniform float weightReference;        // tRef, m (weightReferenceDepth in gardner.cpp)
layout(location = 0) out vec4 accum;  // rgb: w a c, a: w a (blended ONE, ONE)
layout(location = 1) out vec4 reveal; // r: a (blended ZERO, ONE_MINUS_SRC_COLOR: the target keeps prod(1 - a))
#if defined(MOMENTS) || defined(MOMENTS_PASS)
uniform vec2 momentRange;             // [tNear, tFar] of the depth warp (momentDepthRange in gardner.cpp)
#endif
#ifdef MOMENTS
uniform sampler2D momentSums;         // the first pass's sum of A (z, z^2, z^3, z^4)
uniform sampler2D momentZero;         // ... and of A
#endif
#else
out vec4 result;
#endif
void main() {
    // Stay half a texel inside the tile so that filtering never reads a neighbour.
    vec2 lo = atlasRect.xy + 0.5, hi = atlasRect.xy + atlasRect.z - 0.5;
    vec3 uv = vec3(clamp(atlasCoord, lo, hi) / atlasSize, atlasRect.w);
    vec4 terms = texture(atlasTerms, uv);
#ifdef FUSED
    float alpha = clamp(terms.a - (colourMatrix * terms).a, 0.0, 1.0);
#else
    float alpha = clamp(terms.a, 0.0, 1.0);
#endif
    if (alpha <= 0.0) discard;  // outside the ellipsoid: neither the ray's terms nor the blend
    vec3 color = sourceFromScalars(vec3(decodeLight(terms.g), decodeLight(terms.b), 0.0), sunIrradiance,
                                   tiles[tileIndex].skyChroma.rgb, albedo);
#if defined(FRACTION) || defined(WEIGHTED)
    // This pixel's ray in the ellipsoid's unit space (as gardner-exact evaluates it).
    Tile t = tiles[tileIndex];
    vec2 ndc = ndcH.xy / ndcH.z;
    vec3 d = normalize(rayCentre + ndc.x * rightScaled + ndc.y * upScaled);
    float cosF = dot(d, forward);
    vec3 o = t.eyeUnitAc.xyz, du = toUnit(t, d);
    float tStart = t.params.x > 0.5 ? nearClip / cosF : 0.0;
#endif
#ifdef FRACTION
    if (alpha > 0.0) {
        float z = frameDepthAt(sceneDepth, viewPixel());
        if (isSurface(z)) {
            float tObj = eyeDepthOf(z) / cosF;
            float whole = segmentDepth(o, du, tStart, 1e30);
            float front = segmentDepth(o, du, tStart, tObj);
            alpha = opacityInFront(alpha, front, whole);
        }
    }
#endif
#if defined(MOMENTS) || defined(MOMENTS_PASS)
    // The moments' depth: the chord's matter depth, per pixel. (The tile's, its ellipsoid's centre
    // distance, would spare both passes their ray maths, but popped at an order flip nearly as
    // back to front does: 0.030 against 0.032 in GardnerExactTest, 0.014 per pixel.)
    float z = momentDepth(matterDepth(o, du, tStart), momentRange.x, momentRange.y);
#endif
#if defined(WEIGHTED) && defined(MOMENTS_PASS)
    float z2 = z * z;
    float absorbance = absorbanceOf(alpha);
    accum = absorbance * vec4(z, z2, z2 * z, z2 * z2);
    reveal = vec4(absorbance);
#elif defined(WEIGHTED)
#ifdef MOMENTS
    ivec2 pixel = viewPixel();  // the targets are the view's size
    float b0 = texelFetch(momentZero, pixel, 0).r;
    vec4 m = texelFetch(momentSums, pixel, 0) / b0;
    float w = momentWeight(b0, m.x, m.y, m.z, m.w, z, alpha);
#else
    float w = compositeWeight(matterDepth(o, du, tStart), weightReference, weightExponent);
#endif
    float wa = w * alpha;
    accum = vec4(color * wa, wa);
    reveal = vec4(alpha);
#else
    result = vec4(color, alpha);
#endif
}
