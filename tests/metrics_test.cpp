// Render comparison metrics: known answers for exposure, RMSE, PSNR, SSIM and alpha.
#include "nephele/metrics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace nephele;

namespace {

Image pattern(int w, int h) {  // smooth-ish RGB in (0, 1)
    Image img(w, h, 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < 3; ++k)
                img.at(x, y, k) = 0.5f + 0.4f * float(std::sin(0.3 * x + 0.2 * y + k) * std::cos(0.17 * x * y / 8.0));
    return img;
}

Image noisy(const Image& img, float sigma, unsigned seed) {
    Image out = img;
    std::mt19937 rng(seed);
    std::normal_distribution<float> n(0.0f, sigma);
    for (float& v : out.pixels) v = std::clamp(v + n(rng), 0.0f, 1.0f);
    return out;
}

Image grey(int w, int h, std::initializer_list<float> values) {
    Image img(w, h, 1);
    std::copy(values.begin(), values.end(), img.pixels.begin());
    return img;
}

TEST(MetricsTest, IdenticalImages) {
    const Image a = pattern(40, 30);
    const RenderComparison c = compareRenders(a, a);
    EXPECT_DOUBLE_EQ(c.exposure, 1.0);
    EXPECT_EQ(c.rmse, 0.0);
    EXPECT_TRUE(std::isinf(c.psnr) && c.psnr > 0);
    EXPECT_DOUBLE_EQ(c.ssim, 1.0);
    EXPECT_FALSE(c.hasAlpha);
    EXPECT_EQ(toJson(c).find("\"psnr\":null"), toJson(c).find("\"psnr\""));
}

TEST(MetricsTest, DoubledImageFitsExposureTwo) {
    const Image a = pattern(32, 32);
    Image b = a;
    for (float& v : b.pixels) v *= 2;
    const RenderComparison c = compareRenders(a, b);
    EXPECT_NEAR(c.exposure, 2.0, 1e-12);
    EXPECT_NEAR(c.rmse, 0.0, 1e-9);
    EXPECT_GT(c.psnr, 150);
    const RenderComparison back = compareRenders(b, a);
    EXPECT_NEAR(back.exposure, 0.5, 1e-12);
}

TEST(MetricsTest, ConstantOffsetHasAnalyticRmseAndPsnr) {
    // A alternates 0.2 and 0.6, B = A + 0.1. Least squares: s = sum(ab)/sum(aa) = 0.24/0.2 = 1.2;
    // residuals 1.2*0.2-0.3 = -0.06 and 1.2*0.6-0.7 = 0.02, so mse = (0.0036+0.0004)/2 = 0.002.
    // B's max is 0.7 < 1, so the peak is 1: psnr = 10 log10(1/0.002).
    Image a(16, 12, 3), b(16, 12, 3);
    for (int y = 0; y < 12; ++y)
        for (int x = 0; x < 16; ++x)
            for (int k = 0; k < 3; ++k) {
                a.at(x, y, k) = (x + y) % 2 ? 0.6f : 0.2f;
                b.at(x, y, k) = a.at(x, y, k) + 0.1f;
            }
    const RenderComparison c = compareRenders(a, b);
    EXPECT_NEAR(c.exposure, 1.2, 1e-6);
    EXPECT_NEAR(c.rmse, std::sqrt(0.002), 1e-6);
    EXPECT_NEAR(c.psnr, 10 * std::log10(1 / 0.002), 1e-4);

    // Peak is B's max when that exceeds 1: scale both by 10 -> rmse x10, psnr unchanged.
    for (float& v : a.pixels) v *= 10;
    for (float& v : b.pixels) v *= 10;
    const RenderComparison big = compareRenders(a, b);
    EXPECT_NEAR(big.rmse, 10 * std::sqrt(0.002), 1e-5);
    EXPECT_NEAR(big.psnr, 20 * std::log10(7.0 / (10 * std::sqrt(0.002))), 1e-4);
}

TEST(MetricsTest, BlackAKeepsExposureOne) {
    const Image a(8, 8, 3, 0.0f), b(8, 8, 3, 0.5f);
    const RenderComparison c = compareRenders(a, b);
    EXPECT_EQ(c.exposure, 1.0);
    EXPECT_NEAR(c.rmse, 0.5, 1e-12);
    EXPECT_NEAR(c.psnr, 20 * std::log10(1 / 0.5), 1e-9);
}

TEST(MetricsTest, SsimFallsWithNoiseAndIsSymmetric) {
    const Image a = pattern(64, 48);
    double previous = 1.0;
    for (float sigma : {0.01f, 0.05f, 0.1f, 0.2f}) {
        const Image b = noisy(a, sigma, 7);
        const double s = ssimLuminance(a, b);
        EXPECT_LT(s, previous) << "sigma " << sigma;
        EXPECT_GT(s, 0.0);
        EXPECT_NEAR(s, ssimLuminance(b, a), 1e-12);
        EXPECT_NEAR(s, compareRenders(a, b).ssim, 1e-12);
        previous = s;
    }
    EXPECT_LT(previous, 0.9);
}

TEST(MetricsTest, SsimOfConstantImagesFollowsTheFormula) {
    // No variance anywhere, so SSIM = (2 mu_a mu_b + C1) / (mu_a^2 + mu_b^2 + C1), C1 = (0.01 * 1)^2,
    // with mu the sRGB-encoded luminance: linear 1 -> 1, linear 0.5 -> 0.7353569, 0 -> 0.
    const double c1 = 1e-4, half = 0.7353569;
    const Image white(20, 16, 3, 1.0f), mid(20, 16, 3, 0.5f), black(20, 16, 3, 0.0f);
    EXPECT_NEAR(ssimLuminance(white, mid), (2 * half + c1) / (1 + half * half + c1), 1e-6);
    EXPECT_NEAR(ssimLuminance(black, white), c1 / (1 + c1), 1e-9);
    EXPECT_DOUBLE_EQ(ssimLuminance(black, black), 1.0);
    // Luminance, not per channel: pure green at linear g has Y = 0.7152 g.
    Image green(20, 16, 3, 0.0f), greyEquivalent(20, 16, 3, 0.7152f * 0.6f);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 20; ++x) green.at(x, y, 1) = 0.6f;
    EXPECT_NEAR(ssimLuminance(green, greyEquivalent), 1.0, 1e-9);
    // Images smaller than the 11x11 window still work (window shrinks to fit).
    const Image small = pattern(5, 7);
    EXPECT_DOUBLE_EQ(ssimLuminance(small, small), 1.0);
    EXPECT_LT(ssimLuminance(small, noisy(small, 0.2f, 3)), 1.0);
}

TEST(MetricsTest, AlphaMaeAndIou) {
    const Image rgb(4, 2, 3, 0.5f);
    // Masks (> 0.5): A = {0,1,2,3}, B = {2,3,4}; intersection 2, union 5.
    const Image alphaA = grey(4, 2, {1.0f, 0.9f, 0.6f, 1.0f, 0.5f, 0.0f, 0.2f, 0.0f});
    const Image alphaB = grey(4, 2, {0.0f, 0.5f, 0.7f, 1.0f, 0.8f, 0.0f, 0.2f, 0.4f});
    const RenderComparison c = compareRenders(rgb, rgb, &alphaA, &alphaB);
    ASSERT_TRUE(c.hasAlpha);
    EXPECT_NEAR(c.alphaMae, (1.0 + 0.4 + 0.1 + 0 + 0.3 + 0 + 0 + 0.4) / 8, 1e-6);
    EXPECT_NEAR(c.alphaIou, 2.0 / 5.0, 1e-12);
    const std::string json = toJson(c);
    EXPECT_NE(json.find("\"alpha_iou\":0.4"), std::string::npos) << json;
    EXPECT_NE(json.find("\"alpha_mae\":"), std::string::npos) << json;

    const Image empty(4, 2, 1, 0.25f);  // both masks empty -> IoU 1
    const RenderComparison none = compareRenders(rgb, rgb, &empty, &empty);
    EXPECT_EQ(none.alphaIou, 1.0);
    EXPECT_EQ(none.alphaMae, 0.0);

    // Only one side has alpha: not compared.
    EXPECT_FALSE(compareRenders(rgb, rgb, &alphaA, nullptr).hasAlpha);
    EXPECT_EQ(toJson(compareRenders(rgb, rgb, &alphaA, nullptr)).find("alpha"), std::string::npos);
}

TEST(MetricsTest, JsonIsOneLineWithExpectedKeys) {
    RenderComparison c;
    c.exposure = 1.25;
    c.rmse = 0.1;
    c.psnr = 20;
    c.ssim = 0.5;
    EXPECT_EQ(toJson(c), R"({"exposure":1.25,"rmse":0.1,"psnr":20,"ssim":0.5})");
    c.hasAlpha = true;
    c.alphaMae = 0.125;
    c.alphaIou = 1;
    EXPECT_EQ(toJson(c), R"({"exposure":1.25,"rmse":0.1,"psnr":20,"ssim":0.5,"alpha_mae":0.125,"alpha_iou":1})");
}

TEST(MetricsTest, MismatchesThrow) {
    const Image a(8, 8, 3), b(8, 9, 3), alpha(8, 8, 1), wrongAlpha(9, 8, 1);
    EXPECT_THROW(compareRenders(a, b), ImageError);
    EXPECT_THROW(ssimLuminance(a, b), ImageError);
    EXPECT_THROW(compareRenders(a, Image(8, 8, 4)), ImageError);
    EXPECT_THROW(compareRenders(a, a, &wrongAlpha, &alpha), ImageError);
    EXPECT_THROW(compareRenders(a, a, &alpha, &a), ImageError);  // alpha must be grey
    EXPECT_THROW(compareRenders(Image(), Image()), ImageError);
    Image nan = a;
    nan.at(3, 4, 1) = std::nanf("");
    EXPECT_THROW(compareRenders(a, nan), ImageError);
}

}  // namespace

TEST(MetricsTest, MeanClampedDifferenceClampsEachValueFirst) {
    Image a(2, 1, 1), b(2, 1, 1);
    a.pixels = {0.25f, 3.0f};   // 3 counts as 1
    b.pixels = {0.75f, -1.0f};  // -1 counts as 0
    EXPECT_DOUBLE_EQ(meanClampedDifference(a, b), (0.5 + 1.0) / 2);
    EXPECT_DOUBLE_EQ(meanClampedDifference(a, a), 0.0);
    EXPECT_THROW(meanClampedDifference(a, Image(1, 2, 1)), ImageError);
}
