// NoiseGLTest: samples a noise volume (GL_LINEAR, GL_REPEAT) at the given texture
// coordinates, so the test can compare with NoiseVolume::sample on the CPU.
layout(local_size_x = 64) in;

layout(binding = 0) uniform sampler3D noiseVolume;
layout(std430, binding = 0) readonly buffer Coordinates { vec4 uvw[]; };  // xyz used
layout(std430, binding = 1) writeonly buffer Values { float value[]; };
uniform int count;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uint(count)) return;
    value[i] = textureLod(noiseVolume, uvw[i].xyz, 0.0).r;
}
