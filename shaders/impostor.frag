// A cloud impostor over the frame: premultiplied colour and opacity (blended ONE,
// ONE_MINUS_SRC_ALPHA: "over", as its tiles were composited into it).
//   FRACTION  objects inside clouds: the impostor's opacity cut to the share of the cloud's
//             bounding sphere along the ray in front of the opaque depth (the tiles' per-
//             ellipsoid fraction, composite.frag, at the scale of the whole cloud)
#define MODEL_FN
#include "gardner_model.glsl"
#include "view_frame.glsl"
uniform sampler2DArray impostors;
uniform float layer;
uniform vec4 imageRect;            // texels: x, y, w, h
uniform float atlasSize;           // texels per side of a layer
in vec2 texel;
in vec3 ndcH;                      // the frame's NDC: xy / z
#ifdef FRACTION
uniform sampler2D sceneDepth;      // the frame's depth (view_frame.glsl)
uniform vec3 forward;              // unit view axis
uniform vec3 rayCentre, rightScaled, upScaled;  // the ray through NDC (x, y): rayCentre + x rightScaled + y upScaled
uniform vec3 cloudCentre;          // m, camera-relative: the cloud's bounding sphere
uniform float cloudRadius;         // m
#endif
out vec4 result;
void main() {
    // Half a texel inside its image, so that filtering never reads a neighbour.
    vec2 lo = imageRect.xy + 0.5, hi = imageRect.xy + imageRect.zw - 0.5;
    vec4 c = texture(impostors, vec3(clamp(texel, lo, hi) / atlasSize, layer));
    if (c.a <= 0.0) discard;
#ifdef FRACTION
    float z = frameDepthAt(sceneDepth, viewPixel());
    if (isSurface(z)) {
        vec2 ndc = ndcH.xy / ndcH.z;
        vec3 d = normalize(rayCentre + ndc.x * rightScaled + ndc.y * upScaled);
        float tObj = eyeDepthOf(z) / dot(d, forward);
        float tc = dot(cloudCentre, d);
        float h = sqrt(max(cloudRadius * cloudRadius - (dot(cloudCentre, cloudCentre) - tc * tc), 0.0));
        float front = clamp((tObj - (tc - h)) / max(2.0 * h, 1e-6), 0.0, 1.0);
        float a = min(c.a, 1.0);
        c *= opacityInFront(a, front, 1.0) / a;
    }
#endif
    result = c;
}
