// The detail field on the GPU (shaders/detail.glsl): the nephele kind's texture (detailVolume(),
// R32F, GL_LINEAR, GL_REPEAT, as NoiseVolume::sample reproduces) and the uniforms of a view.
#pragma once

#include "nephele/api.hpp"
#include "nephele/detail.hpp"
#include "nephele/gl.hpp"
#include "nephele/shader.hpp"

NEPHELE_API_BEGIN
namespace nephele {

class DetailTexture {
public:
    static constexpr GLuint kUnit = 11;  // texture unit of `detailVolume`, beside the light grids' 6-10
    // The compositor's tiles erode each chord in this many pieces (uniform detailPieces): against
    // the path tracer on the dense cumulus from 1 km, opacity MAE 0.023 with 3, 0.014 with 6.
    static constexpr int kTilePieces = 6;

    // The programs that read the detail are built for one variant of it: off (the detail's code
    // compiled out), the nephele kind or the reference kind (DETAIL and DETAIL_KIND,
    // shaders/detail.glsl). On llvmpipe a branch on a uniform costs its code whichever way it
    // goes, so a renderer builds them again when the scene's variant is not theirs.
    enum class Variant { Off, Nephele, Reference };
    static Variant variant(const Medium::Detail& detail);
    static std::string defines(Variant variant);

    // Sets `detail` (a uniform DetailParams) and `detailVolume` of `program` for the eye `eye`, and
    // binds the texture (made on first use) when the detail is on; `detailPieces` too. With the detail off only
    // detail.erosion (0) is set: the shaders then keep their paths without it.
    void bind(const Program& program, const Medium::Detail& detail, const Vec3& eye);

private:
    gl::Texture texture_;
};

}  // namespace nephele
NEPHELE_API_END
