// The layers' cloud shadows as a pass of their own (full resolution, or more than
// kShadowLayers layers): the frame's rgb multiplied by cloudShadow() (blend ZERO, SRC_COLOR;
// alpha untouched). See layered_shadow.glsl.
#include "layered_shadow.glsl"
in vec2 ndc;
out vec4 color;
uniform sampler2D frameDepth;  // the frame's depth (view_frame.glsl)
uniform bool hasDepth;         // false: the frame has no depth buffer (ground only)
void main() {
    float depth = hasDepth ? frameDepthAt(frameDepth, viewPixel()) : noSurfaceDepth();
    color = vec4(vec3(cloudShadow(ndc, depth)), 1.0);
}
