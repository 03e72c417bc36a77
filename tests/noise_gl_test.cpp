// The noise volume on the GPU: uploaded as a GL_R32F 3D texture with GL_LINEAR and
// GL_REPEAT, sampled by a compute shader (tests/data/shaders/noise_probe.comp), it must
// give what NoiseVolume::sample gives on the CPU, which the CPU reference renderers use.
#include "gl_test_util.hpp"

#include "../model/internal/noise_texture.hpp"

#include "nephele/noise.hpp"
#include "nephele/shader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

using namespace nephele;
using namespace nephele::gl;

namespace {

// The library's own upload (noiseTexture), which every renderer samples the noise through.
Texture uploadVolume(const NoiseVolume& v) {
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    Texture tex = noiseTexture(v);
    checkAlways("upload noise volume");
    return tex;
}

// Samples `tex` at every uvw on the GPU and reads the values back.
std::vector<float> sampleOnGpu(const Texture& tex, const std::vector<glm::vec4>& uvw) {
    Program program = test::buildProbe(NEPHELE_TEST_DATA "/shaders", "noise_probe.comp");
    const GLsizei n = GLsizei(uvw.size());
    Buffer in = Buffer::create(), out = Buffer::create();
    glNamedBufferStorage(in.id(), GLsizeiptr(n * sizeof(glm::vec4)), uvw.data(), 0);
    glNamedBufferStorage(out.id(), GLsizeiptr(n * sizeof(float)), nullptr, 0);
    program.set("count", int(n));
    glBindTextureUnit(0, tex.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, in.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, out.id());
    glUseProgram(program.id());
    glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::vector<float> values(std::size_t(n), -99.0f);
    glGetNamedBufferSubData(out.id(), 0, GLsizeiptr(n * sizeof(float)), values.data());
    glUseProgram(0);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, 0);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, 0);
    glBindTextureUnit(0, 0);
    checkAlways("sample noise volume");
    return values;
}

class NoiseGLTest : public ::testing::TestWithParam<GlBackend> {};

TEST_P(NoiseGLTest, GpuSamplingMatchesNoiseVolumeSample) {
    auto ctx = test::makeContext(GetParam());
    const NoiseVolume volume = makeNoiseVolume(32, 4, 4, 2024);
    const Texture tex = uploadVolume(volume);

    // 400 random coordinates in [-2, 3]^3 (wrapping several times), the corners and
    // seam of the unit cube, and 64 texel centres (exact on any GPU: weights 0).
    std::vector<glm::vec4> uvw;
    std::mt19937 rng(5);
    const auto r = [&] { return float(rng()) / 4294967296.0f * 5.0f - 2.0f; };
    for (int i = 0; i < 400; ++i) uvw.emplace_back(r(), r(), r(), 0.0f);
    for (float a : {0.0f, 1.0f, -1.0f, 0.5f / 32, 1.0f - 0.5f / 32, 1.0f / 64})
        for (float b : {0.0f, 0.37f, 1.0f}) uvw.emplace_back(a, b, 1.0f - b, 0.0f);
    const std::size_t firstCentre = uvw.size();
    for (int i = 0; i < 64; ++i)
        uvw.emplace_back((glm::vec3(i % 32, (i * 7) % 32, (i * 13 + 5) % 32) + 0.5f) / 32.0f, 0.0f);

    const std::vector<float> gpu = sampleOnGpu(tex, uvw);
    float maxDiff = 0, maxFromNearest = 0;
    int mismatches = 0;
    for (std::size_t i = 0; i < uvw.size(); ++i) {
        const glm::vec3 p(uvw[i]);
        const float cpu = volume.sample(p);
        // Centres must agree exactly; elsewhere GPUs round the fractional weights (8 bits
        // on many), which moves a value in [-1,1] by at most ~1e-3 here.
        const float diff = std::abs(gpu[i] - cpu);
        if (diff > (i >= firstCentre ? 1e-6f : 1e-3f) && ++mismatches <= 10)
            ADD_FAILURE() << "uvw (" << p.x << ", " << p.y << ", " << p.z << "): GPU " << gpu[i] << ", CPU " << cpu;
        maxDiff = std::max(maxDiff, diff);
        // Nearest-texel lookup, to show the tolerance tells filtering modes apart.
        const glm::ivec3 t = glm::ivec3(glm::floor((p - glm::floor(p)) * 32.0f)) % 32;
        maxFromNearest = std::max(maxFromNearest, std::abs(gpu[i] - volume.texels[t.x + 32 * (t.y + 32 * t.z)]));
    }
    EXPECT_EQ(mismatches, 0) << "of " << uvw.size() << " samples (first 10 shown); max difference " << maxDiff;
    EXPECT_GT(maxFromNearest, 0.05f) << "GPU values look unfiltered";
    RecordProperty("max_gpu_cpu_difference", std::to_string(maxDiff));
    std::printf("%s: max |GPU - CPU| = %g over %zu samples\n", backendName(GetParam()), maxDiff, uvw.size());
}

INSTANTIATE_TEST_SUITE_P(Backends, NoiseGLTest, ::testing::Values(GlBackend::Egl, GlBackend::OSMesa),
                         [](const auto& info) { return std::string(backendName(info.param)); });

}  // namespace
