// Wang, Ji & Zhang 2011 appearance: density by the 2D modulation texture (eqs. 14-16), wind
// (18), city glow (20), lightning (21); the light of the shared model (cloud_light.glsl) from the
// layer's column depths and photon-traced light tables (layer_light.glsl), the skylight as a
// second directional light (its single scattering).
// Output premultiplied: (radiance * alpha, alpha), blended ONE, ONE_MINUS_SRC_ALPHA.
#define MODEL_FN
#include "gardner_model.glsl"
#include "layer_light.glsl"
in vec3 rel;
layout(location = 0) out vec4 color;
#ifdef REUSE
layout(location = 1) out vec4 moments;  // ReducedTarget's: (a d, a d^2, 0, a), d = the distance to the eye in km
#endif
uniform int mode;                  // 0 = annuli, 1 = billboards
uniform sampler3D lightVolume;     // rgb = encoded knots of the optical depth above, a = density A
uniform sampler2D columns;         // rgb = encoded knots of the whole column's optical depth
uniform sampler2D sunTable, sunManyTable, skyTable;  // the frame's light tables (layerSource())
uniform sampler2D modulation;      // r = threshold, g = city map, b = threshold^2 (its mean over a mip texel)
uniform vec2 uvLightEye;           // fract((eye.xy - t wind) / tilePeriod)
uniform vec2 uvModEye;             // fract((eye.xy - t wind) / modulationPeriod)
uniform float gradScale;           // 1 / LayeredSettings::downsample: the textures' detail of a full-resolution pixel
uniform vec2 uvCityEye;            // fract(eye.xy / modulationPeriod): cities do not move with the wind
uniform float invLightPeriod, invModPeriod;  // 1/m
uniform float base, thickness, eyeHeight;    // m
uniform float coverage, density;   // C, D in [0, 1]
uniform float extinction;          // 1/m at density 1
uniform float albedo;
uniform float layerSlab;           // m, thickness / N: the slab one annulus stands for
uniform float lod0Radius, lod0Spacing;  // m
uniform vec2 sliceAxis;
uniform float steepTan;            // tan of the elevation where annuli and billboards sample equally well
uniform float extent, fadeStart;   // m
uniform float nearRadius, blendBand;  // m
uniform vec3 sunDirection, sunIrradiance;  // unit; colour * intensity
uniform vec3 sunHorizontal;        // unit, the sun's horizontal direction
uniform float sunFromAbove, sunMu; // 1 when the sun is above the horizon, else 0; max(|s.z|, 0.01)
uniform vec3 skyDirection, skyIrradiance;  // skylight (0 when the scene has none)
uniform float skyFromAbove, skyMu;
uniform float hgG;                 // medium.hg_g
uniform vec3 glow;                 // city glow colour * strength (0: none)
uniform float glowHeightCoeff;     // f_c of eq. (20)
uniform int flashCount;
#ifndef MAX_FLASHES
#error "MAX_FLASHES: build with layered/src/renderer.cpp's defines"
#endif
uniform vec4 flashes[MAX_FLASHES]; // xyz relative to the eye (m), w = intensity

// Phi(x), the standard normal distribution, by the logistic 1 / (1 + exp(-1.702 x)) (within 0.01).
float normalCdf(float x) { return 1.0 / (1.0 + exp(-1.702 * x)); }

// E[max(X, 0)] for X normal with mean mu and deviation s: mu Phi(mu / s) + s phi(mu / s).
float expectedPositivePart(float mu, float s) {
    if (s < 1e-4) return max(mu, 0.0);
    float x = mu / s;
    return mu * normalCdf(x) + s * 0.3989423 * exp(-0.5 * x * x);
}

void main() {
    // Texture coordinates and their derivatives before any discard (implicit derivatives in
    // non-uniform control flow are undefined).
    vec2 uvMod = uvModEye + rel.xy * invModPeriod;
    vec2 uvMdx = dFdx(uvMod) * gradScale, uvMdy = dFdy(uvMod) * gradScale;
    vec3 uvw = vec3(uvLightEye + rel.xy * invLightPeriod, (rel.z + eyeHeight - base) / thickness);
    vec3 uvwdx = dFdx(uvw) * gradScale, uvwdy = dFdy(uvw) * gradScale;
    float horizontal = length(rel.xy);
    if (horizontal > extent) discard;
    vec3 d = normalize(rel);
    float zf = (rel.z + eyeHeight - base) / thickness;
    if (zf < -1e-3 || zf > 1.0 + 1e-3) discard;
    // Who stands for the volume here: inside the billboard disc, annuli for steep rays,
    // billboards for grazing ones; a fragment's optical depth takes its share.
    float tanElev = abs(d.z) / max(length(d.xy), 1e-6);
    float annulusShare = smoothstep(0.5 * steepTan, 2.0 * steepTan, tanElev);
    // At the billboard disc's rim: an annulus stands for the ray's path across one slab, a run of
    // layerSlab / tan(e) horizontally around the fragment; within the disc the billboards stand
    // for the grazing rays' share of it, so an annulus keeps that share only of the part of its
    // run outside the disc. (With the rim as a hard switch, a ray that climbed into a slab inside
    // the disc and left the disc before the next annulus met no matter in between and saw that
    // annulus, deeper in the layer: a bright line at the rim looking along a deck's base.)
    float share, path;
    if (mode == 0) {
        float run = layerSlab / max(tanElev, 1e-4);
        float outside = lod0Radius > 0.0 ? clamp((horizontal + 0.5 * run - lod0Radius) / run, 0.0, 1.0) : 1.0;
        share = mix(annulusShare, 1.0, outside);
        path = layerSlab / max(abs(d.z), 1e-4);
    } else {
        if (horizontal > lod0Radius) discard;
        share = 1.0 - annulusShare;
        path = lod0Spacing / max(abs(dot(d.xy, sliceAxis)), 1e-4);
    }
    share *= 1.0 - smoothstep(fadeStart, extent, horizontal);
    if (horizontal < nearRadius) discard;
    if (blendBand > 0.0) share *= smoothstep(nearRadius, nearRadius + blendBand, horizontal);
    // Cheap tests first (llvmpipe pays per texture fetch): no share, or a threshold that no
    // A <= 1 can pass (eq. 16 is 0 where r >= C), means no matter here.
    if (share < 1e-4) discard;
    // Far away a fetch returns the mean of the threshold r over the pixel's footprint, and eq.
    // (16)'s max() of the mean loses the thin peaks that the mean of the max() keeps (a distant
    // layer was 0.29 opaque where the path tracer's volume is 0.40): the mean of the max() over
    // a normal spread of r with its variance over the footprint (its mipmaps' mean of r^2). A's
    // own spread is left out: counted as well (per mip level), it overshot the volume's opacity.
    vec3 mod3 = textureGrad(modulation, uvMod, uvMdx, uvMdy).rgb;
    float r = mod3.r, spread = sqrt(max(mod3.b - r * r, 0.0));
    // No A <= 1 passes the threshold anywhere here (with coverage 0 nowhere: r >= 0).
    if (coverage <= 0.0 || r - 3.0 * spread >= coverage) discard;
    vec4 t3 = textureGrad(lightVolume, vec3(uvw.xy, clamp(zf, 0.0, 1.0)), uvwdx, uvwdy);
    float theta = r + 1.0 - coverage, mu = t3.a - theta;
    // The footprint is cloudy over Phi(mu / spread) of it; the slab's opacity is that share of
    // an opaque part, not the mean density spread over the whole pixel.
    float cloudy = spread < 1e-4 ? 1.0 : normalCdf(mu / spread);
    float rho = density * expectedPositivePart(mu, spread);  // eq. (16), the footprint's mean
    float alpha = cloudy * (1.0 - exp(-extinction * rho / max(cloudy, 1e-4) * path * share));
    if (alpha <= 0.0) discard;
    // The column's optical depths above and below, the light tables there, the source function.
    vec3 depths = layerColumnDepths(t3.rgb, textureGrad(columns, uvw.xy, uvwdx.xy, uvwdy.xy).rgb, theta, density);
    vec2 uvTable = vec2(layerTableCoord(depths.x), layerTableCoord(depths.y));
    float tauSun = mix(depths.y, depths.x, sunFromAbove) / sunMu;
    vec3 radiance = layerSource(textureLod(sunTable, uvTable, 0.0), textureLod(sunManyTable, uvTable, 0.0),
                                textureLod(skyTable, uvTable, 0.0), tauSun, d,
                                sunDirection, sunHorizontal, hgG, sunIrradiance, albedo);
    radiance +=
        albedo * skyIrradiance * singleScatter(d, skyDirection, hgG, mix(depths.y, depths.x, skyFromAbove) / skyMu);
    // City glow, eq. (20).
#ifdef CITY_GLOW  // (a program of its own: llvmpipe would fetch the city map even where no layer glows)
    if (glow != vec3(0.0)) {
        float city = textureGrad(modulation, uvCityEye + rel.xy * invModPeriod, uvMdx, uvMdy).g;
        radiance += glow * city * (1.0 - clamp(glowHeightCoeff * zf, 0.0, 1.0));
    }
#endif
    // Lightning, eq. (21): I / d^2 for the flashes active now.
    float flash = 0.0;
    for (int i = 0; i < flashCount; ++i) {
        vec3 v = rel - flashes[i].xyz;
        flash += flashes[i].w / max(dot(v, v), 1.0);
    }
    radiance += vec3(albedo / kLightPi * flash);
    color = vec4(radiance * alpha, alpha);
#ifdef REUSE
    float eyeDistance = min(length(rel) * 1e-3, 250.0);  // km: d^2 within a half float's range
    moments = vec4(alpha * eyeDistance, alpha * eyeDistance * eyeDistance, 0.0, alpha);
#endif
}
