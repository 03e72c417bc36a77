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

// sRGB-encoded Rec. 709 luminance in [0, 1].
std::vector<double> luma(const Image& img) {
    std::vector<double> y(std::size_t(img.width) * img.height);
    for (std::size_t p = 0; p < y.size(); ++p) {
        const float* px = &img.pixels[p * 3];
        y[p] = linearToSrgb(0.2126f * px[0] + 0.7152f * px[1] + 0.0722f * px[2]);
    }
    return y;
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

// "Valid" separable filtering of a w x h map with gx (horizontal) and gy (vertical).
std::vector<double> filter(const std::vector<double>& m, int w, int h, const std::vector<double>& gx,
                           const std::vector<double>& gy) {
    const int ow = w - int(gx.size()) + 1, oh = h - int(gy.size()) + 1;
    std::vector<double> rows(std::size_t(ow) * h), out(std::size_t(ow) * oh);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < ow; ++x) {
            double s = 0;
            for (std::size_t k = 0; k < gx.size(); ++k) s += gx[k] * m[std::size_t(y) * w + x + k];
            rows[std::size_t(y) * ow + x] = s;
        }
    for (int y = 0; y < oh; ++y)
        for (int x = 0; x < ow; ++x) {
            double s = 0;
            for (std::size_t k = 0; k < gy.size(); ++k) s += gy[k] * rows[(y + k) * ow + x];
            out[std::size_t(y) * ow + x] = s;
        }
    return out;
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
    const std::vector<double> ya = luma(a), yb = luma(b);
    std::vector<double> aa(ya.size()), bb(ya.size()), ab(ya.size());
    for (std::size_t i = 0; i < ya.size(); ++i) {
        aa[i] = ya[i] * ya[i];
        bb[i] = yb[i] * yb[i];
        ab[i] = ya[i] * yb[i];
    }
    const std::vector<double> gx = gaussian(std::min(w, 11)), gy = gaussian(std::min(h, 11));
    const std::vector<double> mu_a = filter(ya, w, h, gx, gy), mu_b = filter(yb, w, h, gx, gy),
                              e_aa = filter(aa, w, h, gx, gy), e_bb = filter(bb, w, h, gx, gy),
                              e_ab = filter(ab, w, h, gx, gy);
    constexpr double C1 = 0.01 * 0.01, C2 = 0.03 * 0.03;
    double sum = 0;
    for (std::size_t i = 0; i < mu_a.size(); ++i) {
        const double ma = mu_a[i], mb = mu_b[i];
        const double va = e_aa[i] - ma * ma, vb = e_bb[i] - mb * mb, cov = e_ab[i] - ma * mb;
        sum += (2 * ma * mb + C1) * (2 * cov + C2) / ((ma * ma + mb * mb + C1) * (va + vb + C2));
    }
    return sum / double(mu_a.size());
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
