#include "nephele/metrics.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <vector>

namespace nephele {

namespace {

std::string sizeOf(const Image& i) {
    return std::to_string(i.width) + "x" + std::to_string(i.height) + "x" + std::to_string(i.channels);
}

void require(const Image& img, const Image& ref, int channels, const char* what) {
    if (img.empty() || img.width != ref.width || img.height != ref.height || img.channels != channels)
        throw ImageError(std::string("compareRenders: ") + what + " is " + sizeOf(img) + ", expected " +
                         std::to_string(ref.width) + "x" + std::to_string(ref.height) + "x" + std::to_string(channels));
    if (!std::all_of(img.pixels.begin(), img.pixels.end(), [](float v) { return std::isfinite(v); }))
        throw ImageError(std::string("compareRenders: ") + what + " has NaN or infinite values");
}

std::vector<double> gaussian(int n) {  // n taps centred on (n-1)/2, sigma 1.5, summing to 1
    std::vector<double> g(n);
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        const double d = i - (n - 1) / 2.0;
        sum += g[i] = std::exp(-d * d / (2 * 1.5 * 1.5));
    }
    for (double& v : g) v /= sum;
    return g;
}

void appendNumber(std::string& s, const char* key, double v) {
    s += s.size() > 1 ? ",\"" : "\"";
    s += key;
    s += "\":";
    if (!std::isfinite(v)) {
        s += "null";
        return;
    }
    char buf[32];
    s.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

}  // namespace

double ssimLuminance(const Image& a, const Image& b) {
    require(a, a, 3, "A");
    require(b, a, 3, "B");
    const int w = a.width, h = a.height;
    const std::vector<double> gx = gaussian(std::min(w, 11)), gy = gaussian(std::min(h, 11));
    const int ow = w - int(gx.size()) + 1, oh = h - int(gy.size()) + 1, ny = int(gy.size());
    // Row by row: the five maps (luma of A and B, their squares and product), filtered
    // horizontally, for the last gy.size() rows only, so that the working set is a few rows
    // whatever the image's size (compare holds two 8192^2 images and no more; issue 38). The
    // sums are those of a whole-map "valid" separable filter, term by term.
    constexpr int kMaps = 5;
    std::vector<double> ring(std::size_t(kMaps) * ny * ow), line(std::size_t(kMaps) * w);
    auto rowOf = [&](int map, int y) { return ring.data() + (std::size_t(map) * ny + std::size_t(y % ny)) * ow; };
    auto lumaOf = [](const Image& img, std::size_t p) {
        const float* px = &img.pixels[p * 3];
        return double(linearToSrgb(0.2126f * px[0] + 0.7152f * px[1] + 0.0722f * px[2]));
    };
    constexpr double C1 = 0.01 * 0.01, C2 = 0.03 * 0.03;
    double sum = 0;
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const std::size_t p = std::size_t(y) * w + x;
            const double ya = lumaOf(a, p), yb = lumaOf(b, p);
            line[x] = ya, line[w + x] = yb, line[2 * w + x] = ya * ya, line[3 * w + x] = yb * yb,
            line[4 * w + x] = ya * yb;
        }
        for (int m = 0; m < kMaps; ++m) {
            double* out = rowOf(m, y);
            const double* in = line.data() + std::size_t(m) * w;
            for (int x = 0; x < ow; ++x) {
                double s = 0;
                for (std::size_t k = 0; k < gx.size(); ++k) s += gx[k] * in[x + k];
                out[x] = s;
            }
        }
        const int oy = y - ny + 1;  // the output row whose last input row is y
        if (oy < 0) continue;
        for (int x = 0; x < ow; ++x) {
            double f[kMaps];
            for (int m = 0; m < kMaps; ++m) {
                double s = 0;
                for (int k = 0; k < ny; ++k) s += gy[k] * rowOf(m, oy + k)[x];
                f[m] = s;
            }
            const double ma = f[0], mb = f[1];
            const double va = f[2] - ma * ma, vb = f[3] - mb * mb, cov = f[4] - ma * mb;
            sum += (2 * ma * mb + C1) * (2 * cov + C2) / ((ma * ma + mb * mb + C1) * (va + vb + C2));
        }
    }
    return sum / (double(ow) * double(oh));
}

RenderComparison compareRenders(const Image& a, const Image& b, const Image* alphaA, const Image* alphaB) {
    require(a, a, 3, "A");
    require(b, a, 3, "B");
    if (alphaA) require(*alphaA, a, 1, "alpha of A");
    if (alphaB) require(*alphaB, a, 1, "alpha of B");
    RenderComparison c;

    double ab = 0, aa = 0, peak = 1;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        ab += double(a.pixels[i]) * b.pixels[i];
        aa += double(a.pixels[i]) * a.pixels[i];
        peak = std::max(peak, double(b.pixels[i]));
    }
    c.exposure = aa > 0 ? ab / aa : 1.0;  // A black: nothing to scale
    double se = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        const double e = c.exposure * a.pixels[i] - b.pixels[i];
        se += e * e;
    }
    c.rmse = std::sqrt(se / double(a.pixels.size()));
    c.psnr = c.rmse > 0 ? 20.0 * std::log10(peak / c.rmse) : INFINITY;
    c.ssim = ssimLuminance(a, b);

    if (alphaA && alphaB) {
        c.hasAlpha = true;
        double sum = 0;
        std::size_t inter = 0, uni = 0;
        for (std::size_t i = 0; i < alphaA->pixels.size(); ++i) {
            const float pa = alphaA->pixels[i], pb = alphaB->pixels[i];
            sum += std::fabs(double(pa) - pb);
            inter += pa > 0.5f && pb > 0.5f;
            uni += pa > 0.5f || pb > 0.5f;
        }
        c.alphaMae = sum / double(alphaA->pixels.size());
        c.alphaIou = uni ? double(inter) / double(uni) : 1.0;
    }
    return c;
}

double silhouetteDimension(const Image& alpha) {
    const int w = alpha.width, h = alpha.height;
    const auto in = [&](int x, int y) { return alpha.at(x, y, 0) > 0.5f; };
    std::vector<char> edge(std::size_t(w) * h, 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!in(x, y)) continue;
            const bool open = (x > 0 && !in(x - 1, y)) || (x + 1 < w && !in(x + 1, y)) || (y > 0 && !in(x, y - 1)) ||
                              (y + 1 < h && !in(x, y + 1));
            edge[std::size_t(y) * w + x] = open;
        }
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (int s = 2; s <= 32; s *= 2) {
        const int bw = (w + s - 1) / s, bh = (h + s - 1) / s;
        std::vector<char> box(std::size_t(bw) * bh, 0);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                if (edge[std::size_t(y) * w + x]) box[std::size_t(y / s) * bw + x / s] = 1;
        long count = 0;
        for (char b : box) count += b;
        if (count == 0) return 0;
        const double lx = std::log(1.0 / s), ly = std::log(double(count));
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly, ++n;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

double meanClampedDifference(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height || a.channels != b.channels)
        throw ImageError("meanClampedDifference: " + sizeOf(a) + " against " + sizeOf(b));
    double sum = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i)
        sum += std::fabs(std::clamp(a.pixels[i], 0.0f, 1.0f) - std::clamp(b.pixels[i], 0.0f, 1.0f));
    return a.pixels.empty() ? 0 : sum / double(a.pixels.size());
}

std::string toJson(const RenderComparison& c) {
    std::string s = "{";
    appendNumber(s, "exposure", c.exposure);
    appendNumber(s, "rmse", c.rmse);
    appendNumber(s, "psnr", c.psnr);  // null when infinite (identical images)
    appendNumber(s, "ssim", c.ssim);
    if (c.hasAlpha) {
        appendNumber(s, "alpha_mae", c.alphaMae);
        appendNumber(s, "alpha_iou", c.alphaIou);
    }
    return s + "}";
}

}  // namespace nephele
