#include "accuracy_reference.hpp"

#include "nephele/opaque.hpp"
#include "nephele/pathtrace.hpp"
#include "pathtrace_hooks.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace nephele::cli {

Image blockMean(const Image& a, int block) {
    Image out(a.width / block, a.height / block, a.channels);
    for (int y = 0; y < out.height; ++y)
        for (int x = 0; x < out.width; ++x)
            for (int k = 0; k < a.channels; ++k) {
                double sum = 0;
                for (int j = 0; j < block; ++j)
                    for (int i = 0; i < block; ++i) sum += a.at(x * block + i, y * block + j, k);
                out.at(x, y, k) = float(sum / (block * block));
            }
    return out;
}

namespace {

// RMSE of rgb(a - b) over the cloud's blocks (either alpha > 0.02, alphas from `mask`),
// relative to `norm`.
double rmseOver(const Image& a, const Image& b, const Image& maskA, const Image& maskB, double norm) {
    double se = 0;
    std::size_t n = 0;
    for (std::size_t p = 0; p < std::size_t(a.width) * a.height; ++p) {
        if (!(maskA.pixels[4 * p + 3] > 0.02f || maskB.pixels[4 * p + 3] > 0.02f)) continue;
        for (int k = 0; k < 3; ++k) {
            const double d = double(a.pixels[4 * p + k]) - b.pixels[4 * p + k];
            se += d * d;
        }
        n += 3;
    }
    return n == 0 || norm <= 0 ? 0 : std::sqrt(se / n) / norm;
}

// The reference's mean radiance over the blocks where it has cloud.
double cloudMean(const Image& ref) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t p = 0; p < std::size_t(ref.width) * ref.height; ++p) {
        if (!(ref.pixels[4 * p + 3] > 0.02f)) continue;
        for (int k = 0; k < 3; ++k) sum += ref.pixels[4 * p + k];
        n += 3;
    }
    return n ? sum / n : 0;
}

Image add(const Image& a, const Image& b) {
    Image out = a;
    for (std::size_t i = 0; i < out.pixels.size(); ++i)
        if (i % 4 != 3) out.pixels[i] += b.pixels[i];
    return out;
}

Image subtract(const Image& a, const Image& b) {
    Image out = a;
    for (std::size_t i = 0; i < out.pixels.size(); ++i)
        if (i % 4 != 3) out.pixels[i] -= b.pixels[i];
    return out;
}

}  // namespace

double relativeRmse(const Image& a, const Image& b) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t p = 0; p < std::size_t(a.width) * a.height; ++p) {
        if (!(a.pixels[4 * p + 3] > 0.02f || b.pixels[4 * p + 3] > 0.02f)) continue;
        for (int k = 0; k < 3; ++k) sum += b.pixels[4 * p + k];
        n += 3;
    }
    return n == 0 ? 0 : rmseOver(a, b, a, b, sum / n);
}

namespace {

// One set of a reference's pieces: the scattering orders first..last, each piece traced with
// its own seed.
struct Part {
    int first, last;
    unsigned seedBase;
    std::vector<Image> pieces;  // sun + sky block means, each piece
    Image sun, sky, full;       // their running means
};

// Traces a reference's pieces: the sun's light and the sky's apart, each piece of `piece`
// (the sky's of `skyPiece`) samples per pixel, through the cache when there is one.
struct PieceTracer {
    const View& view;
    const NoiseVolume& noise;
    const ReferenceSettings& s;
    Scene sun, sky;
    int piece, skyPiece;

    PieceTracer(const Scene& scene, const View& v, const NoiseVolume& n, const ReferenceSettings& settings)
        : view(v),
          noise(n),
          s(settings),
          sun(sunOnly(scene)),
          sky(skyOnly(scene)),
          piece(std::clamp(s.pieceSpp, 1, std::max(1, s.spp / 2))),
          skyPiece(std::max(1, piece * s.skySpp / std::max(1, s.spp))) {}

    Image trace(const Scene& sc, int spp, int firstBounce, int maxBounces, unsigned seed) const {
        PathTraceSettings p;
        p.spp = std::max(1, spp);
        p.firstBounce = firstBounce, p.maxBounces = maxBounces;
        p.seed = seed;
        return s.cacheDir.empty() ? renderPathTraced(sc, view, p, &noise)
                                  : renderPathTracedCached(sc, view, p, &noise, s.cacheDir);
    }

    void addPiece(Part& part) const {
        const unsigned seed = part.seedBase + unsigned(part.pieces.size());
        const Image fullA = trace(sun, piece, part.first, part.last, seed),
                    fullB = trace(sky, skyPiece, part.first, part.last, seed);
        const Image a = blockMean(fullA, s.block), b = blockMean(fullB, s.block), both = add(fullA, fullB);
        part.pieces.push_back(add(a, b));
        const float w = 1.0f / float(part.pieces.size());
        auto runningMean = [w](Image& mean, const Image& x) {
            for (std::size_t i = 0; i < mean.pixels.size(); ++i) mean.pixels[i] += w * (x.pixels[i] - mean.pixels[i]);
        };
        if (part.pieces.size() == 1) part.sun = a, part.sky = b, part.full = both;
        runningMean(part.sun, a), runningMean(part.sky, b), runningMean(part.full, both);
    }

    // Adds pieces until `part` would reach `target` from its `noise` now, at least one, at most `most`.
    void grow(Part& part, double noise, double target, int most) const {
        const double m = double(part.pieces.size());
        const int want = int(std::ceil(1.1 * m * std::pow(noise / std::max(target, 1e-9), 2)));
        while (int(part.pieces.size()) < std::clamp(want, int(m) + 1, most)) addPiece(part);
    }

    // The wall time a trace of this kind would take here, from a pilot (1/64 of the pixels at
    // 2 spp, its CPU time scaled).
    double estimate(const Scene& sc, int spp, int first, int last) const {
        PathTraceSettings p;
        p.spp = std::max(1, spp), p.firstBounce = first, p.maxBounces = last;
        return estimatePathTraceSeconds(sc, view, p, &noise);
    }
};

// A part's noise relative to `norm`: the noise of a mean of m pieces is their RMS spread / sqrt(m - 1).
double noiseOf(const Part& part, double norm) {
    const Image mean = add(part.sun, part.sky);
    double spread = 0;
    for (const Image& p : part.pieces) spread += std::pow(rmseOver(p, mean, mean, mean, norm), 2);
    const double m = double(part.pieces.size());
    return std::sqrt(spread / m / (m - 1));
}

}  // namespace

Reference makeReference(const Scene& scene, const View& view, const NoiseVolume& noise, const ReferenceSettings& s) {
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t before = detail::pathTracedImagesComputed();
    const PieceTracer tracer(scene, view, noise, s);
    const int allBounces = PathTraceSettings{}.maxBounces;
    // Pieces of independent seeds, added until the mean's noise is below the target: the
    // spread of the pieces measures it. The scattering orders up to kReferenceBounces in one
    // set of pieces, those past it (a few per cent of the light, in deep matter only) in
    // another, at most a quarter of the samples (a sample of them costs a whole path): the two
    // noises add in quadrature.
    const int maxPieces = std::max(2, s.spp / tracer.piece), maxTails = std::max(2, maxPieces / 4);
    Part low{0, kReferenceBounces, 1, {}, {}, {}, {}}, high{kReferenceBounces + 1, allBounces, 1000001, {}, {}, {}, {}};
    Reference r;
    for (;;) {
        while (low.pieces.size() < 2) tracer.addPiece(low);
        while (high.pieces.size() < 2) tracer.addPiece(high);
        r.sun = add(low.sun, high.sun), r.sky = add(low.sky, high.sky);
        r.total = add(r.sun, r.sky);
        const double norm = cloudMean(r.total), lowNoise = noiseOf(low, norm), highNoise = noiseOf(high, norm);
        r.noise = std::hypot(lowNoise, highNoise);
        if (r.noise <= s.targetNoise) break;
        const bool lowFull = int(low.pieces.size()) >= maxPieces, highFull = int(high.pieces.size()) >= maxTails;
        if (highNoise > 0.25 * s.targetNoise && !highFull) tracer.grow(high, highNoise, 0.25 * s.targetNoise, maxTails);
        else if (!lowFull)
            tracer.grow(low, lowNoise,
                        std::sqrt(std::max(std::pow(s.targetNoise, 2) - highNoise * highNoise,
                                           0.25 * std::pow(s.targetNoise, 2))),
                        maxPieces);
        else if (!highFull) tracer.addPiece(high);
        else break;
    }
    r.full = add(low.full, high.full);
    r.spp = tracer.piece * int(low.pieces.size());
    r.highSpp = tracer.piece * int(high.pieces.size());
    Image highTotal = add(high.sun, high.sky);  // over the same blocks as the total
    for (std::size_t p = 3; p < highTotal.pixels.size(); p += 4) highTotal.pixels[p] = r.total.pixels[p];
    r.highShare = cloudMean(r.total) > 0 ? cloudMean(highTotal) / cloudMean(r.total) : 0;
    r.single = blockMean(tracer.trace(tracer.sun, s.singleSpp, 0, 0, 1000), s.block);
    // What it would take made from scratch here: each kind of trace's estimate times the pieces of that kind.
    const Scene& sun = tracer.sun;
    const Scene& sky = tracer.sky;
    r.highScratchSeconds = double(high.pieces.size()) * (tracer.estimate(sun, tracer.piece, high.first, high.last) +
                                                         tracer.estimate(sky, tracer.skyPiece, high.first, high.last));
    r.scratchSeconds = double(low.pieces.size()) * (tracer.estimate(sun, tracer.piece, 0, low.last) +
                                                    tracer.estimate(sky, tracer.skyPiece, 0, low.last)) +
                       r.highScratchSeconds + tracer.estimate(sun, s.singleSpp, 0, 0);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.traced = int(detail::pathTracedImagesComputed() - before);
    return r;
}

ComponentErrors componentErrors(const Scene& scene, const View& view, const Reference& ref, int block,
                                const std::function<Image(const Scene&, bool)>& render) {
    const Image sun = blockMean(render(sunOnly(scene), false), block);
    const Image sky = blockMean(render(skyOnly(scene), false), block);
    const Image single = blockMean(render(sunOnly(scene), true), block);
    const Image background = blockMean(renderOpaqueCpu(scene, view), block);
    const double norm = cloudMean(ref.total);
    ComponentErrors e;
    e.total = rmseOver(add(sun, sky), ref.total, sun, ref.total, norm);
    e.single = rmseOver(single, ref.single, sun, ref.total, norm);
    e.multiple = rmseOver(subtract(sun, single), subtract(ref.sun, ref.single), sun, ref.total, norm);
    e.sky = rmseOver(sky, ref.sky, sun, ref.total, norm);
    // The background seen through the cloud, with the method's opacity against the reference's.
    Image mine = background, theirs = background;
    for (std::size_t p = 0; p < std::size_t(background.width) * background.height; ++p)
        for (int k = 0; k < 3; ++k) {
            mine.pixels[4 * p + k] *= 1 - sun.pixels[4 * p + 3];
            theirs.pixels[4 * p + k] *= 1 - ref.total.pixels[4 * p + 3];
        }
    e.opacity = rmseOver(mine, theirs, sun, ref.total, norm);
    return e;
}

ReferenceShares referenceShares(const Reference& ref) {
    const double total = cloudMean(ref.total);
    if (total <= 0) return {};
    // Means over the same blocks: cloudMean's mask is the image's own alpha, so use the total's.
    auto over = [&](const Image& part) {
        Image masked = part;
        for (std::size_t p = 0; p < std::size_t(part.width) * part.height; ++p)
            masked.pixels[4 * p + 3] = ref.total.pixels[4 * p + 3];
        return cloudMean(masked) / total;
    };
    ReferenceShares s;
    s.single = over(ref.single);
    s.multiple = over(ref.sun) - s.single;
    s.sky = over(ref.sky);
    return s;
}

}  // namespace nephele::cli
