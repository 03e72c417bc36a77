// DetailGLTest: evaluates the detail field (shaders/detail.glsl) at the given points relative to
// the eye, so the test can compare the GLSL twin with the C++ one.
#define MODEL_FN
#include "gardner_model.glsl"
#include "detail.glsl"
layout(local_size_x = 64) in;

uniform sampler3D detailVolume;
uniform DetailParams detail;
layout(std430, binding = 0) readonly buffer Points { vec4 rel[]; };  // xyz used
layout(std430, binding = 1) writeonly buffer Values { float value[]; };
uniform int count;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uint(count)) return;
    value[i] = detailValue(detailVolume, detail, rel[i].xyz);
}
