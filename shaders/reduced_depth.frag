// The frame's depth reduced to a lower resolution (core/internal/reduced_target.hpp): per texel, the
// farthest depth of the frame's pixels it covers (so that clouds are computed wherever any of them
// sees past the objects; the upsampling sorts out which pixel gets what). Depths stay in the
// frame's convention (farthest = the largest, or the smallest with reversed Z).
//
// With REUSE, the same pass also keeps what it can of the last frame's image (ReducedTarget's
// history): a kept texel gets the last image's colour at the point it shows, reprojected by its
// mean distance, and the depth of the near plane, which the draws that follow fail against (so
// llvmpipe shades only the others); a texel drawn afresh gets 0 and its depth.
#include "view_frame.glsl"
uniform sampler2D frameDepth;
uniform vec2 fullSize, reducedSize;  // pixels
#ifdef NO_DEPTH
float blockDepth(ivec2 t, out bool surface) {
    surface = false;
    return noSurfaceDepth();
}
#else
float blockDepth(ivec2 t, out bool surface) {
    // The block of full-resolution pixels whose centres fall in this texel.
    vec2 scale = fullSize / reducedSize;
    ivec2 last = ivec2(fullSize) - 1;
    ivec2 lo = ivec2(ceil(vec2(t) * scale - 0.5)), hi = ivec2(ceil(vec2(t + 1) * scale - 0.5)) - 1;
    lo = clamp(lo, ivec2(0), last);
    hi = clamp(max(hi, lo), ivec2(0), last);
    bool reversed = noSurfaceDepth() < 0.5;
    float d = reversed ? 1.0 : 0.0;
    surface = false;
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            float z = frameDepthAt(frameDepth, ivec2(x, y));
            d = reversed ? min(d, z) : max(d, z);
            surface = surface || isSurface(z);
        }
    return d;
}
#endif

#ifndef REUSE
void main() {
    bool surface;
    gl_FragDepth = blockDepth(ivec2(gl_FragCoord.xy), surface);  // the reduced target is drawn at its own origin
}
#else
layout(location = 0) out vec4 color;    // premultiplied, as the draws write it
layout(location = 1) out vec4 moments;  // (a d, a d^2, accumulated parallax bound in px, a), d in km
uniform sampler2D lastColor, lastMoments;
uniform bool haveLast;            // the last image can be reprojected (else every texel afresh)
uniform mat3 rayOf;               // the world direction through NDC (x, y) is rayOf * (x, y, 1)
uniform mat4 lastViewProjection;  // the last frame's, its eye at the origin
uniform vec3 shift;               // m: a point seen at p from this eye was at p + shift from the last eye
uniform int period, phase;        // a texel's turn to be drawn afresh
uniform float maxError;           // px: the bound past which a texel is drawn afresh
uniform float weatherError;       // px: what the weather's step since the last frame adds to the bound
uniform float focal;              // px per radian
uniform float nearest;            // m: the nearest matter may be where the last image has none
uniform float nearPlane;          // the depth of the near plane: a kept texel's, which every draw fails against
layout(std430) buffer Kept {      // the texels kept, over KEPT_COUNTERS counters by row (less contention)
    uint keptCount[KEPT_COUNTERS];
};

// A texel whose block held a surface: its bound, so large that no texel reprojected from
// near it is kept (what the surface hid is unknown; a cloud in front of it all but opaque, 1 -
// alpha < 1e-3, leaves some of it, rightly: the surface does not show then).
const float kSurfaceBound = 1e6;

// The point at distance `dist` along `dir` from this eye, on the last image (xy), and its clip w.
vec3 onLastImage(vec3 dir, float dist) {
    vec4 c = lastViewProjection * vec4(dir * dist + shift, 1.0);
    return vec3(c.xy / c.w * 0.5 + 0.5, c.w);
}

// Whether the texel keeps the last image's colour: into `kept` and `keptMoments` if so.
bool reproject(ivec2 t, out vec4 kept, out vec4 keptMoments) {
    kept = vec4(0.0), keptMoments = vec4(0.0);
    // 8x8 blocks take turns in a 4x4 Bayer order, so each frame's share is spread over the image.
    ivec2 b = (t >> 3) & 3;
    int order = 4 * (2 * ((b.x ^ b.y) & 1) + (b.y & 1)) + 2 * (((b.x ^ b.y) >> 1) & 1) + ((b.y >> 1) & 1);
    if (!haveLast || order % period == phase) return false;
    vec3 dir = normalize(rayOf * vec3((vec2(t) + 0.5) / reducedSize * 2.0 - 1.0, 1.0));
    // Its distance: the last image's mean where the direction was (matter far away), then where
    // the point at that distance was.
    vec4 c = lastViewProjection * vec4(dir, 0.0);
    if (c.w <= 0.0) return false;
    vec2 uv = c.xy / c.w * 0.5 + 0.5;
    vec4 m = texture(lastMoments, uv);
    vec3 p = onLastImage(dir, m.w > 1e-3 ? m.x / m.w * 1e3 : 1e7);
    if (p.z <= 0.0) return false;
    uv = p.xy;
    vec2 margin = 0.5 / reducedSize;
    if (any(lessThan(uv, margin)) || any(greaterThan(uv, 1.0 - margin))) return false;
    // A texel the view has not moved from (a still view, a second channel of the same view): its
    // own texel exactly, not a bilinear mix off the centre by the matrices' round-off.
    vec2 texel = uv * reducedSize - 0.5;
    if (all(lessThan(abs(texel - round(texel)), vec2(1e-3)))) uv = (round(texel) + 0.5) / reducedSize;
    m = texture(lastMoments, uv);
    // The parallax bound. The eye's sideways move turns the view of a point by side / mean: the
    // reprojection follows the point, but what depends on the view's angle does not follow it:
    // the angle to the sun (the phase function's forward lobe), and the angle to the layers'
    // slabs, whose path through them goes as 1 / |dir.z| (a grazing ray's opacity changes by
    // cot(elevation) times the turn). Matter spread over distances [mean - spread, mean +
    // spread] moves apart by side * spread / mean^2. Where nothing was drawn, matter at
    // `nearest` may have come into view.
    vec3 side = shift - dir * dot(shift, dir);
    float mean = m.x / max(m.w, 1e-6), spread = sqrt(max(m.y / max(m.w, 1e-6) - mean * mean, 0.0));  // km
    float grazing = 1.0 / max(abs(dir.z), 0.02);
    float turn = m.w > 1e-3 ? (grazing + spread / mean) / (mean * 1e3) : 1.0 / nearest;
    // A weather ramp's step adds to it too: a texel drawn k frames ago shows the weather of k
    // steps ago, so under a ramp texels are drawn afresh every few frames, not all at once.
    float error = m.z + length(side) * focal * turn + weatherError;
    if (error > maxError) return false;
    kept = texture(lastColor, uv);
    keptMoments = vec4(m.xy, error, m.w);
    return true;
}

void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);
    bool surface;
    float d = blockDepth(t, surface);
    vec4 kept, keptMoments;
    // A surface in the block: the draws' depth test decides there, afresh.
    bool keep = !surface && reproject(t, kept, keptMoments);
    color = keep ? kept : vec4(0.0);
    moments = keep ? keptMoments : vec4(0.0, 0.0, surface ? kSurfaceBound : 0.0, 0.0);
    gl_FragDepth = keep ? nearPlane : d;
    if (keep) atomicAdd(keptCount[t.y % KEPT_COUNTERS], 1u);
}
#endif
