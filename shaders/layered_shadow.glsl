// Cloud shadows of the far-field layers, Wang, Ji & Zhang 2011 eq. (19), per pixel of the
// frame: "the multiplication of S to the rendering results of the scene".
//   S = 1 - D max(T_S - (r + 1 - C), 0), T_S = 1 (the column's peak alpha),
// r the modulation texture's threshold where the ray from the surface point towards the sun
// crosses the layer's middle, read with the layer shader's wind (eq. 18); the product over
// the layers above the point. The formula is layer_shadow.glsl's, which sunTransmittance() in
// layered/src/modulation.cpp compiles as C++ (layered_shadow_gl_test compares the two).
// Surfaces: every pixel with depth < 1 (the scene's objects, a host's terrain and aircraft) is
// a point on a sunlit opaque surface (its colour is the format's sun-only Lambert term, so the
// whole colour is multiplied); a pixel at depth 1 whose ray goes down is the format's ground,
// taken to be the plane z = groundHeight, of which only the sun's share is shadowed.
// Where a pixel spans more than a texel of the threshold texture, its mipmaps filter it.
// Used by layered_shadow.frag (its own pass) and reduced_upsample.frag (fused into the
// upsampling of the reduced-resolution layers, compiled per layer count with SHADOW_LAYERS
// defined: llvmpipe runs every instruction of a shader, so a dynamically indexed sampler
// array and a loop sized by a uniform cost more than the unrolled count).
#define MODEL_FN
#include "layer_shadow.glsl"
#include "view_frame.glsl"
// The array size is the C++ side's (kMaxShadowLayers, core/internal/reduced_target.hpp), given
// by the programs that include this file.
#ifndef SHADOW_SLOTS
#error "SHADOW_SLOTS: build with shadowSlotsDefine() (core/internal/reduced_target.hpp)"
#endif
const int kShadowLayers = SHADOW_SLOTS;
uniform int shadowLayerCount;               // 0..kShadowLayers
uniform sampler2D shadowModulation[kShadowLayers];  // r = threshold
uniform vec2 shadowUvModEye[kShadowLayers];  // fract((eye.xy - t wind) / modulationPeriod)
uniform float shadowMiddle[kShadowLayers];   // m, the layer's middle height (base + thickness / 2)
uniform float shadowCoverage[kShadowLayers], shadowDensity[kShadowLayers];  // C, D in [0, 1]
uniform float shadowInvModPeriod;            // 1/m
uniform vec3 shadowRayCentre;                // the ray through NDC (0, 0), unit component along the view axis
uniform vec3 shadowRightScaled, shadowUpScaled;  // camera right, up * half the frustum's width, height at unit distance
uniform float shadowFar;                     // m, the camera's far clip distance
uniform float shadowEyeHeight;               // m, eye z
uniform float groundHeight;                  // m, z of the ground plane
uniform float groundSunShare;                // in [0, 1]: the sun's share of the ground's light
uniform vec3 shadowSun;                      // unit, towards the sun (z > 0)

// The factor for the colour of the pixel at `ndc` whose window depth is `depth` (in the view's
// convention, view_frame.glsl): 1 where the pixel is sky or above every shadowing layer's middle.
float cloudShadow(vec2 ndc, float depth) {
    // A ray whose component along the view direction is 1: the point at eye-space depth z is ray * z.
    vec3 ray = shadowRayCentre + ndc.x * shadowRightScaled + ndc.y * shadowUpScaled;
    vec3 rel;            // m, the surface point relative to the eye
    float share = 1.0;   // how much of the pixel's light is the sun's
    bool surface = true;
    if (isSurface(depth)) {
        rel = ray * eyeDepthOf(depth);
    } else if (ray.z < 0.0 && shadowEyeHeight > groundHeight) {
        rel = ray * ((groundHeight - shadowEyeHeight) / ray.z);
        share = groundSunShare;
    } else {
        rel = ray * shadowFar;  // the sky: no surface, but a point for its neighbours' derivatives
        surface = false;
    }
    float h = shadowEyeHeight + rel.z;
    float s = 1.0;
#ifdef SHADOW_LAYERS
    for (int i = 0; i < SHADOW_LAYERS; ++i) {  // a compile-time count: unrolled, constant sampler indices
#else
    for (int i = 0; i < shadowLayerCount; ++i) {
#endif
        vec2 q = rel.xy + shadowRayOffset(shadowSun, h, shadowMiddle[i]);
        vec2 uv = shadowUvModEye[i] + q * shadowInvModPeriod;
        float r = textureGrad(shadowModulation[i], uv, dFdx(uv), dFdy(uv)).r;
        s *= layerShadow(h, shadowMiddle[i], r, shadowCoverage[i], shadowDensity[i]);
    }
    return surface ? 1.0 - share * (1.0 - s) : 1.0;
}
