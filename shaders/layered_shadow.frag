// Cloud shadows of one far-field layer, Wang, Ji & Zhang 2011 eq. (19), multiplied onto the
// frame already drawn (blend ZERO, SRC_COLOR on rgb; alpha untouched): as the paper says,
// "the multiplication of S to the rendering results of the scene".
//   S = 1 - D max(T_S - (r + 1 - C), 0), T_S = 1 (the column's peak alpha),
// r the modulation texture's threshold where the ray from the surface point towards the sun
// crosses the layer's middle, read with the layer shader's wind (eq. 18). The CPU twin is
// sunTransmittance() in layered/src/modulation.cpp: keep the two equal (layered_gl_test).
// Surfaces: every pixel with depth < 1 (the scene's objects, a host's terrain and aircraft) is
// a point on a sunlit opaque surface (its colour is the format's sun-only Lambert term, so the
// whole colour is multiplied); a pixel at depth 1 whose ray goes down is the format's ground,
// taken to be the plane z = groundHeight, of which only the sun's share is shadowed.
// Where a pixel spans more than a texel of the threshold texture, its mipmaps filter it.
in vec2 ndc;
out vec4 color;
uniform sampler2D frameDepth;      // a copy of the frame's depth (depth in [0, 1])
uniform bool hasDepth;             // false: the frame has no depth buffer (ground only)
uniform sampler2D modulation;      // r = threshold
uniform vec3 forward;              // unit view direction
uniform vec3 rightScaled, upScaled;  // camera right * tan(half fov x), up * tan(half fov y)
uniform float nearClip, farClip;   // m
uniform float eyeHeight;           // m, eye z
uniform float groundHeight;        // m, z of the ground plane
uniform float groundSunShare;      // in [0, 1]: the sun's share of the ground's light
uniform vec3 sunDirection;         // unit, towards the sun (z > 0)
uniform float middle;              // m, the layer's middle height (base + thickness / 2)
uniform vec2 uvModEye;             // fract((eye.xy - t wind) / modulationPeriod)
uniform float invModPeriod;        // 1/m
uniform float coverage, density;   // C, D in [0, 1]
void main() {
    // A ray whose component along `forward` is 1: the point at eye-space depth z is ray * z.
    vec3 ray = forward + ndc.x * rightScaled + ndc.y * upScaled;
    float depth = hasDepth ? texelFetch(frameDepth, ivec2(gl_FragCoord.xy), 0).r : 1.0;
    vec3 rel;            // m, the surface point relative to the eye
    float share = 1.0;   // how much of the pixel's light is the sun's
    bool surface = true;
    if (depth < 1.0) {
        float zn = 2.0 * depth - 1.0;
        rel = ray * (2.0 * nearClip * farClip / ((farClip + nearClip) - zn * (farClip - nearClip)));
    } else if (ray.z < 0.0 && eyeHeight > groundHeight) {
        rel = ray * ((groundHeight - eyeHeight) / ray.z);
        share = groundSunShare;
    } else {
        rel = ray * farClip;  // the sky: no surface, but a point for its neighbours' derivatives
        surface = false;
    }
    float h = eyeHeight + rel.z;
    vec2 q = rel.xy + sunDirection.xy * ((middle - h) / max(sunDirection.z, 1e-6));
    // The threshold texture's footprint: the plain level 0 (the CPU twin) wherever a pixel is
    // smaller than a texel; filtered further out, where level 0 would alias on the ground
    // near the horizon. Derivatives before any discard.
    vec2 uv = uvModEye + q * invModPeriod;
    vec2 uvdx = dFdx(uv), uvdy = dFdy(uv);
    if (!surface || h >= middle) discard;  // at or above the layer's middle: no shadow (as the CPU twin)
    float r = textureGrad(modulation, uv, uvdx, uvdy).r;
    float s = 1.0 - density * max(coverage - r, 0.0);  // eq. (19) with T_S = 1
    color = vec4(vec3(1.0 - share * (1.0 - s)), 1.0);
}
