// The weighted, order-independent composite's resolve (McGuire & Bavoil 2013): one full-screen
// pass that puts the accumulated clouds "over" the frame, with the blending of the
// back-to-front composite (rgb: SRC_ALPHA, ONE_MINUS_SRC_ALPHA; alpha: ONE,
// ONE_MINUS_SRC_ALPHA, so the frame's alpha accumulates the cloud opacity):
//   colour = sum(w a c) / sum(w a),  opacity = 1 - prod(1 - a).
#include "view_frame.glsl"
uniform sampler2D accumTexture;   // rgb: sum of w a c, a: sum of w a
uniform sampler2D revealTexture;  // r: prod of (1 - a)
out vec4 result;
void main() {
    ivec2 p = viewPixel();  // the targets are the view's size
    vec4 accum = texelFetch(accumTexture, p, 0);
    if (!(accum.a > 0.0)) discard;  // no cloud here (also keeps 0 / 0 out of the frame)
    float opacity = 1.0 - texelFetch(revealTexture, p, 0).r;
    result = vec4(accum.rgb / accum.a, opacity);
}
