// Tile-atlas packer: exact layouts for small inputs, then properties over many random inputs,
// checked by an independent checker (which is itself shown to reject broken results).
#include "packer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

using namespace nephele;
using ::testing::AssertionFailure;
using ::testing::AssertionResult;
using ::testing::AssertionSuccess;

namespace {

int floorPow2Test(int v) {
    int p = 1;
    while (p * 2 <= v) p *= 2;
    return p;
}

std::string describe(const TilePlacement& p) {
    return "tile " + std::to_string(p.id) + " (size " + std::to_string(p.size) + ", pass " + std::to_string(p.pass) +
           " at " + std::to_string(p.x) + "," + std::to_string(p.y) + ")";
}

// Checks everything packTiles promises that can be checked cheaply, without its algorithm:
// one placement per request with the requested size; passes and utilisation consistent; tiles
// inside the atlas and aligned to their size; placement order by size descending then id; no
// overlap within a pass; and first pass with room: when a tile was placed, no earlier pass had a
// free aligned slot of its size.
AssertionResult checkPacking(const std::vector<TileRequest>& tiles, int w, int h, const PackResult& r) {
    if (r.placements.size() != tiles.size())
        return AssertionFailure() << r.placements.size() << " placements for " << tiles.size() << " tiles";
    std::map<int, int> requested;  // id -> size
    for (const TileRequest& t : tiles) requested[t.id] = t.size;
    std::map<int, int> seen;
    int maxPass = -1;
    for (const TilePlacement& p : r.placements) {
        auto it = requested.find(p.id);
        if (it == requested.end() || it->second != p.size)
            return AssertionFailure() << describe(p) << " was not requested with that size";
        if (seen[p.id]++) return AssertionFailure() << describe(p) << " is placed twice";
        if (p.pass < 0) return AssertionFailure() << describe(p) << " has a negative pass";
        if (p.x < 0 || p.y < 0 || p.x + p.size > w || p.y + p.size > h)
            return AssertionFailure() << describe(p) << " is outside the " << w << "x" << h << " atlas";
        if (p.x % p.size || p.y % p.size) return AssertionFailure() << describe(p) << " is not aligned to its size";
        maxPass = std::max(maxPass, p.pass);
    }
    if (r.passes != maxPass + 1)
        return AssertionFailure() << r.passes << " passes reported, " << maxPass + 1 << " used";
    if (int(r.utilisation.size()) != r.passes)
        return AssertionFailure() << r.utilisation.size() << " utilisation entries for " << r.passes << " passes";

    for (size_t i = 1; i < r.placements.size(); ++i) {
        const TilePlacement &a = r.placements[i - 1], &b = r.placements[i];
        if (a.size < b.size || (a.size == b.size && a.id >= b.id))
            return AssertionFailure() << describe(b) << " is listed after " << describe(a);
    }

    // Overlap: per pass, sweep in x; only tiles starting before a tile's right edge can overlap it.
    std::vector<std::vector<TilePlacement>> byPass(r.passes);
    for (const TilePlacement& p : r.placements) byPass[p.pass].push_back(p);
    std::vector<double> area(r.passes, 0.0);
    for (int k = 0; k < r.passes; ++k) {
        std::vector<TilePlacement>& v = byPass[k];
        if (v.empty()) return AssertionFailure() << "pass " << k << " is empty";
        std::sort(v.begin(), v.end(), [](const TilePlacement& a, const TilePlacement& b) { return a.x < b.x; });
        for (size_t i = 0; i < v.size(); ++i) {
            area[k] += double(v[i].size) * v[i].size;
            for (size_t j = i + 1; j < v.size() && v[j].x < v[i].x + v[i].size; ++j)
                if (v[j].y < v[i].y + v[i].size && v[i].y < v[j].y + v[j].size)
                    return AssertionFailure() << describe(v[i]) << " overlaps " << describe(v[j]);
        }
    }

    double sum = 0.0;
    for (int k = 0; k < r.passes; ++k) {
        const double expected = area[k] / (double(w) * h);
        if (std::abs(r.utilisation[k] - expected) > 1e-12 || r.utilisation[k] < 0.0 || r.utilisation[k] > 1.0)
            return AssertionFailure() << "pass " << k << " utilisation " << r.utilisation[k] << ", expected "
                                      << expected;
        sum += expected;
    }
    const double mean = r.passes ? sum / r.passes : 0.0;
    if (std::abs(r.meanUtilisation() - mean) > 1e-12)
        return AssertionFailure() << "mean utilisation " << r.meanUtilisation() << ", expected " << mean;

    // First pass with room, by counting. Replay in placement order. The tiles already in a pass
    // are aligned, inside the atlas, disjoint and (by the order check) no smaller than the tile of
    // side s being placed, so each covers exactly (its side / s)^2 of the floor(w/s) * floor(h/s)
    // aligned s-slots of the atlas and no part of any other. A free s-slot therefore existed iff
    // the pass's area so far was below floor(w/s) * floor(h/s) * s^2.
    std::vector<std::int64_t> filled(r.passes, 0);
    for (const TilePlacement& p : r.placements) {
        const std::int64_t s = p.size, capacity = std::int64_t(w / s) * (h / s) * s * s;
        for (int q = 0; q < p.pass; ++q)
            if (filled[q] < capacity)
                return AssertionFailure() << describe(p) << " would still have fitted into pass " << q;
        filled[p.pass] += s * s;
    }
    return AssertionSuccess();
}

// Morton (Z-order) code of a position: x in the even bits, y in the odd bits.
std::uint64_t morton(int x, int y) {
    std::uint64_t m = 0;
    for (int b = 0; (x >> b) | (y >> b); ++b)
        m |= std::uint64_t((x >> b) & 1) << (2 * b) | std::uint64_t((y >> b) & 1) << (2 * b + 1);
    return m;
}

// Brute force, for small atlases: replays the placements on a pixel grid per pass and checks each
// tile against the definition of first fit: no earlier pass has a free aligned slot of its size,
// and in its own pass it sits at the free aligned slot whose bottom-left corner comes first in
// Morton order.
AssertionResult checkFirstFitBruteForce(int w, int h, const PackResult& r) {
    std::vector<std::vector<char>> used;  // per pass, w * h pixels, row y at y * w
    for (const TilePlacement& p : r.placements) {
        while (int(used.size()) <= p.pass) used.emplace_back(size_t(w) * h, 0);
        const int s = p.size;
        for (int q = 0; q <= p.pass; ++q) {
            const std::vector<char>& g = used[q];
            auto slotFree = [&](int x0, int y0) {
                for (int y = y0; y < y0 + s; ++y)
                    for (int x = x0; x < x0 + s; ++x)
                        if (g[size_t(y) * w + x]) return false;
                return true;
            };
            int fx = -1, fy = -1;  // first free aligned slot in scan order
            std::uint64_t first = std::numeric_limits<std::uint64_t>::max();
            for (int y = 0; y + s <= h; y += s)
                for (int x = 0; x + s <= w; x += s)
                    if (morton(x, y) < first && slotFree(x, y)) fx = x, fy = y, first = morton(x, y);
            if (q < p.pass && fx >= 0)
                return AssertionFailure()
                       << describe(p) << " would have fitted into pass " << q << " at " << fx << "," << fy;
            if (q == p.pass && (fx != p.x || fy != p.y))
                return AssertionFailure() << describe(p) << " is not at the first free slot " << fx << "," << fy;
        }
        for (int y = p.y; y < p.y + s; ++y)
            for (int x = p.x; x < p.x + s; ++x) used[p.pass][size_t(y) * w + x] = 1;
    }
    return AssertionSuccess();
}

int floorLevel(int v) {  // floor(log2(v)) for v >= 1
    int l = 0;
    while ((2 << l) <= v) ++l;
    return l;
}

// Random tiles with unique (possibly negative, non-contiguous) ids in random order. The size mix
// varies: uniform over levels, mostly small, a single size, or two sizes.
std::vector<TileRequest> randomTiles(std::mt19937& rng, int count, int maxSize) {
    const int maxLevel = floorLevel(maxSize);
    const int mode = std::uniform_int_distribution<int>(0, 3)(rng);
    std::uniform_int_distribution<int> anyLevel(0, maxLevel);
    std::geometric_distribution<int> smallLevel(0.5);
    const int a = anyLevel(rng), b = anyLevel(rng);
    const int base = std::uniform_int_distribution<int>(-1000, 1000)(rng);
    const int step = std::uniform_int_distribution<int>(1, 7)(rng);
    std::vector<TileRequest> tiles;
    for (int i = 0; i < count; ++i) {
        int level = 0;
        switch (mode) {
            case 0: level = anyLevel(rng); break;
            case 1: level = std::min(maxLevel, smallLevel(rng)); break;
            case 2: level = a; break;
            default: level = (rng() & 1) ? a : b; break;
        }
        tiles.push_back({base + i * step, 1 << level});
    }
    std::shuffle(tiles.begin(), tiles.end(), rng);
    return tiles;
}

std::int64_t totalArea(const std::vector<TileRequest>& tiles) {
    std::int64_t a = 0;
    for (const TileRequest& t : tiles) a += std::int64_t(t.size) * t.size;
    return a;
}

template <class F>
std::string thrownMessage(F f) {
    try {
        f();
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "(no std::invalid_argument)";
}

TEST(PackerTest, TileSizeForRoundsUpAndClamps) {
    EXPECT_EQ(tileSizeFor(0.3, 4, 256), 4);
    EXPECT_EQ(tileSizeFor(0.3, 1, 256), 1);
    EXPECT_EQ(tileSizeFor(1.0, 1, 256), 1);
    EXPECT_EQ(tileSizeFor(1.5, 1, 256), 2);
    EXPECT_EQ(tileSizeFor(5.0, 1, 256), 8);
    EXPECT_EQ(tileSizeFor(8.0, 1, 256), 8);
    EXPECT_EQ(tileSizeFor(8.01, 1, 256), 16);
    EXPECT_EQ(tileSizeFor(255.9, 1, 256), 256);
    EXPECT_EQ(tileSizeFor(256.0, 1, 256), 256);
    EXPECT_EQ(tileSizeFor(257.0, 1, 256), 256);
    EXPECT_EQ(tileSizeFor(1e300, 1, 256), 256);
    EXPECT_EQ(tileSizeFor(3.0, 16, 16), 16);
    EXPECT_EQ(tileSizeFor(100.0, 16, 16), 16);
    EXPECT_EQ(tileSizeFor(1e9, 1, 1 << 30), 1 << 30);
    EXPECT_EQ(tileSizeFor(0.0, 2, 64), 2);
    EXPECT_EQ(tileSizeFor(-5.0, 2, 64), 2);
    EXPECT_EQ(tileSizeFor(std::numeric_limits<double>::quiet_NaN(), 2, 64), 2);
    EXPECT_EQ(tileSizeFor(std::numeric_limits<double>::infinity(), 2, 64), 2);  // non-finite -> min
    EXPECT_EQ(tileSizeFor(-std::numeric_limits<double>::infinity(), 2, 64), 2);
    EXPECT_EQ(tileSizeFor(std::numeric_limits<double>::denorm_min(), 2, 64), 2);
    // Every extent lands on the smallest power of two >= it, within the bounds.
    for (double e = 0.05; e < 600.0; e *= 1.01) {
        const int s = tileSizeFor(e, 2, 256);
        ASSERT_TRUE(s >= 2 && s <= 256 && (s & (s - 1)) == 0) << e << " -> " << s;
        if (e <= 2.0) {
            ASSERT_EQ(s, 2) << e;
        } else if (e >= 256.0) {
            ASSERT_EQ(s, 256) << e;
        } else {
            ASSERT_TRUE(s >= e && s / 2 < e) << e << " -> " << s;
        }
    }
}

TEST(PackerTest, TileSizeForRejectsBadBounds) {
    EXPECT_THROW(tileSizeFor(5.0, 3, 256), std::invalid_argument);
    EXPECT_THROW(tileSizeFor(5.0, 0, 256), std::invalid_argument);
    EXPECT_THROW(tileSizeFor(5.0, 1, 100), std::invalid_argument);
    EXPECT_THROW(tileSizeFor(5.0, 64, 32), std::invalid_argument);
    EXPECT_THROW(tileSizeFor(5.0, -2, 32), std::invalid_argument);
}

TEST(PackerTest, EmptyInput) {
    const PackResult r = packTiles({}, 1280, 720);
    EXPECT_TRUE(r.placements.empty());
    EXPECT_EQ(r.passes, 0);
    EXPECT_TRUE(r.utilisation.empty());
    EXPECT_EQ(r.meanUtilisation(), 0.0);
}

TEST(PackerTest, ScanOrderIsMortonFromTheBottomLeft) {
    const PackResult r = packTiles({{7, 256}, {3, 256}, {9, 256}, {1, 256}}, 512, 512);
    const std::vector<TilePlacement> expected = {
        {1, 0, 0, 0, 256}, {3, 0, 256, 0, 256}, {7, 0, 0, 256, 256}, {9, 0, 256, 256, 256}};
    EXPECT_EQ(r.placements, expected);
    EXPECT_EQ(r.passes, 1);
    ASSERT_EQ(r.utilisation.size(), 1u);
    EXPECT_DOUBLE_EQ(r.utilisation[0], 1.0);

    // Z-order inside a power-of-two square.
    std::vector<TileRequest> ones;
    for (int i = 0; i < 9; ++i) ones.push_back({i, 1});
    const PackResult z = packTiles(ones, 4, 4);
    const int zx[] = {0, 1, 0, 1, 2, 3, 2, 3, 0}, zy[] = {0, 0, 1, 1, 0, 0, 1, 1, 2};
    for (int i = 0; i < 9; ++i) {
        EXPECT_EQ(z.placements[i].x, zx[i]) << i;
        EXPECT_EQ(z.placements[i].y, zy[i]) << i;
    }

    // A 6x4 atlas: the 4x4 square at the origin comes before the 2x2 squares to its right.
    const PackResult s = packTiles({{0, 2}, {1, 2}, {2, 2}, {3, 2}, {4, 2}, {5, 2}}, 6, 4);
    const std::vector<TilePlacement> blocks = {{0, 0, 0, 0, 2}, {1, 0, 2, 0, 2}, {2, 0, 0, 2, 2},
                                               {3, 0, 2, 2, 2}, {4, 0, 4, 0, 2}, {5, 0, 4, 2, 2}};
    EXPECT_EQ(s.placements, blocks);
}

TEST(PackerTest, SmallerTilesBackfillEarlierPasses) {
    // 1280x720 holds two 512 tiles; the third spills, then a 256 still fits into pass 0 beside them.
    const PackResult r = packTiles({{0, 512}, {1, 512}, {2, 512}, {3, 256}, {4, 256}, {5, 256}}, 1280, 720);
    const std::vector<TilePlacement> expected = {{0, 0, 0, 0, 512},    {1, 0, 512, 0, 512},    {2, 1, 0, 0, 512},
                                                 {3, 0, 1024, 0, 256}, {4, 0, 1024, 256, 256}, {5, 1, 512, 0, 256}};
    EXPECT_EQ(r.placements, expected);
    EXPECT_EQ(r.passes, 2);
    EXPECT_TRUE(checkPacking({{0, 512}, {1, 512}, {2, 512}, {3, 256}, {4, 256}, {5, 256}}, 1280, 720, r));
    EXPECT_TRUE(checkFirstFitBruteForce(1280, 720, r));
}

TEST(PackerTest, SpillsToFurtherPassesWhenFull) {
    std::vector<TileRequest> five;
    for (int i = 0; i < 5; ++i) five.push_back({i, 512});
    const PackResult r = packTiles(five, 1024, 1024);
    EXPECT_EQ(r.passes, 2);
    ASSERT_EQ(r.utilisation.size(), 2u);
    EXPECT_DOUBLE_EQ(r.utilisation[0], 1.0);
    EXPECT_DOUBLE_EQ(r.utilisation[1], 0.25);
    EXPECT_DOUBLE_EQ(r.meanUtilisation(), 0.625);
    EXPECT_EQ(r.placements[4].pass, 1);
    EXPECT_TRUE(checkPacking(five, 1024, 1024, r));

    // A non-power-of-two atlas: 13x7 has 6*3 aligned 2-slots, and 91 pixels.
    std::vector<TileRequest> twos, ones;
    for (int i = 0; i < 19; ++i) twos.push_back({i, 2});
    for (int i = 0; i < 92; ++i) ones.push_back({i, 1});
    EXPECT_EQ(packTiles(std::vector<TileRequest>(twos.begin(), twos.end() - 1), 13, 7).passes, 1);
    EXPECT_EQ(packTiles(twos, 13, 7).passes, 2);
    EXPECT_EQ(packTiles(std::vector<TileRequest>(ones.begin(), ones.end() - 1), 13, 7).passes, 1);
    EXPECT_EQ(packTiles(ones, 13, 7).passes, 2);
    EXPECT_EQ(packTiles(ones, 1, 1).passes, 92);

    // Same-size tiles fill passes completely up to the last.
    std::vector<TileRequest> many;
    for (int i = 0; i < 1000; ++i) many.push_back({i, 64});
    const PackResult m = packTiles(many, 1280, 720);  // 20 * 11 = 220 slots of 64
    EXPECT_EQ(m.passes, 5);
    EXPECT_TRUE(checkPacking(many, 1280, 720, m));
}

TEST(PackerTest, RejectsBadInput) {
    EXPECT_THROW(packTiles({{1, 0}}, 64, 64), std::invalid_argument);
    EXPECT_THROW(packTiles({{1, 3}}, 64, 64), std::invalid_argument);
    EXPECT_THROW(packTiles({{1, -4}}, 64, 64), std::invalid_argument);
    EXPECT_THROW(packTiles({{1, 48}}, 64, 64), std::invalid_argument);
    EXPECT_THROW(packTiles({{1, 4}}, 0, 64), std::invalid_argument);
    EXPECT_THROW(packTiles({{1, 4}}, 64, -1), std::invalid_argument);
    EXPECT_THROW(packTiles({}, 0, 0), std::invalid_argument);
    EXPECT_THROW(packTiles({{1, 4}, {2, 8}, {1, 16}}, 64, 64), std::invalid_argument);  // duplicate id
    EXPECT_THROW(packTiles({{5, 4}, {5, 4}}, 64, 64), std::invalid_argument);

    // Too large in one dimension only; the message names the id, size and atlas.
    const std::string tall = thrownMessage([] { packTiles({{2, 8}, {42, 1024}}, 1280, 720); });
    EXPECT_NE(tall.find("42"), std::string::npos) << tall;
    EXPECT_NE(tall.find("1024"), std::string::npos) << tall;
    EXPECT_NE(tall.find("1280x720"), std::string::npos) << tall;
    const std::string wide = thrownMessage([] { packTiles({{17, 64}}, 40, 100); });
    EXPECT_NE(wide.find("17"), std::string::npos) << wide;
    EXPECT_NE(wide.find("64"), std::string::npos) << wide;
    EXPECT_NE(wide.find("40x100"), std::string::npos) << wide;
    EXPECT_NE(thrownMessage([] { packTiles({{9, 4}, {9, 8}}, 64, 64); }).find("9"), std::string::npos);

    // Exactly as large as the atlas is fine.
    EXPECT_EQ(packTiles({{0, 512}, {1, 512}}, 512, 512).passes, 2);
    EXPECT_EQ(packTiles({{0, 1}}, 1, 1).passes, 1);
}

TEST(PackerTest, CheckerCatchesBrokenResults) {
    // A hand-made result with two overlapping tiles.
    const std::vector<TileRequest> pair = {{0, 4}, {1, 4}};
    PackResult bad;
    bad.placements = {{0, 0, 0, 0, 4}, {1, 0, 0, 0, 4}};
    bad.passes = 1;
    bad.utilisation = {32.0 / 64.0};
    EXPECT_FALSE(checkPacking(pair, 8, 8, bad));
    bad.placements[1] = {1, 0, 4, 0, 4};  // now disjoint: accepted
    EXPECT_TRUE(checkPacking(pair, 8, 8, bad));
    EXPECT_TRUE(checkFirstFitBruteForce(8, 8, bad));
    bad.placements[1] = {1, 0, 4, 4, 4};  // disjoint but not the first free slot
    EXPECT_TRUE(checkPacking(pair, 8, 8, bad));
    EXPECT_FALSE(checkFirstFitBruteForce(8, 8, bad));
    bad.placements[1] = {1, 0, 2, 2, 4};  // unaligned, overlapping partially
    EXPECT_FALSE(checkPacking(pair, 8, 8, bad));

    // Mutations of a real result, one at a time.
    std::mt19937 rng(7);
    const std::vector<TileRequest> tiles = randomTiles(rng, 300, 64);
    const PackResult good = packTiles(tiles, 100, 80);
    ASSERT_TRUE(checkPacking(tiles, 100, 80, good));
    ASSERT_TRUE(checkFirstFitBruteForce(100, 80, good));
    ASSERT_GE(good.passes, 2);
    auto mutated = [&](auto change) {
        PackResult r = good;
        change(r);
        return r;
    };
    const auto firstOf = [&](int pass, int skip) {
        for (size_t i = 0; i < good.placements.size(); ++i)
            if (good.placements[i].pass == pass && skip-- == 0) return i;
        return good.placements.size();
    };
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { r.placements.back().x = 100; })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { r.placements.back().y = -1; })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { r.placements.pop_back(); })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { r.placements[3].size *= 2; })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { r.placements[3].id = r.placements[4].id; })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80,
                              mutated([](PackResult& r) { std::swap(r.placements.front(), r.placements.back()); })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { ++r.passes; })));
    EXPECT_FALSE(checkPacking(tiles, 100, 80, mutated([](PackResult& r) { r.utilisation[0] *= 0.99; })));
    // The last (smallest) tile moved to a new pass of its own, everything else kept consistent:
    // only the first-pass-with-room check can object.
    const AssertionResult late = checkPacking(tiles, 100, 80, mutated([](PackResult& r) {
                                                  TilePlacement& t = r.placements.back();
                                                  const double a = double(t.size) * t.size / 8000.0;
                                                  r.utilisation[t.pass] -= a;
                                                  r.utilisation.push_back(a);
                                                  t.pass = r.passes++;
                                                  t.x = t.y = 0;
                                              }));
    EXPECT_FALSE(late);
    EXPECT_NE(std::string(late.message()).find("would still have fitted"), std::string::npos) << late.message();
    // Overlap: the second tile of pass 0 moved onto the first.
    const AssertionResult overlap = checkPacking(tiles, 100, 80, mutated([&](PackResult& r) {
                                                     TilePlacement& t = r.placements[firstOf(0, 1)];
                                                     t.x = r.placements[firstOf(0, 0)].x,
                                                     t.y = r.placements[firstOf(0, 0)].y;
                                                 }));
    EXPECT_FALSE(overlap);
    EXPECT_NE(std::string(overlap.message()).find("overlaps"), std::string::npos) << overlap.message();
}

// The main property test: many random inputs over several atlas shapes.
TEST(PackerTest, RandomInputsSatisfyAllProperties) {
    const std::vector<std::pair<int, int>> atlases = {{1280, 720},  {512, 512},   {1000, 333}, {64, 64},
                                                      {1024, 1024}, {1920, 1080}, {333, 1000}, {7, 5}};
    std::mt19937 rng(20240601);
    for (int c = 0; c < 200; ++c) {
        const auto [w, h] = atlases[c % atlases.size()];
        const int maxSize = std::min({512, w, h});
        const int count = std::uniform_int_distribution<int>(0, 5000)(rng);
        std::vector<TileRequest> tiles = randomTiles(rng, count, maxSize);
        SCOPED_TRACE("case " + std::to_string(c) + ": " + std::to_string(count) + " tiles into " + std::to_string(w) +
                     "x" + std::to_string(h));
        const PackResult r = packTiles(tiles, w, h);
        ASSERT_TRUE(checkPacking(tiles, w, h, r));
        // Passes are needed for the total area at least.
        const std::int64_t atlasArea = std::int64_t(w) * h;
        EXPECT_GE(std::int64_t(r.passes), (totalArea(tiles) + atlasArea - 1) / atlasArea);
        // Deterministic: the same tiles in another order give the identical result.
        std::shuffle(tiles.begin(), tiles.end(), rng);
        const PackResult again = packTiles(tiles, w, h);
        ASSERT_EQ(again.placements, r.placements);
        ASSERT_EQ(again.passes, r.passes);
        ASSERT_EQ(again.utilisation, r.utilisation);
    }
}

// Small atlases of every shape, against the brute-force definition of first fit.
TEST(PackerTest, MatchesBruteForceFirstFitOnSmallAtlases) {
    std::mt19937 rng(99);
    std::uniform_int_distribution<int> side(1, 48);
    for (int c = 0; c < 150; ++c) {
        const int w = side(rng), h = side(rng);
        const int count = std::uniform_int_distribution<int>(1, 250)(rng);
        const std::vector<TileRequest> tiles = randomTiles(rng, count, std::min(w, h));
        SCOPED_TRACE("case " + std::to_string(c) + ": " + std::to_string(count) + " tiles into " + std::to_string(w) +
                     "x" + std::to_string(h));
        const PackResult r = packTiles(tiles, w, h);
        ASSERT_TRUE(checkPacking(tiles, w, h, r));
        ASSERT_TRUE(checkFirstFitBruteForce(w, h, r));
    }
}

TEST(PackerTest, TiesAreBrokenByIdRegardlessOfInputOrder) {
    std::vector<TileRequest> tiles;
    for (int i = 0; i < 200; ++i) tiles.push_back({(i * 37) % 211 - 100, 1 << (i % 4)});
    const PackResult reference = packTiles(tiles, 20, 12);
    std::mt19937 rng(3);
    for (int k = 0; k < 20; ++k) {
        std::shuffle(tiles.begin(), tiles.end(), rng);
        ASSERT_EQ(packTiles(tiles, 20, 12).placements, reference.placements);
    }
    EXPECT_TRUE(checkPacking(tiles, 20, 12, reference));
    EXPECT_TRUE(checkFirstFitBruteForce(20, 12, reference));

    // Ids over the whole int range order as signed integers.
    const int lo = std::numeric_limits<int>::min(), hi = std::numeric_limits<int>::max();
    const PackResult extremes = packTiles({{hi, 2}, {0, 2}, {lo, 2}, {-1, 2}, {1, 4}}, 8, 8);
    std::vector<int> ids;
    for (const TilePlacement& p : extremes.placements) ids.push_back(p.id);
    EXPECT_EQ(ids, (std::vector<int>{1, lo, -1, 0, hi}));
    EXPECT_THROW(packTiles({{lo, 2}, {hi, 2}, {lo, 1}}, 8, 8), std::invalid_argument);
}

}  // namespace

// The reuse allocator (EllipsoidSettings::reuse): random allocations and frees over many
// "frames" never overlap and stay inside the atlas; freeing everything merges every block
// back into its root, so that the largest tile fits again in layer 0.
TEST(TileAllocatorTest, RandomAllocateAndFreeNeverOverlapsAndMergesBack) {
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1280, 720}, {512, 512}, {1000, 333}, {64, 48}}) {
        SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
        const int layers = 3, minSize = 8, maxSize = std::min(256, floorPow2Test(std::min(w, h)));
        TileAllocator a(w, h, minSize, layers);
        const std::int64_t whole = a.freeArea();
        std::mt19937 rng(7);
        std::vector<TilePlacement> live;
        for (int step = 0; step < 4000; ++step) {
            if (!live.empty() && (rng() % 3 == 0 || a.freeArea() < whole / 8)) {
                const std::size_t k = rng() % live.size();
                a.free(live[k]);
                live[k] = live.back();
                live.pop_back();
            } else {
                const int size = minSize << (rng() % (std::bit_width(unsigned(maxSize / minSize))));
                const TilePlacement p = a.allocate(size);
                if (p.pass < 0) continue;
                ASSERT_EQ(p.size, size);
                ASSERT_TRUE(p.x % size == 0 && p.y % size == 0) << describe(p);
                ASSERT_TRUE(p.x + size <= w && p.y + size <= h && p.pass < layers) << describe(p);
                for (const TilePlacement& q : live)
                    ASSERT_FALSE(q.pass == p.pass && p.x < q.x + q.size && q.x < p.x + p.size && p.y < q.y + q.size &&
                                 q.y < p.y + p.size)
                        << describe(p) << " overlaps " << describe(q);
                live.push_back(p);
            }
            std::int64_t used = 0;
            for (const TilePlacement& q : live) used += std::int64_t(q.size) * q.size;
            ASSERT_EQ(a.freeArea() + used, whole);
        }
        for (const TilePlacement& q : live) a.free(q);
        EXPECT_EQ(a.freeArea(), whole);
        EXPECT_EQ(a.layersUsed(), 0);
        const TilePlacement big = a.allocate(maxSize);
        EXPECT_EQ(big.pass, 0);
        EXPECT_EQ(a.layersUsed(), 1);
    }
}

// Allocation fills the lowest layer first and reports when no layer has room.
TEST(TileAllocatorTest, FillsTheLowestLayerFirstAndSaysWhenFull) {
    TileAllocator a(64, 64, 8, 2);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(a.allocate(32).pass, 0);
    EXPECT_EQ(a.allocate(8).pass, 1);
    EXPECT_EQ(a.allocate(64).pass, -1);  // layer 1 has an 8 px tile in it
    EXPECT_EQ(a.layersUsed(), 2);
    EXPECT_THROW(a.allocate(4), std::invalid_argument);
    EXPECT_THROW(a.allocate(12), std::invalid_argument);
}
