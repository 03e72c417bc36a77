// `nephele bench --scale --quick`: every method at two counts, per-phase times and memory,
// the growth exponents, and the generated section it writes for docs/benchmarks.md.
#include "cli_run.hpp"
#include "temp_dir.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

TEST(ScaleBenchTest, QuickRunWritesPhasesAndExponents) {
    const fs::path dir = nephele::test::freshProcessDir("nephele_scale_bench_test_");
    // Under the sanitizers 16 and 48 ellipsoids (160's radiance grids and CPU reference are
    // most of the time; the code checked is the same).
    const std::string counts[2] = {"16", nephele::test::kSanitized ? "48" : "160"};
    const auto r = nephele::test::runBounded(
        "bench --scale --quick --scale-counts " + counts[0] + " " + counts[1] + " --out-dir " + dir.string(), 4096,
        300);
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string csv = slurp(dir / "scale_bench.csv");
    EXPECT_EQ(
        csv.rfind("ellipsoids,method,size,load_ms,load_peak_mb,plan_ms,draw_ms,frame_peak_mb,next_ms,refused\n", 0),
        0u);
    int rows = 0;
    for (const char* method : {"ellipsoid", "auto", "raymarch", "gardner-exact"})
        for (const std::string& count : counts) {
            const std::string start = "\n" + count + "," + method + ",";
            const std::size_t at = csv.find(start);
            ASSERT_NE(at, std::string::npos) << start << "\n" << csv;
            const std::string line = csv.substr(at + 1, csv.find('\n', at + 1) - at - 1);
            EXPECT_EQ(line.find("nan"), std::string::npos) << line;
            EXPECT_EQ(line.substr(line.size() - 3), ",\"\"") << "refused: " << line;
            ++rows;
        }
    EXPECT_EQ(rows, 8);
    const std::string section = slurp(dir / "scale_bench.md");
    EXPECT_EQ(section.rfind("<!-- BEGIN GENERATED: scale bench -->\nMeasured by `nephele bench --scale` on ", 0), 0u)
        << section;
    EXPECT_NE(section.find("| ellipsoid | "), std::string::npos);
    EXPECT_NE(section.find("Growth exponent"), std::string::npos);
    EXPECT_NE(section.find("<!-- END GENERATED: scale bench -->\n"), std::string::npos);
    // The docs/ regeneration step puts it into benchmarks.md and copies its CSV beside it.
    fs::create_directories(dir / "docs");
    std::ofstream(dir / "docs" / "benchmarks.md")
        << "# x\n<!-- BEGIN GENERATED: scale bench -->\nold\n<!-- END GENERATED: scale bench -->\n";
    const auto p = nephele::test::runBounded(
        "bench --publish " + (dir / "docs").string() + " --out-dir " + dir.string(), 1024, 30);
    ASSERT_EQ(p.code, 0) << p.output;
    const std::string page = slurp(dir / "docs" / "benchmarks.md");
    EXPECT_EQ(page.find("old\n"), std::string::npos);
    EXPECT_NE(page.find("Growth exponent"), std::string::npos);
    EXPECT_EQ(slurp(dir / "docs" / "scale_bench.csv"), csv);
    fs::remove_all(dir);
}

TEST(ScaleBenchTest, BadCountsAndModesAreRefused) {
    const auto zero = nephele::test::runBounded("bench --scale --scale-counts 0", 1024, 30);
    EXPECT_EQ(zero.code, 2) << zero.output;
    EXPECT_NE(zero.output.find("--scale-counts: must be in 1..1000000, got 0"), std::string::npos) << zero.output;
    const auto both = nephele::test::runBounded("bench --scale --layered", 1024, 30);
    EXPECT_EQ(both.code, 2) << both.output;
}

}  // namespace

namespace {

// `nephele bench --grids --quick`: single.json's one cloud, its grid's size, time and memory,
// and the generated section it writes for docs/benchmarks.md.
TEST(GridBenchTest, QuickRunWritesEachCloudsTimeAndMemory) {
    const fs::path dir = nephele::test::freshProcessDir("nephele_grid_bench_test_");
    const auto r = nephele::test::runBounded(
        "bench --grids --quick --scenes " + std::string(NEPHELE_SCENES) + " --out-dir " + dir.string(), 4096, 120);
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string csv = slurp(dir / "grid_bench.csv");
    ASSERT_EQ(csv.rfind("scene,cloud,ellipsoids,optical_radius,size,ms,mb\n", 0), 0u) << csv;
    // single.json: one ellipsoid of optical radius 10, so a 16^3 grid (radianceGridSize), and
    // its bytes as radianceGridBytes(16) counts them: 16^3 (96 + 8 * 6) B = 0.5625 MiB.
    const std::string row = csv.substr(csv.find('\n') + 1);
    EXPECT_EQ(row.rfind("single.json,0,1,", 0), 0u) << row;
    EXPECT_NE(row.find(",16,"), std::string::npos) << row;
    EXPECT_NE(row.find(",0.5625\n"), std::string::npos) << row;
    const double ms = std::stod(row.substr(row.find(",16,") + 4));
    EXPECT_GT(ms, 0.0);
    const std::string section = slurp(dir / "grid_bench.md");
    EXPECT_EQ(section.rfind("<!-- BEGIN GENERATED: grid bench -->\nMeasured by `nephele bench --grids` on ", 0), 0u)
        << section;
    EXPECT_NE(section.find("| `single.json` | 1 | 1 × 16³ |"), std::string::npos) << section;
    EXPECT_NE(section.find("<!-- END GENERATED: grid bench -->\n"), std::string::npos);
    fs::remove_all(dir);
}

}  // namespace
