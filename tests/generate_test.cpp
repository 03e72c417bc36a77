// Expansion of `generate` entries (nephele/generate.hpp): determinism, counts, the placement
// statistics and eq. 16 radii of the cumulus, both prunings, the mesh ellipsoids and the
// L-system counts; and that the loader expands and reports them.
#include "nephele/generate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace nephele;

namespace {

const std::string kData = std::string(NEPHELE_TEST_DATA) + "/";

Generator cumulus(unsigned seed, int count) {
    Generator g;
    g.type = Generator::Type::Cumulus;
    g.name = "c";
    g.seed = seed;
    g.count = count;
    g.center = Vec3(100, -200, 1500);
    return g;
}

bool sameCloud(const Cloud& a, const Cloud& b) {
    if (a.ellipsoids.size() != b.ellipsoids.size()) return false;
    for (size_t i = 0; i < a.ellipsoids.size(); ++i) {
        const Ellipsoid &x = a.ellipsoids[i], &y = b.ellipsoids[i];
        if (x.center != y.center || x.radii != y.radii || x.rotationDeg != y.rotationDeg || x.density != y.density)
            return false;
    }
    return true;
}

// Is point p inside (or on) ellipsoid e? Relative slack 1e-9 for rounding.
bool inside(const Ellipsoid& e, const Vec3& p) {
    const Vec3 q = glm::transpose(rotationFromDegrees(e.rotationDeg)) * (p - e.center) / e.radii;
    return glm::dot(q, q) <= 1.0 + 1e-9;
}

// Is ellipsoid b inside ellipsoid a, judged from 2000 points on b's surface (an independent
// check of generate.cpp's closed-form test: a false "inside" needs every sample inside).
bool insideSampled(const Ellipsoid& a, const Ellipsoid& b) {
    const glm::dmat3 R = rotationFromDegrees(b.rotationDeg);
    const int n = 2000;
    for (int i = 0; i < n; ++i) {  // Fibonacci sphere
        const double z = 1.0 - (2.0 * i + 1.0) / n, r = std::sqrt(1.0 - z * z), phi = i * 2.39996322972865332;
        const Vec3 u(r * std::cos(phi), r * std::sin(phi), z);
        if (!inside(a, b.center + R * (u * b.radii))) return false;
    }
    return true;
}

}  // namespace

TEST(GenerateTest, CumulusIsDeterministicFromItsSeed) {
    const Cloud a = generateCumulus(cumulus(7, 40)), b = generateCumulus(cumulus(7, 40));
    EXPECT_TRUE(sameCloud(a, b));
    EXPECT_FALSE(sameCloud(a, generateCumulus(cumulus(8, 40))));
    EXPECT_EQ(a.name, "c");
    // A fixed point of the sequence (mt19937 and our own mappings are portable): if this
    // changes, every scene's generated clouds change. Tolerance: printing precision.
    Generator g = cumulus(7, 1);
    g.hollow = g.pruneContained = false;
    const Cloud one = generateCumulus(g);
    ASSERT_EQ(one.ellipsoids.size(), 1u);
    const Vec3 c = one.ellipsoids[0].center;
    const Vec3 expected(122.338107039, -317.425945548, 1478.607599511);
    EXPECT_NEAR(c.x, expected.x, 1e-6);
    EXPECT_NEAR(c.y, expected.y, 1e-6);
    EXPECT_NEAR(c.z, expected.z, 1e-6);
}

TEST(GenerateTest, CumulusCountsAddUp) {
    for (unsigned seed : {1u, 2u, 3u}) {
        for (int count : {1, 40, 200}) {
            GenerateStats s;
            Generator g = cumulus(seed, count);
            g.density = 0.7;
            const Cloud c = generateCumulus(g, &s);
            EXPECT_EQ(s.name, "c");
            EXPECT_EQ(s.placed, count);
            EXPECT_EQ(s.kept, s.placed - s.prunedHollow - s.prunedContained);
            EXPECT_EQ(s.kept, static_cast<int>(c.ellipsoids.size()));
            EXPECT_EQ(s.degenerate, 0);
            for (const Ellipsoid& e : c.ellipsoids) EXPECT_EQ(e.density, 0.7);
        }
    }
    GenerateStats s;
    Generator g = cumulus(1, 200);
    g.hollow = g.pruneContained = false;
    generateCumulus(g, &s);
    EXPECT_EQ(s.kept, 200);
    EXPECT_EQ(s.prunedHollow + s.prunedContained, 0);
}

TEST(GenerateTest, CumulusPlacementIsGaussianPerAxis) {
    Generator g = cumulus(11, 20000);
    g.sigma = Vec3(300, 200, 100);
    g.clampLo = Vec3(-10);  // clamps far out: the unclamped normal distribution
    g.clampHi = Vec3(10);
    g.hollow = g.pruneContained = false;
    const Cloud c = generateCumulus(g);
    Vec3 sum(0), sum2(0);
    for (const Ellipsoid& e : c.ellipsoids) {
        const Vec3 d = e.center - g.center;
        sum += d;
        sum2 += d * d;
    }
    const double n = c.ellipsoids.size();
    const Vec3 mean = sum / n, sd = glm::sqrt(sum2 / n - mean * mean);
    for (int k = 0; k < 3; ++k) {
        // n = 20000: standard error of the mean sigma/141 = 0.007 sigma, of the std-dev
        // sigma/200 = 0.005 sigma; 0.03 sigma is beyond 4 standard errors of either.
        EXPECT_NEAR(mean[k], 0.0, 0.03 * g.sigma[k]) << "axis " << k;
        EXPECT_NEAR(sd[k], g.sigma[k], 0.03 * g.sigma[k]) << "axis " << k;
    }
}

TEST(GenerateTest, CumulusPlacementIsClamped) {
    Generator g = cumulus(5, 5000);
    g.hollow = g.pruneContained = false;
    const Cloud c = generateCumulus(g);
    int atBase = 0;
    for (const Ellipsoid& e : c.ellipsoids) {
        const Vec3 z = (e.center - g.center) / g.sigma;
        for (int k = 0; k < 3; ++k) {
            EXPECT_GE(z[k], g.clampLo[k] - 1e-12);
            EXPECT_LE(z[k], g.clampHi[k] + 1e-12);
        }
        atBase += std::abs(z.z - g.clampLo.z) < 1e-12;
    }
    // P(N(0,1) < -0.5) = 0.3085: clamped, not redrawn, so about that many sit on the flat base
    // (the standard error at n = 5000 is 0.0065; 0.03 is 4.6 of them).
    EXPECT_NEAR(atBase / 5000.0, 0.3085, 0.03);
}

TEST(GenerateTest, CumulusRadiiFollowEquation16) {
    Generator g = cumulus(3, 2000);
    g.hollow = g.pruneContained = false;
    g.aspect = Vec3(1.0, 0.8, 0.6);
    const Cloud c = generateCumulus(g);
    std::vector<std::pair<double, double>> byDistance;  // (d in sigmas, radius)
    for (const Ellipsoid& e : c.ellipsoids) {
        const Vec3 z = (e.center - g.center) / g.sigma;
        const double r = e.radii.x;
        EXPECT_NEAR(e.radii.y, 0.8 * r, 1e-9 * r);
        EXPECT_NEAR(e.radii.z, 0.6 * r, 1e-9 * r);
        EXPECT_EQ(e.rotationDeg, Vec3(0));
        // eq. 16: eps (1 - 0.1 sqrt(sum ((P - C) / 2 sigma)^2))
        const Vec3 h = z / 2.0;
        EXPECT_NEAR(r, g.maxRadius * (1.0 - 0.1 * std::sqrt(glm::dot(h, h))), 1e-9 * g.maxRadius);
        EXPECT_LE(r, g.maxRadius);
        byDistance.emplace_back(glm::length(z), r);
    }
    std::sort(byDistance.begin(), byDistance.end());
    for (size_t i = 1; i < byDistance.size(); ++i) EXPECT_LE(byDistance[i].second, byDistance[i - 1].second);
}

// The core's bounds (|dx| < 0.75 sigma_x, |dy| < 0.75 sigma_y, |dz| < sigma_z / 3) held by
// hand-made points, not by a copy of generate.cpp's formula: clamping every draw to
// [lo, lo] * sigma puts all `count` placements at exactly lo * sigma, so a cloud whose clamp
// sits just inside the core on every axis (0.74, 0.74, 0.32 sigma) loses every ellipsoid and
// one just outside on any single axis (0.76 or 0.34 sigma), on either side, loses none.
// Broken (the core's x bound 0.8 sigma instead of 0.75, tests/sabotage/09-hollow-core-wider
// .sabotage): the 0.76 sigma points are pruned, 50 of 50 instead of 0.
TEST(GenerateTest, HollowPruningRemovesExactlyTheCore) {
    auto prunedAt = [](const Vec3& at) {
        Generator g = cumulus(9, 50);
        g.pruneContained = false;
        g.hollow = true;
        g.clampLo = g.clampHi = at;
        GenerateStats s;
        const Cloud c = generateCumulus(g, &s);
        EXPECT_EQ(int(c.ellipsoids.size()), g.count - s.prunedHollow);
        return s.prunedHollow;
    };
    for (const double side : {1.0, -1.0}) {
        EXPECT_EQ(prunedAt(side * Vec3(0.74, 0.74, 0.32)), 50) << "inside the core on every axis, side " << side;
        EXPECT_EQ(prunedAt(side * Vec3(0.76, 0.74, 0.32)), 0) << "outside in x, side " << side;
        EXPECT_EQ(prunedAt(side * Vec3(0.74, 0.76, 0.32)), 0) << "outside in y, side " << side;
        EXPECT_EQ(prunedAt(side * Vec3(0.74, 0.74, 0.34)), 0) << "outside in z, side " << side;
    }
    // A Gaussian cloud: the pruned cloud is the unpruned one of the same seed minus its core, in
    // placement order, and the count is pinned (seed 9, 400 placements: 26 in the core, as
    // generated when this test was written; 400 P(|x| < 0.75) P(|y| < 0.75) P(|z| < 1/3) =
    // 400 * 0.547^2 * 0.261 = 31 expected, so 26 is an ordinary draw). A change of the core's
    // bounds or of the random sequence moves it (the 0.8 sigma core of the sabotage: 30, not 26).
    Generator all = cumulus(9, 400);
    all.hollow = all.pruneContained = false;
    Generator hollow = all;
    hollow.hollow = true;
    const Cloud full = generateCumulus(all);
    GenerateStats s;
    const Cloud pruned = generateCumulus(hollow, &s);
    EXPECT_EQ(s.prunedHollow, 26);
    EXPECT_EQ(full.ellipsoids.size() - pruned.ellipsoids.size(), size_t(s.prunedHollow));
    size_t k = 0;
    for (const Ellipsoid& e : full.ellipsoids)
        if (k < pruned.ellipsoids.size() && pruned.ellipsoids[k].center == e.center) ++k;
    EXPECT_EQ(k, pruned.ellipsoids.size()) << "the kept ellipsoids are the unpruned cloud's, in its order";
}

TEST(GenerateTest, ContainedPruningKeepsNoEllipsoidInsideAnother) {
    for (const Vec3 aspect : {Vec3(1, 1, 0.7), Vec3(1, 1, 1), Vec3(2, 0.5, 0.7)}) {
        Generator all = cumulus(4, 200);
        // Eq. 16 radii vary by only 0.05 max_radius per sigma of distance, so containment needs
        // sigma well below max_radius: tight clusters, where many are inside others.
        all.sigma = Vec3(8, 8, 6);
        all.aspect = aspect;
        all.hollow = all.pruneContained = false;
        Generator prune = all;
        prune.pruneContained = true;
        const Cloud full = generateCumulus(all);
        GenerateStats s;
        const Cloud kept = generateCumulus(prune, &s);
        EXPECT_GT(s.prunedContained, 0);
        for (size_t i = 0; i < kept.ellipsoids.size(); ++i)
            for (size_t j = 0; j < kept.ellipsoids.size(); ++j)
                if (i != j) {
                    EXPECT_FALSE(insideSampled(kept.ellipsoids[i], kept.ellipsoids[j])) << i << " holds " << j;
                }
        // Every dropped one is inside a kept one.
        size_t k = 0;
        for (const Ellipsoid& e : full.ellipsoids) {
            if (k < kept.ellipsoids.size() && kept.ellipsoids[k].center == e.center) {
                ++k;
                continue;
            }
            bool held = false;
            for (const Ellipsoid& o : kept.ellipsoids) held = held || insideSampled(o, e);
            EXPECT_TRUE(held);
        }
        EXPECT_EQ(k, kept.ellipsoids.size());
    }
}

TEST(GenerateTest, RotationDegreesRoundTrip) {
    for (const Vec3 deg :
         {Vec3(0), Vec3(10, 20, 30), Vec3(-170, 80, 100), Vec3(45, 90, 0), Vec3(30, -90, 0), Vec3(179, -45, -120)}) {
        const glm::dmat3 R = rotationFromDegrees(deg);
        const glm::dmat3 back = rotationFromDegrees(degreesFromRotation(R));
        for (int c = 0; c < 3; ++c)
            for (int r = 0; r < 3; ++r) EXPECT_NEAR(back[c][r], R[c][r], 1e-9) << deg.x << " " << deg.y << " " << deg.z;
    }
}

namespace {

Generator mesh(const std::string& file) {
    Generator g;
    g.type = Generator::Type::Mesh;
    g.name = "m";
    g.path = file;
    g.resolvedPath = kData + file;
    return g;
}

// The triangles of the test OBJs, transformed, in file order (fan triangulation).
void expectEllipsoidPerTriangle(const Cloud& c, const std::vector<std::array<Vec3, 3>>& tris, double thickness) {
    ASSERT_EQ(c.ellipsoids.size(), tris.size());
    for (size_t i = 0; i < tris.size(); ++i) {
        const auto& [A, B, C] = tris[i];
        const Ellipsoid& e = c.ellipsoids[i];
        const Vec3 G = (A + B + C) / 3.0;
        EXPECT_NEAR(glm::length(e.center - G), 0.0, 1e-9) << "triangle " << i;
        const glm::dmat3 R = rotationFromDegrees(e.rotationDeg);
        const Vec3 n = glm::normalize(glm::cross(B - A, C - A));
        EXPECT_NEAR(glm::dot(R[2], n), 1.0, 1e-9) << "local z along the triangle normal, triangle " << i;
        EXPECT_GE(e.radii.x, e.radii.y);
        EXPECT_NEAR(e.radii.z, thickness * e.radii.y, 1e-9 * e.radii.y);
        // Steiner circumellipse: the three vertices lie on the ellipsoid's equator.
        for (const Vec3& P : {A, B, C}) {
            const Vec3 q = glm::transpose(R) * (P - e.center) / e.radii;
            EXPECT_NEAR(glm::dot(q, q), 1.0, 1e-9) << "triangle " << i;
            EXPECT_NEAR(q.z, 0.0, 1e-9);
        }
    }
}

}  // namespace

TEST(GenerateTest, MeshTetrahedronGivesOneEllipsoidPerTriangle) {
    Generator g = mesh("scenes/tetra.obj");
    g.scale = 2;
    g.position = Vec3(10, 20, 1000);
    g.rotationDeg = Vec3(0, 0, 90);
    g.thicknessRatio = 0.3;
    g.density = 0.5;
    GenerateStats s;
    const Cloud c = generateMesh(g, &s);
    const glm::dmat3 R = rotationFromDegrees(g.rotationDeg);
    auto P = [&](double x, double y, double z) { return g.position + 2.0 * (R * Vec3(x, y, z)); };
    const Vec3 v1 = P(0, 0, 0), v2 = P(100, 0, 0), v3 = P(0, 100, 0), v4 = P(0, 0, 100);
    expectEllipsoidPerTriangle(c, {{v1, v3, v2}, {v1, v2, v4}, {v1, v4, v3}, {v2, v3, v4}}, 0.3);
    // Outward normals: tetra.obj winds its faces counter-clockwise seen from outside.
    const Vec3 centre = (v1 + v2 + v3 + v4) / 4.0;
    for (const Ellipsoid& e : c.ellipsoids)
        EXPECT_GT(glm::dot(rotationFromDegrees(e.rotationDeg)[2], e.center - centre), 0.0);
    for (const Ellipsoid& e : c.ellipsoids) EXPECT_EQ(e.density, 0.5);
    EXPECT_EQ(s.placed, 4);
    EXPECT_EQ(s.kept, 4);
    EXPECT_EQ(s.degenerate, 0);
}

TEST(GenerateTest, MeshPolygonsAreFannedAndIndexFormsRead) {
    // quad_fan.obj: a quad with v/vt/vn refs, a pentagon with negative refs and v//vn, and
    // a degenerate triangle (three collinear points).
    GenerateStats s;
    const Cloud c = generateMesh(mesh("quad_fan.obj"), &s);
    const Vec3 a(0, 0, 0), b(200, 0, 0), cq(200, 100, 0), d(0, 100, 0);
    const Vec3 p0(0, 0, 500), p1(100, 0, 500), p2(150, 80, 520), p3(50, 150, 540), p4(-50, 80, 520);
    expectEllipsoidPerTriangle(c, {{a, b, cq}, {a, cq, d}, {p0, p1, p2}, {p0, p2, p3}, {p0, p3, p4}}, 0.5);
    EXPECT_EQ(s.placed, 6);
    EXPECT_EQ(s.degenerate, 1);
    EXPECT_EQ(s.kept, 5);
    // The quad lies in z = 0 wound counter-clockwise seen from above: normal +z.
    EXPECT_NEAR(rotationFromDegrees(c.ellipsoids[0].rotationDeg)[2].z, 1.0, 1e-12);
    // A right triangle 200 x 100: its Steiner ellipse is not a circle.
    EXPECT_GT(c.ellipsoids[0].radii.x, c.ellipsoids[0].radii.y);
}

TEST(GenerateTest, MeshIsDeterministic) {
    EXPECT_TRUE(sameCloud(generateMesh(mesh("quad_fan.obj")), generateMesh(mesh("quad_fan.obj"))));
}

TEST(GenerateTest, BadObjNamesFileAndLine) {
    auto lineOf = [](const std::string& file) {
        try {
            generateMesh(mesh(file));
        } catch (const ObjError& e) {
            EXPECT_EQ(std::string(e.what()).rfind(kData + file + ":" + std::to_string(e.line()) + ": ", 0), 0u)
                << e.what();
            return e.line();
        }
        ADD_FAILURE() << file << " was accepted";
        return -1;
    };
    EXPECT_EQ(lineOf("bad_vertex.obj"), 3);  // "v 1 two 3"
    EXPECT_EQ(lineOf("bad_index.obj"), 5);   // "f 1 2 9" with 3 vertices
    EXPECT_EQ(lineOf("no_faces.obj"), 0);
}

TEST(GenerateTest, LoaderExpandsAndReportsBadObjWithSceneAndLine) {
    const std::string scene = kData + "inline.json";  // OBJ paths are relative to tests/data
    try {
        parseScene(R"({"cloudscene": 1, "camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]},
          "generate": [{"type": "cumulus", "center": [0, 500, 0]}, {"type": "mesh", "path": "bad_index.obj"}]})",
                   scene);
        FAIL() << "a scene with a bad OBJ loaded";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.file(), scene);
        EXPECT_EQ(e.jsonPath(), "generate[1].path");
        EXPECT_NE(e.fault().find("bad_index.obj:5: "), std::string::npos) << e.what();
        EXPECT_NE(e.fault().find("out of range"), std::string::npos) << e.what();
    }
}

TEST(GenerateTest, LoaderExpandsEveryGeneratorOnce) {
    Scene s = loadScene(kData + "scenes/mesh.json");
    ASSERT_EQ(s.generators.size(), 1u);  // kept as loaded
    ASSERT_EQ(s.generated.size(), 1u);
    ASSERT_EQ(s.clouds.size(), 1u);
    EXPECT_EQ(s.clouds[0].name, "mesh0");
    EXPECT_EQ(s.generated[0].name, "mesh0");
    EXPECT_EQ(s.generated[0].kept, 4);
    EXPECT_EQ(s.clouds[0].ellipsoids.size(), 4u);
    EXPECT_TRUE(expandGenerators(s).empty());  // already expanded: nothing added
    EXPECT_EQ(s.clouds.size(), 1u);
    s.generators.push_back(cumulus(1, 10));  // a host adds one in code
    const auto added = expandGenerators(s);
    ASSERT_EQ(added.size(), 1u);
    EXPECT_EQ(s.clouds.size(), 2u);
    EXPECT_EQ(s.generated.size(), 2u);
    EXPECT_EQ(static_cast<int>(s.clouds[1].ellipsoids.size()), added[0].kept);
}

namespace {

// The mean extinction (1/m) of a scene's clouds over the volume they fill (where the summed
// density is > 0), on a 96^3 grid of cell centres over the clouds' bounding box (finer than
// and offset from the generator's own 64^3 estimate).
double meanExtinctionOverVolume(const Scene& s) {
    struct Shape {
        glm::dmat3 toUnit;
        Vec3 center;
        double density, reach;
    };
    std::vector<Shape> shapes;
    Vec3 lo(1e300), hi(-1e300);
    for (const Cloud& c : s.clouds)
        for (const Ellipsoid& e : c.ellipsoids) {
            lo = glm::min(lo, e.center - e.maxRadius()), hi = glm::max(hi, e.center + e.maxRadius());
            const glm::dmat3 scale(1 / e.radii.x, 0, 0, 0, 1 / e.radii.y, 0, 0, 0, 1 / e.radii.z);
            shapes.push_back(
                {scale * glm::transpose(rotationFromDegrees(e.rotationDeg)), e.center, e.density, e.maxRadius()});
        }
    const int n = 96;
    double sum = 0;
    long filled = 0;
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const Vec3 x = lo + (Vec3(i, j, k) + 0.5) / double(n) * (hi - lo);
                double rho = 0;
                for (const Shape& e : shapes) {
                    const Vec3 d = x - e.center;
                    if (std::abs(d.x) > e.reach || std::abs(d.y) > e.reach || std::abs(d.z) > e.reach) continue;
                    const Vec3 u = e.toUnit * d;
                    const double q = glm::dot(u, u);
                    if (q < 1) rho += e.density * (1 - q) * (1 - q);
                }
                if (rho > 0) sum += rho, ++filled;
            }
    return s.medium.extinction * sum / double(filled);
}

}  // namespace

// "medium": "cumulus" gives a generated cumulus real cumulus matter (issue 34: a mean extinction
// of 0.05-0.1 /m over the cloud), whatever the scene's medium; without it the cloud is as before.
TEST(GenerateTest, CumulusMediumGivesRealCumulusDensity) {
    const std::string head = R"({"cloudscene": 1, "camera": {"position": [0, -3000, 1500], "look_at": [0, 0, 1500]}, )";
    const std::string small = R"({"type": "cumulus", "center": [0, 0, 1500], "medium": "cumulus"})";
    const std::string big = R"({"type": "cumulus", "center": [0, 0, 1500], "count": 200, "seed": 3, )"
                            R"("sigma": [450, 350, 150], "max_radius": 230, "medium": "cumulus"})";
    for (const auto& [medium, entry] :
         {std::pair{std::string(R"("medium": {"extinction": 0.04})"), small},
          std::pair{std::string(R"("medium": {"extinction": 0.5})"), small},
          std::pair{std::string(R"("medium": {"liquid_water_content": 0.1, "droplet_effective_radius": 20})"), small},
          std::pair{std::string(R"("medium": {"extinction": 0.04})"), big}}) {
        {
            SCOPED_TRACE(medium + " " + entry);
            const Scene s = parseScene(head + medium + R"(, "generate": [)" + entry + "]}", "test.json");
            ASSERT_EQ(s.clouds.size(), 1u);
            for (const Ellipsoid& e : s.clouds[0].ellipsoids) EXPECT_EQ(e.density, s.clouds[0].ellipsoids[0].density);
            // The generator's 64^3 estimate of the mean against this 96^3 one: measured 0.0750 in every
            // case. Scaled for a lone ellipsoid (kCumulusExtinction, no overlap) it was 0.16 (small)
            // and 0.28 /m (big): the ellipsoids overlap.
            const double mean = meanExtinctionOverVolume(s);
            std::printf("mean extinction over the cloud: %.4f /m\n", mean);
            EXPECT_NEAR(mean, meanExtinctionFromWater(kCumulusLiquidWater, kCumulusDropletRadius), 0.0075);
            EXPECT_GE(mean, 0.05);
            EXPECT_LE(mean, 0.1);
        }
    }
    // The default ("scene") keeps the scene's own, thin matter: the goldens' clouds.
    const Scene thin = parseScene(head + R"("generate": [{"type": "cumulus", "center": [0, 0, 1500]}]})", "test.json");
    for (const Ellipsoid& e : thin.clouds[0].ellipsoids) EXPECT_EQ(e.density, 1.0);
    const double thinMean = meanExtinctionOverVolume(thin);
    std::printf("mean extinction over the default cloud, default medium: %.4f /m\n", thinMean);
    EXPECT_LT(thinMean, 0.05);
}

// The showcase (README command 1, issue 34 §6) is real cumulus with the detail: its cumulus's
// mean extinction over the cloud in 0.05-0.1 /m (measured 0.0750), the eroding detail on.
TEST(GenerateTest, TheShowcaseIsRealCumulusWithTheDetail) {
    const Scene s = loadScene(NEPHELE_SCENES "/showcase.json");
    ASSERT_EQ(s.clouds.size(), 1u);
    const double mean = meanExtinctionOverVolume(s);
    std::printf("mean extinction over the showcase's cumulus: %.4f /m\n", mean);
    EXPECT_GE(mean, 0.05);
    EXPECT_LE(mean, 0.1);
    EXPECT_TRUE(s.medium.detail.on());
}

TEST(GenerateTest, CumulusMediumRules) {
    const std::string head = R"({"cloudscene": 1, "camera": {"position": [0, -3000, 1500], "look_at": [0, 0, 1500]}, )";
    auto fault = [&](const std::string& rest) {
        try {
            parseScene(head + rest + "}", "test.json");
        } catch (const SceneError& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_EQ(fault(R"("generate": [{"type": "cumulus", "center": [0, 0, 0], "medium": "cumulus", "density": 2}])"),
              "test.json: generate[0].density: give either 'density' or \"medium\": \"cumulus\" (which sets the "
              "density), not both");
    EXPECT_EQ(fault(R"("medium": {"extinction": 0}, "generate": )"
                    R"([{"type": "cumulus", "center": [0, 0, 0], "medium": "cumulus"}])"),
              "test.json: generate[0].medium: 'cumulus' sets the density to 0.328125 / medium.extinction, and "
              "medium.extinction is 0");
    EXPECT_EQ(fault(R"("generate": [{"type": "cumulus", "center": [0, 0, 0], "medium": "stratus"}])"),
              "test.json: generate[0].medium: must be one of 'scene', 'cumulus', got 'stratus'");
    EXPECT_EQ(fault(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], )"
                    R"("axiom": "F", "rules": {}, "medium": "cumulus"}])"),
              "test.json: generate[0].medium: 'medium' is not a key of a lsystem generator");
}

namespace {

Generator lsystem(const std::string& axiom, std::vector<std::pair<char, std::string>> rules, int iterations) {
    Generator g;
    g.type = Generator::Type::LSystem;
    g.name = "l";
    g.center = Vec3(0, 0, 1000);
    g.axiom = axiom;
    g.rules = std::move(rules);
    g.iterations = iterations;
    return g;
}

}  // namespace

TEST(GenerateTest, LSystemSingleF) {
    Generator g = lsystem("F", {{'F', "F[+F]F[-F]"}}, 0);
    g.jitter = 0;
    GenerateStats s;
    const Cloud c = generateLSystem(g, &s);
    ASSERT_EQ(c.ellipsoids.size(), 1u);
    // Heading east, the sphere at the middle of the step.
    EXPECT_NEAR(glm::length(c.ellipsoids[0].center - Vec3(50, 0, 1000)), 0.0, 1e-9);
    EXPECT_EQ(c.ellipsoids[0].radii, Vec3(80));
    EXPECT_EQ(s.placed, 1);
    EXPECT_EQ(s.kept, 1);
}

TEST(GenerateTest, LSystemKnownCounts) {
    // F -> F[+F]F[-F]: 4^n spheres after n rewritings.
    for (int n = 0; n <= 4; ++n)
        EXPECT_EQ(generateLSystem(lsystem("F", {{'F', "F[+F]F[-F]"}}, n)).ellipsoids.size(),
                  static_cast<size_t>(std::pow(4, n)));
    // The paper's eq. 18 grammar with F for its spheres: X -> XF+YF&X... here A -> F+B, B -> FF&A:
    // F-counts follow a(n+1) = 1 + b(n), b(n+1) = 2 + a(n); from A: 0, 1, 3, 4, 6.
    const int expected[] = {0, 1, 3, 4, 6};
    for (int n = 0; n <= 4; ++n)
        EXPECT_EQ(generateLSystem(lsystem("A", {{'A', "F+B"}, {'B', "FF&A"}}, n)).ellipsoids.size(),
                  static_cast<size_t>(expected[n]))
            << n;
}

TEST(GenerateTest, LSystemTurtleAndJitter) {
    // With jitter 0 the turtle is exact: F+F with 90 degrees turns left (east then north);
    // [ ] restores the position; & pitches down.
    Generator g = lsystem("F[+F]F[&F]", {}, 0);
    g.angleDeg = 90;
    g.jitter = 0;
    const Cloud c = generateLSystem(g);
    ASSERT_EQ(c.ellipsoids.size(), 4u);
    auto at = [&](size_t i, Vec3 p) { EXPECT_NEAR(glm::length(c.ellipsoids[i].center - p), 0.0, 1e-9) << i; };
    at(0, {50, 0, 1000});
    at(1, {100, 50, 1000});
    at(2, {150, 0, 1000});
    at(3, {200, 0, 950});
    // Jitter: radius and step vary within +-jitter, deterministically from the seed.
    Generator j = lsystem("F", {{'F', "FF"}}, 6);
    j.jitter = 0.3;
    const Cloud a = generateLSystem(j), b = generateLSystem(j);
    EXPECT_TRUE(sameCloud(a, b));
    j.seed = 2;
    EXPECT_FALSE(sameCloud(a, generateLSystem(j)));
    double lo = 1e9, hi = 0;
    for (const Ellipsoid& e : a.ellipsoids) {
        lo = std::min(lo, e.radii.x);
        hi = std::max(hi, e.radii.x);
    }
    EXPECT_GE(lo, 80 * 0.7);
    EXPECT_LE(hi, 80 * 1.3);
    EXPECT_LT(lo, 80 * 0.85);  // 64 draws spread over the range
    EXPECT_GT(hi, 80 * 1.15);
}

TEST(GenerateTest, LSystemExplosionIsRefused) {
    Generator g = lsystem("F", {{'F', "FFFFFFFFFF"}}, 8);  // 10^8 symbols
    EXPECT_THROW(generateLSystem(g), std::length_error);
}
