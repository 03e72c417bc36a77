// The frame's depth reduced to a lower resolution (core/internal/reduced_target.hpp): per texel, the
// farthest depth of the frame's pixels it covers (so that clouds are computed wherever any of them
// sees past the objects; the upsampling sorts out which pixel gets what). Depths stay in the
// frame's convention (farthest = the largest, or the smallest with reversed Z).
#include "view_frame.glsl"
uniform sampler2D frameDepth;
uniform vec2 fullSize, reducedSize;  // pixels
void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);  // the reduced target is drawn at its own origin
    // The block of full-resolution pixels whose centres fall in this texel.
    vec2 scale = fullSize / reducedSize;
    ivec2 last = ivec2(fullSize) - 1;
    ivec2 lo = ivec2(ceil(vec2(t) * scale - 0.5)), hi = ivec2(ceil(vec2(t + 1) * scale - 0.5)) - 1;
    lo = clamp(lo, ivec2(0), last);
    hi = clamp(max(hi, lo), ivec2(0), last);
    bool reversed = noSurfaceDepth() < 0.5;
    float d = reversed ? 1.0 : 0.0;
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            float z = frameDepthAt(frameDepth, ivec2(x, y));
            d = reversed ? min(d, z) : max(d, z);
        }
    gl_FragDepth = d;
}
