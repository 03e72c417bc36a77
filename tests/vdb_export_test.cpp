// `nephele export SCENE --vdb FILE`: the file read back with OpenVDB holds the path tracer's
// extinction field (nephele::ExtinctionField) at every voxel centre, to float precision, and
// between centres within the trilinear interpolation's error bound; bad arguments exit 2 with
// a message and leave no file.
#include "cli_run.hpp"
#include "temp_dir.hpp"

#include "nephele/gardner.hpp"  // NoiseSettings
#include "nephele/limits.hpp"
#include "nephele/pathtrace.hpp"
#include "nephele/scene.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

namespace fs = std::filesystem;
using namespace nephele;

namespace {

class VdbExportTest : public ::testing::Test {
protected:
    void SetUp() override {
        openvdb::initialize();
        dir_ = test::freshProcessDir("vdb_export-", true, NEPHELE_TEST_OUTPUT);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    // `scene` with medium.noise set to `noise`, written to the test's folder.
    std::string withNoise(const std::string& scene, double noise) const {
        std::ifstream in(scene);
        nlohmann::json j = nlohmann::json::parse(in);
        j["medium"]["noise"] = noise;
        const std::string out = path(fs::path(scene).stem().string() + "-noise" + std::to_string(noise) + ".json");
        std::ofstream(out) << j.dump(1);
        return out;
    }

    // Runs `nephele export` and reads the grid back (null when the file is not there).
    openvdb::FloatGrid::Ptr exportAndRead(const std::string& scene, const std::string& file,
                                          const std::string& more = "") {
        const test::BoundedRun r = test::runBounded("export " + scene + " --vdb " + file + " " + more, 8192, 300);
        EXPECT_EQ(r.code, 0) << r.output;
        if (!fs::exists(file)) return nullptr;
        openvdb::io::File f(file);
        f.open();
        openvdb::GridBase::Ptr base = f.readGrid("density");
        f.close();
        return openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    }

    fs::path dir_;
};

// The field the export must hold: the path tracer's, for the scene as loaded.
struct Field {
    Scene scene;
    NoiseVolume noise;
    std::unique_ptr<ExtinctionField> field;
    explicit Field(const std::string& file) : scene(loadScene(file)) {
        const NoiseSettings ns;
        if (scene.medium.noise > 0) noise = makeNoiseVolume(ns);
        field = std::make_unique<ExtinctionField>(scene, &noise);
    }
    double operator()(const Vec3& p) const { return (*field)(p); }
};

// Points inside the ellipsoids, uniform in a random ellipsoid's unit ball (most hold matter),
// and a quarter of them anywhere in the field's box (most are empty).
std::vector<Vec3> samplePoints(const Field& f, int count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), unit(0, 1);
    std::vector<Vec3> points;
    std::vector<const Ellipsoid*> all;
    for (const Cloud& c : f.scene.clouds)
        for (const Ellipsoid& e : c.ellipsoids) all.push_back(&e);
    while (int(points.size()) < count) {
        if (points.size() % 4 == 3) {
            points.push_back(f.field->lo() + Vec3(unit(rng), unit(rng), unit(rng)) * (f.field->hi() - f.field->lo()));
            continue;
        }
        const Ellipsoid& e = *all[std::size_t(unit(rng) * double(all.size())) % all.size()];
        const Vec3 b(u(rng), u(rng), u(rng));
        if (glm::dot(b, b) >= 1) continue;
        points.push_back(e.center + rotationFromDegrees(e.rotationDeg) * (b * e.radii));
    }
    return points;
}

// The value at each voxel centre is the field there, to float precision: 200 random centres.
void expectCentresHoldTheField(const openvdb::FloatGrid& grid, const Field& f, const std::string& label) {
    const openvdb::math::Transform& xf = grid.transform();
    auto acc = grid.getConstAccessor();
    int withMatter = 0;
    double worst = 0;
    for (const Vec3& p : samplePoints(f, 200, 11)) {
        const openvdb::Coord ijk = openvdb::Coord::round(xf.worldToIndex(openvdb::Vec3d(p.x, p.y, p.z)));
        const openvdb::Vec3d c = xf.indexToWorld(ijk);
        const double want = f(Vec3(c.x(), c.y(), c.z())), got = acc.getValue(ijk);
        withMatter += want > 0;
        // 1e-3 relative (the issue's bound; float storage: measured 5.6e-8; with the transform off
        // by half a voxel 0.88) and 1e-9 /m absolute.
        EXPECT_NEAR(got, want, 1e-3 * want + 1e-9) << label << " at voxel " << ijk << " (world " << c << ")";
        if (want > 0) worst = std::max(worst, std::abs(got - want) / want);
    }
    EXPECT_GE(withMatter, 100) << label << ": too few samples in the matter to test anything";
    std::printf("%s: %d of 200 voxel centres in matter, worst relative error %.2e\n", label.c_str(), withMatter, worst);
}

// |f - trilinear(f)| <= sum over axes a of (v^2 / 8) max |d^2 f / dx_a^2| on the cell (f is C1
// and piecewise C2: (1 - q)^2 meets 0 with zero slope). For one ellipsoid, f = s g^2 with
// g = 1 - q, q = |M (x - c)|^2, M = diag(1/r) R^T: |dg/dx_a| <= 2 |M e_a| and |d^2g/dx_a^2| =
// 2 |M e_a|^2 inside, so |d^2f/dx_a^2| = s |2 g'^2 + 2 g g''| <= 12 s |M e_a|^2. Summed over the
// ellipsoids within a cell diagonal of p.
double trilinearBound(const Scene& scene, const Vec3& p, double v) {
    double bound = 0;
    for (const Cloud& c : scene.clouds)
        for (const Ellipsoid& e : c.ellipsoids) {
            if (glm::length(p - e.center) > e.maxRadius() + 2 * v) continue;
            const glm::dmat3 r = rotationFromDegrees(e.rotationDeg);
            const double sigma = scene.medium.extinction * e.density;
            for (int a = 0; a < 3; ++a) {
                double me2 = 0;  // |M e_a|^2 = sum_k (R_ak / r_k)^2
                for (int k = 0; k < 3; ++k) me2 += (r[k][a] / e.radii[k]) * (r[k][a] / e.radii[k]);
                bound += v * v / 8 * 12 * sigma * me2;
            }
        }
    return bound;
}

}  // namespace

TEST_F(VdbExportTest, VoxelCentresHoldThePathTracersField) {
    for (const char* name : {"single.json", "cumulus27.json"}) {
        SCOPED_TRACE(name);
        const std::string scene = std::string(NEPHELE_SCENES "/") + name, file = path(std::string(name) + ".vdb");
        const openvdb::FloatGrid::Ptr grid = exportAndRead(scene, file);
        ASSERT_TRUE(grid);
        EXPECT_EQ(grid->getName(), "density");
        EXPECT_EQ(grid->getGridClass(), openvdb::GRID_FOG_VOLUME);
        EXPECT_TRUE(grid->transform().isLinear());
        const Field f(scene);
        EXPECT_GT(f.scene.medium.noise, 0);  // the shipped scenes' noise: the export holds it too
        expectCentresHoldTheField(*grid, f, name);
        // The whole field lies within the grid's samples: the box's corners are within half a voxel of a centre.
        const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
        const openvdb::Vec3d lo = grid->transform().indexToWorld(box.min()),
                             hi = grid->transform().indexToWorld(box.max());
        const double v = grid->voxelSize().x();
        for (int a = 0; a < 3; ++a) {
            EXPECT_GE(lo[a], f.field->lo()[a] - 0.5 * v);
            EXPECT_LE(hi[a], f.field->hi()[a] + 0.5 * v);
        }
    }
}

// With --voxel, and with the exact field (noise 0) between centres: trilinear interpolation
// of the grid (what a renderer reads) stays within trilinearBound of the field.
TEST_F(VdbExportTest, BetweenCentresTheGridInterpolatesTheField) {
    for (const auto& [name, voxel] : {std::pair{"single.json", 8.0}, std::pair{"cumulus27.json", 6.0}}) {
        SCOPED_TRACE(name);
        const std::string scene = withNoise(std::string(NEPHELE_SCENES "/") + name, 0),
                          file = path(std::string(name) + ".vdb");
        const openvdb::FloatGrid::Ptr grid = exportAndRead(scene, file, "--voxel " + std::to_string(voxel));
        ASSERT_TRUE(grid);
        EXPECT_DOUBLE_EQ(grid->voxelSize().x(), voxel);
        const Field f(scene);
        expectCentresHoldTheField(*grid, f, std::string(name) + " noise 0");
        openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(*grid);
        double worstShare = 0;  // the largest error as a share of its bound
        int withMatter = 0;
        for (const Vec3& p : samplePoints(f, 200, 23)) {
            const double want = f(p), got = sampler.wsSample(openvdb::Vec3d(p.x, p.y, p.z));
            const double bound = trilinearBound(f.scene, p, voxel) + 1e-3 * want + 1e-9;
            withMatter += want > 0;
            EXPECT_NEAR(got, want, bound) << "at " << p.x << ", " << p.y << ", " << p.z;
            worstShare = std::max(worstShare, std::abs(got - want) / bound);
        }
        EXPECT_GE(withMatter, 100);
        // Measured: 0.29 of the bound (single) and 0.25 (cumulus27); with the grid's transform off
        // by half a voxel along x 3.4 and 4.6 (tests/sabotage/60), and the centres' test fails too.
        std::printf("%s: interpolation error at most %.2f of its bound\n", name, worstShare);
    }
}

TEST_F(VdbExportTest, BadArgumentsExitTwoAndWriteNothing) {
    const std::string single = NEPHELE_SCENES "/single.json", out = path("out.vdb");
    auto expectRefused = [&](const std::string& args, const std::string& message) {
        const test::BoundedRun r = test::runBounded("export " + args, 8192, 60);
        EXPECT_EQ(r.code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
        EXPECT_FALSE(fs::exists(out)) << args;
        for (const auto& e : fs::directory_iterator(dir_))
            EXPECT_EQ(e.path().string().find(".partial-"), std::string::npos) << "left behind: " << e.path();
    };
    expectRefused(single, "--vdb is required");
    expectRefused(single + " --vdb " + out + " --voxel 0", "--voxel");
    expectRefused(single + " --vdb " + out + " --voxel -2", "--voxel");
    expectRefused(single + " --vdb " + out + " --voxel nan", "--voxel");
    // 640 x 520 x 400 m (and the path tracer's 1e-9 of slack) at 0.1 m: 6402 x 5202 x 4002 voxels.
    expectRefused(
        single + " --vdb " + out + " --voxel 0.1",
        "--voxel 0.1 m gives 6402 x 5202 x 4002 = 133279422408 voxels over the field's extent (640 x 520 x 400 m), "
        "over the limit 'VDB export voxels' (67108864); give a larger --voxel");
    expectRefused(path("missing.json") + " --vdb " + out, "missing.json");
    std::ofstream(path("bad.json"))
        << R"({"cloudscene": 1, "camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]}, )"
           R"("medium": {"extinction": 0.04, "liquid_water_content": 1, "droplet_effective_radius": 10}})";
    expectRefused(path("bad.json") + " --vdb " + out,
                  "bad.json: medium.liquid_water_content: give either 'extinction' or the pair");
    std::ofstream(path("empty.json"))
        << R"({"cloudscene": 1, "camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]}})";
    expectRefused(path("empty.json") + " --vdb " + out, "empty.json: the scene holds no cloud matter to export");
    fs::create_directories(path("folder.vdb"));
    const test::BoundedRun r = test::runBounded("export " + single + " --vdb " + path("folder.vdb"), 8192, 60);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("--vdb"), std::string::npos) << r.output;
    EXPECT_TRUE(fs::is_directory(path("folder.vdb")));
}

// An existing file is replaced whole, or kept when the export is refused.
TEST_F(VdbExportTest, AnExistingFileIsReplacedOrKept) {
    const std::string out = path("keep.vdb");
    std::ofstream(out) << "old";
    const test::BoundedRun refused =
        test::runBounded("export " NEPHELE_SCENES "/single.json --vdb " + out + " --voxel 0.1", 8192, 60);
    EXPECT_EQ(refused.code, 2) << refused.output;
    EXPECT_EQ(fs::file_size(out), 3u);
    ASSERT_TRUE(exportAndRead(NEPHELE_SCENES "/single.json", out, "--voxel 20"));
    EXPECT_GT(fs::file_size(out), 3u);
}
