// Nephele's Gardner ellipsoid model: ONE source compiled as GLSL by the tile and composite
// shaders and as C++ (with glm) by the exact CPU model, so the two cannot drift apart
// (model/include/nephele/gardner_model.hpp includes this file). Keep to the common subset:
// float and vec3 only, every literal with an `f` suffix, functions prefixed MODEL_FN.
//
// Conventions. An ellipsoid with centre c, rotation R and radii r has the unit-space map
// M = diag(1/r) * R^T, x -> M (x - c); its density is density * (1 - q)^2 with q = |M(x-c)|^2.
// A ray o + t d with unit world direction d (t in metres) is o' + t d' in unit space,
// o' = M (o - c), d' = M d.

// Antiderivative of (h2 - u^2)^2 in u: h2^2 u - 2/3 h2 u^3 + u^5 / 5.
MODEL_FN float chordPrimitive(float u, float h2) {
    float u2 = u * u;
    return u * (h2 * h2 - u2 * (0.6666667f * h2 - 0.2f * u2));
}

// A ray o' + t d' (unit space of an ellipsoid) against the unit sphere, in the unit-space arc
// length u from the ray's closest approach to the centre: len = |M d| (unit length per metre),
// tc the closest approach's arc length, h2 = 1 - b^2 with b the impact parameter (<= 0: the
// ray misses), h = sqrt(max(h2, 0)), and [tMin, tMax] as [u0, u1] clamped to the chord [-h, h].
// Every closed form along a chord (segmentDepth, shadeDepth, matterDepth, chordSampleDepth,
// erodedSegmentDepth) starts from it.
struct ChordSpan {
    float len;
    float tc;
    float h2;
    float h;
    float u0;
    float u1;
};
MODEL_FN ChordSpan chordSpan(vec3 oUnit, vec3 dUnit, float tMin, float tMax) {
    ChordSpan c;
    c.len = length(dUnit);
    vec3 dn = dUnit / c.len;
    c.tc = -dot(oUnit, dn);
    vec3 perp = oUnit + c.tc * dn;
    c.h2 = 1.0f - dot(perp, perp);
    c.h = sqrt(max(c.h2, 0.0f));
    c.u0 = clamp(tMin * c.len - c.tc, -c.h, c.h);
    c.u1 = clamp(tMax * c.len - c.tc, -c.h, c.h);
    return c;
}
// The chord beyond tStart: u1 = h.
MODEL_FN ChordSpan chordBeyond(vec3 oUnit, vec3 dUnit, float tStart) {
    ChordSpan c = chordSpan(oUnit, dUnit, tStart, tStart);
    c.u1 = c.h;
    return c;
}

// Integral of (1 - q)^2 dt over t in [tMin, tMax] for one ellipsoid, in metres: the
// ellipsoid's optical depth divided by (extinction * density). Exact and closed form:
// with u the unit-space distance from the ray's closest approach to the centre and
// b^2 = 1 - h2 the squared impact parameter, q = b^2 + u^2 and the integrand is (h2 - u^2)^2.
// Numerically stable far from the ellipsoid (no difference of large polynomials in t).
MODEL_FN float segmentDepth(vec3 oUnit, vec3 dUnit, float tMin, float tMax) {
    ChordSpan c = chordSpan(oUnit, dUnit, tMin, tMax);
    if (c.h2 <= 0.0f || tMax <= tMin) return 0.0f;
    return (chordPrimitive(c.u1, c.h2) - chordPrimitive(c.u0, c.h2)) / c.len;
}

// The whole chord: 16/15 (1 - b^2)^(5/2) / |M d|, with radial profile F(b) = (1 - b^2)^(5/2)
// (the projective radial-falloff texture holds F).
MODEL_FN float radialProfile(float b2) {
    float h2 = max(1.0f - b2, 0.0f);
    return h2 * h2 * sqrt(h2);
}
const float kChordScale = 1.0666667f;  // 16/15

// ---- Eq. (2) of Elinas & Stuerzlinger with the constants derived from the medium:
//   alpha = ((I - T1) - T2 (1 - g)) / D,   D = kTranslucence, T1 = 0, T2 = D,
// where the opacity it gives is the density field's. With noise that is the field the path
// tracer renders, density (1 + noise n(x)), n the fBm noise in [-1, 1], read here at one point
// of the chord (the shading point):
//   alpha = 1 - (1 - A)^max(1 + noise n, 0)   (A = 1 - exp(-tau), the smooth field's opacity)
// The radial falloff carries what the smooth field takes off the centre's opacity Ac:
//   1 - g = min(Ac - A, 1 - alpha),   I / D = alpha + (1 - g)
// (both in [0, 1], as the 8-bit atlas needs). With noise 0 that is I / D = Ac and
// g = 1 - Ac (1 - A / Ac): the paper's textured ellipsoid and radial texture, alpha = A exactly.
// Gardner's own use of the noise, a threshold (I / D = Ac (1 + noise n),
// g = 1 - Ac (1 + noise) (1 - A / Ac)), cut away every rim where A < Ac noise / (1 + noise): the
// thin edges a path tracer shows, and against the sun the silver lining (README, "The light").
const float kTranslucence = 0.5f;  // D

// The optical depth (absorbance) of opacity a; opacity 1 taken as 1 - 1e-6 (13.8), so that
// the moment composite's sums stay finite.
MODEL_FN float absorbanceOf(float a) { return -log(max(1.0f - a, 1e-6f)); }

MODEL_FN float noisyOpacity(float a, float noiseAmp, float n) {
    return 1.0f - exp(-absorbanceOf(a) * max(1.0f + noiseAmp * n, 0.0f));
}
// Eq. (2)'s two terms (I / D, g) of a chord of smooth opacity a, from one noisy opacity.
MODEL_FN vec2 gardnerTerms(float ac, float a, float noiseAmp, float n) {
    float alpha = noisyOpacity(a, noiseAmp, n);
    float falloff = min(max(ac - a, 0.0f), 1.0f - alpha);  // 1 - g
    return vec2(alpha + falloff, 1.0f - falloff);
}
// What the blending and the colour-matrix pass compute from the two terms (before clamping).
MODEL_FN float gardnerAlpha(float iOverD, float g) { return iOverD - kTranslucence * (1.0f - g) / kTranslucence; }

// An opaque object inside an ellipsoid is covered only by the matter in front of it: the
// ellipsoid's opacity alpha, scaled in optical depth by the fraction front / whole.
MODEL_FN float opacityInFront(float alpha, float front, float whole) {
    if (front <= 0.0f || whole <= 0.0f) return 0.0f;
    return 1.0f - pow(max(1.0f - alpha, 1e-7f), min(front / whole, 1.0f));
}

// The depth along the ray (m) of an ellipsoid's shading point: the ray's closest approach to
// the centre in unit space, clamped to the chord the eye sees, [max(tIn, tStart), tOut]
// (tStart: the near plane's distance along the ray when the near plane cuts the ellipsoid,
// else 0). The per-pixel order and the weighted composite's weights are by this depth.
MODEL_FN float shadeDepth(vec3 oUnit, vec3 dUnit, float tStart) {
    ChordSpan c = chordBeyond(oUnit, dUnit, tStart);
    float tIn = (c.tc - c.h) / c.len, tOut = (c.tc + c.h) / c.len;
    return min(max(c.tc / c.len, max(tIn, tStart)), tOut);
}

// The depth along the ray (m) of the centroid of an ellipsoid's matter the eye sees (density
// along the chord beyond tStart), in closed form: with u as in segmentDepth, the first moment
// of (h2 - u^2)^2 over [u0, h] is (h2 - u0^2)^3 / 6. Unlike shadeDepth it does not collapse
// to the near plane as the eye passes the centre of an ellipsoid it is inside (the matter
// left is ahead), so weights taken from it change as smoothly as the matter does.
MODEL_FN float matterDepth(vec3 oUnit, vec3 dUnit, float tStart) {
    ChordSpan c = chordBeyond(oUnit, dUnit, tStart);
    if (c.h2 <= 0.0f) return max(c.tc / c.len, tStart);
    float mass = chordPrimitive(c.h, c.h2) - chordPrimitive(c.u0, c.h2);
    float a0 = c.h2 - c.u0 * c.u0;
    float u = mass > 0.0f ? a0 * a0 * a0 / (6.0f * mass) : c.u0;
    return max((c.tc + u) / c.len, tStart);
}

// ---- The weighted, order-independent composite (after McGuire & Bavoil 2013, "Weighted
// blended order-independent transparency"). Per pixel, over the contributions i (opacity
// a_i, colour c_i, shading depth t_i):
//   colour = sum(w_i a_i c_i) / sum(w_i a_i),  opacity = 1 - prod(1 - a_i),
// composited "over" the background once. The opacity is exactly the back-to-front one;
// the colour is a weighted mean in which nearer matter counts more. The weight is a power
// of a depth ratio, w = (tRef / t)^k: after the division only ratios of weights matter, and
// (t2 / t1)^k is the same at every distance (no scale to tune), continuous in t (so in the
// eye's position: nothing can flip). tRef, one per frame below every shading depth
// (weightReferenceDepth in gardner.cpp), keeps w in (0, 1]; the floor keeps the sums above
// zero in float (RGBA32F accumulation), reached only at t > tRef * 1e30^(1/k).
const float kWeightExponent = 3.0f;  // k, chosen against the exact model (docs/compositor.md, "Why these constants")
// tRef is at least this (m): matter nearer than it weighs alike. Without it, the moment the eye
// enters an ellipsoid its matter, then metres away, outweighs everything behind it a
// thousandfold whatever its opacity, and the colour jumps in one frame. Views from outside
// (every shading depth beyond it) do not change. About a cumulus puff's radius; the flicker
// bench chose it (docs/compositor.md).
const float kWeightNearDepth = 100.0f;
MODEL_FN float compositeWeight(float tShade, float tRef, float exponent) {
    return max(pow(tRef / max(tShade, tRef), exponent), 1e-30f);
}

// ---- The moment-based order-independent composite (after Munstermann, Krumpen, Klein & Peters
// 2018, "Moment-based order-independent transparency"): the weighted composite with, as each
// contribution's weight, the transmittance of the matter in front of it, reconstructed from
// the pixel's first moments of absorbance over depth. A first pass sums, per pixel, b0 =
// sum(A_i) and b_k = sum(A_i z_i^k), k = 1..4, with A_i = -ln(1 - a_i) and z_i the contribution's
// depth warped to [-1, 1]; the second weighs each contribution by T(z_i) from them. Where the
// contributions are few or far apart in depth it is the back-to-front order (a back-lit
// cloud's bright far rims stay behind its dark front); it is continuous in every depth and
// opacity, so nothing can flip.
const float kMomentBias = 5e-7f;            // the paper's for four power moments in 32-bit floats
const float kMomentOverestimation = 0.25f;  // the share of its own absorbance a contribution sees in front of it
const float kMomentBiasEven = 0.375f;       // the bias vector (0, 0.375, 0, 0.375)
// The depth warp: log(t / tNear) over the frame's [tNear, tFar] to [-1, 1] (a depth ratio, as the
// weighted composite's weight: the same resolution at every distance).
MODEL_FN float momentDepth(float t, float tNear, float tFar) {
    float z = log(max(t, tNear) / tNear) / max(log(tFar / tNear), 1e-6f);
    return clamp(2.0f * z - 1.0f, -1.0f, 1.0f);
}
// The transmittance in front of depth z from b0 and the moments m1..m4 = b_k / b0 (the paper's
// Hamburger reconstruction: the bounds of the canonical representation, Cholesky of the 3x3
// Hankel matrix, the roots of a quadratic).
MODEL_FN float momentTransmittance(float b0, float m1, float m2, float m3, float m4, float z) {
    // Bias towards a valid moment vector: rounding can leave the sums just outside the set.
    m1 = m1 * (1.0f - kMomentBias);
    m2 = m2 * (1.0f - kMomentBias) + kMomentBias * kMomentBiasEven;
    m3 = m3 * (1.0f - kMomentBias);
    m4 = m4 * (1.0f - kMomentBias) + kMomentBias * kMomentBiasEven;
    float l21d11 = m3 - m1 * m2;
    float d11 = m2 - m1 * m1;
    float invD11 = 1.0f / d11;
    float l21 = l21d11 * invD11;
    float d22 = (m4 - m2 * m2) - l21d11 * l21;
    // c = B^-1 (1, z, z^2) by forward substitution, scaling and backward substitution.
    float c0 = 1.0f, c1 = z, c2 = z * z;
    c1 = c1 - m1;
    c2 = c2 - (m2 + l21 * c1);
    c1 = c1 * invD11;
    c2 = c2 / d22;
    c1 = c1 - l21 * c2;
    c0 = c0 - (c1 * m1 + c2 * m2);
    // The roots z1 <= z2 of c0 + c1 x + c2 x^2.
    float p = c1 / c2, q = c0 / c2;
    float r = sqrt(max(p * p * 0.25f - q, 0.0f));
    float z1 = -p * 0.5f - r, z2 = -p * 0.5f + r;
    // The absorbance in front of z: the weights of the roots in front (and kMomentOverestimation
    // of z's own), as the interpolating polynomial's dot product with the moments.
    float f0 = kMomentOverestimation, f1 = z1 < z ? 1.0f : 0.0f, f2 = z2 < z ? 1.0f : 0.0f;
    float f01 = (f1 - f0) / (z1 - z);
    float f12 = (f2 - f1) / (z2 - z1);
    float f012 = (f12 - f01) / (z2 - z);
    float q1 = f01 - f012 * z1;
    float q2 = f012;
    float q0 = f0 - q1 * z;
    q1 = q1 - q2 * z;
    float absorbance = q0 + q1 * m1 + q2 * m2;
    // Matter at one depth leaves the Hankel matrix singular to float precision (the bias's share
    // of it lost to rounding): there the transmittance in front is the contribution's own share.
    float t = exp(-b0 * absorbance);
    if (!(t >= 0.0f)) t = exp(-b0 * kMomentOverestimation);
    // (Floored as compositeWeight: a pixel's weights never all vanish, whatever its opacity.)
    return clamp(t, 1e-30f, 1.0f);
}
// A contribution's weight: the transmittance in front of it without the share of its own
// absorbance the reconstruction counts in front of it (kMomentOverestimation of it; exact for one
// contribution, and for contributions far apart in depth). Without this an opaque
// contribution (absorbance up to 13.8) saw exp(-0.25 x 13.8) = 3% of itself: a bright thin veil
// in front of a cloud's opaque body outweighed the body 30-fold.
MODEL_FN float momentWeight(float b0, float m1, float m2, float m3, float m4, float z, float alpha) {
    return min(momentTransmittance(b0, m1, m2, m3, m4, z) * exp(kMomentOverestimation * absorbanceOf(alpha)), 1.0f);
}

// Opacity of optical depth tau.
MODEL_FN float opacityOf(float tau) { return 1.0f - exp(-tau); }

// ---- Colour (section 3.5): each ellipsoid's colour is the light its chord sends to the eye
// (cloud_light.glsl), per unit of its opacity: the noise, which scales the chord's density,
// changes its opacity, not its colour. (A brightening where the noise thickens the cloud,
// 1 + noise n / 2, was tried against the path tracer: without it the error fell on every
// scene measured, back-lit cumulus27 18.2% -> 18.0%, from 2 km 11.2% -> 10.7%, single.json
// 8.8% -> 8.2%; README, "The light".)

// The light of cloud matter (single scattering, the grids' diffuse light): cloud_light.glsl.
#include "cloud_light.glsl"
