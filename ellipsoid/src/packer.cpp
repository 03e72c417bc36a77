// Tile-atlas packer: a buddy allocator per pass, in Morton order, which reduces to a bump pointer
// per root block.
//
// Each pass starts as the atlas decomposed into its maximal aligned power-of-two squares, the root
// blocks (for a power-of-two square atlas, the atlas itself; for 1280x720, two 512 squares along the
// bottom, then smaller squares up the top and right edges). Positions are scanned in Morton order
// (Z-order) of the bottom-left corner: x in the even bits, y in the odd bits, i.e. recursively the
// quadrants bottom-left, bottom-right, top-left, top-right. An aligned square of side s is then a
// contiguous range of s^2 Morton codes starting at its corner's code, and so is every root.
//
// A buddy allocator would keep per-size free lists ordered by Morton code and split the first free
// block that is large enough. Because tiles arrive largest first and sides are powers of two, that
// allocator only ever hands out each root's space from the front: the taken part of a root is a
// Morton prefix whose length is a multiple of the current s^2, so its next free aligned s-square
// starts right after the prefix, and a root has room for s iff it is large enough and not full.
// The free lists therefore collapse to one fill counter per root, and first fit is the first root
// (in Morton order) with room, at root corner + the 2-D position of Morton offset `fill`.
#include "packer.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace nephele {
namespace {

constexpr int kLevels = 32;  // block sides 2^0 .. 2^31 (the recursion's virtual root may be 2^31)

bool isPowerOfTwo(int v) { return v > 0 && (v & (v - 1)) == 0; }
int levelOf(int size) { return std::bit_width(unsigned(size)) - 1; }

struct Root {
    int x, y, level;
    std::int64_t area;  // 4^level
};

// Appends, in Morton order, the maximal aligned squares inside [0,w) x [0,h) within the aligned
// square of side 2^level at (x, y). Squares with level < lo (smaller than every tile) are dropped.
void decompose(std::int64_t x, std::int64_t y, int level, int lo, int w, int h, std::vector<Root>& roots) {
    if (x >= w || y >= h || level < lo) return;
    const std::int64_t s = std::int64_t(1) << level;
    if (x + s <= w && y + s <= h) {
        roots.push_back({int(x), int(y), level, s * s});
        return;
    }
    const std::int64_t half = s / 2;
    for (int q = 0; q < 4; ++q) decompose(x + (q & 1) * half, y + (q >> 1) * half, level - 1, lo, w, h, roots);
}

// The even bits of v, compacted: the x coordinate of Morton code v (the y coordinate is evenBits(v >> 1)).
int evenBits(std::uint64_t v) {
    v &= 0x5555555555555555u;
    v = (v | (v >> 1)) & 0x3333333333333333u;
    v = (v | (v >> 2)) & 0x0f0f0f0f0f0f0f0fu;
    v = (v | (v >> 4)) & 0x00ff00ff00ff00ffu;
    v = (v | (v >> 8)) & 0x0000ffff0000ffffu;
    v = (v | (v >> 16)) & 0x00000000ffffffffu;
    return int(v);
}

// One stable LSD radix pass on the byte of the keys at `shift`; skipped if all keys share that byte.
void radixPass(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch, int shift) {
    std::array<std::uint32_t, 256> slot{};
    for (std::uint64_t k : keys) ++slot[(k >> shift) & 255];
    if (slot[(keys[0] >> shift) & 255] == keys.size()) return;
    for (std::uint32_t d = 0, at = 0; d < 256; ++d) {
        const std::uint32_t count = slot[d];
        slot[d] = at;
        at += count;
    }
    scratch.resize(keys.size());
    for (std::uint64_t k : keys) scratch[slot[(k >> shift) & 255]++] = k;
    keys.swap(scratch);
}

}  // namespace

double PackResult::meanUtilisation() const {
    if (utilisation.empty()) return 0.0;
    double sum = 0.0;
    for (double u : utilisation) sum += u;
    return sum / double(utilisation.size());
}

int tileSizeFor(double pixelExtent, int minSize, int maxSize) {
    if (!isPowerOfTwo(minSize) || !isPowerOfTwo(maxSize) || minSize > maxSize)
        throw std::invalid_argument("tileSizeFor: minSize " + std::to_string(minSize) + " and maxSize " +
                                    std::to_string(maxSize) + " must be powers of two with minSize <= maxSize");
    if (!std::isfinite(pixelExtent) || pixelExtent <= 0.0) return minSize;
    if (pixelExtent >= double(maxSize)) return maxSize;
    int s = minSize;
    while (double(s) < pixelExtent) s *= 2;  // stops at maxSize at the latest
    return s;
}

PackResult packTiles(std::vector<TileRequest> tiles, int atlasWidth, int atlasHeight) {
    const auto atlas = [&] { return std::to_string(atlasWidth) + "x" + std::to_string(atlasHeight); };
    if (atlasWidth <= 0 || atlasHeight <= 0)
        throw std::invalid_argument("packTiles: atlas size " + atlas() + " must be positive");
    PackResult result;
    if (tiles.empty()) return result;

    // Sort keys: (31 - level) above the id with its sign bit flipped, so that ascending keys are
    // size descending, then id ascending. Radix sorted: ids first (exposing duplicates), then levels.
    std::vector<std::uint64_t> keys, scratch;
    keys.reserve(tiles.size());
    int lo = kLevels;  // smallest tile level
    for (const TileRequest& t : tiles) {
        const auto tile = [&] {
            return "packTiles: tile id " + std::to_string(t.id) + " of size " + std::to_string(t.size);
        };
        if (!isPowerOfTwo(t.size)) throw std::invalid_argument(tile() + " is not a power of two >= 1");
        if (t.size > atlasWidth || t.size > atlasHeight)
            throw std::invalid_argument(tile() + " does not fit the " + atlas() + " atlas");
        lo = std::min(lo, levelOf(t.size));
        keys.push_back(std::uint64_t(31 - levelOf(t.size)) << 32 | (std::uint32_t(t.id) ^ 0x80000000u));
    }
    for (int shift = 0; shift < 32; shift += 8) radixPass(keys, scratch, shift);
    for (size_t i = 1; i < keys.size(); ++i)
        if (std::uint32_t(keys[i]) == std::uint32_t(keys[i - 1]))
            throw std::invalid_argument("packTiles: duplicate tile id " +
                                        std::to_string(int(std::uint32_t(keys[i]) ^ 0x80000000u)));
    radixPass(keys, scratch, 32);

    std::vector<Root> roots;
    decompose(0, 0, std::bit_width(unsigned(std::max(atlasWidth, atlasHeight) - 1)), lo, atlasWidth, atlasHeight,
              roots);
    const int nRoots = int(roots.size());

    // Per pass: fill[pass * nRoots + r] is the area taken from root r (a Morton prefix of it);
    // cursor[pass * kLevels + l]: roots before it have no room for side 2^l (they never regain it).
    // firstPass[l]: passes before it have no room for side 2^l.
    std::vector<std::int64_t> fill, area;
    std::vector<int> cursor;
    std::array<int, kLevels> firstPass{};
    result.placements.reserve(keys.size());
    for (std::uint64_t key : keys) {
        const int level = 31 - int(key >> 32), size = 1 << level;
        const int id = int(std::uint32_t(key) ^ 0x80000000u);
        int& p = firstPass[level];
        int r = 0;
        for (;; ++p) {
            if (p == int(area.size())) {  // open a new pass
                area.push_back(0);
                fill.resize(fill.size() + nRoots, 0);
                cursor.resize(cursor.size() + kLevels, 0);
            }
            int& c = cursor[size_t(p) * kLevels + level];
            const std::int64_t* f = &fill[size_t(p) * nRoots];
            while (c < nRoots && (roots[c].level < level || f[c] == roots[c].area)) ++c;
            if (c < nRoots) {
                r = c;
                break;
            }
            if (area[p] == 0) throw std::logic_error("packTiles: an empty pass had no room");  // unreachable
        }
        std::int64_t& taken = fill[size_t(p) * nRoots + r];
        const std::uint64_t offset = std::uint64_t(taken);
        result.placements.push_back({id, p, roots[r].x + evenBits(offset), roots[r].y + evenBits(offset >> 1), size});
        taken += std::int64_t(size) * size;
        area[p] += std::int64_t(size) * size;
    }

    result.passes = int(area.size());
    const double atlasArea = double(atlasWidth) * double(atlasHeight);
    for (std::int64_t a : area) result.utilisation.push_back(double(a) / atlasArea);
    return result;
}

}  // namespace nephele

namespace nephele {

namespace {
std::uint64_t mortonOf(int x, int y) {
    auto spread = [](std::uint64_t v) {
        v &= 0xffffffffu;
        v = (v | (v << 16)) & 0x0000ffff0000ffffu;
        v = (v | (v << 8)) & 0x00ff00ff00ff00ffu;
        v = (v | (v << 4)) & 0x0f0f0f0f0f0f0f0fu;
        v = (v | (v << 2)) & 0x3333333333333333u;
        v = (v | (v << 1)) & 0x5555555555555555u;
        return v;
    };
    return spread(std::uint64_t(x)) | spread(std::uint64_t(y)) << 1;
}
}  // namespace

bool TileAllocator::Block::operator<(const Block& o) const {
    return layer != o.layer ? layer < o.layer : mortonOf(x, y) < mortonOf(o.x, o.y);
}

TileAllocator::TileAllocator(int atlasWidth, int atlasHeight, int minSize, int layers)
    : minLevel_(levelOf(minSize)), layers_(layers) {
    if (atlasWidth <= 0 || atlasHeight <= 0 || !isPowerOfTwo(minSize) || layers < 1)
        throw std::invalid_argument(
            "TileAllocator: a positive atlas size and layer count, and a power-of-two minimum size");
    std::vector<Root> roots;
    decompose(0, 0, std::bit_width(unsigned(std::max(atlasWidth, atlasHeight) - 1)), minLevel_, atlasWidth, atlasHeight,
              roots);
    for (const Root& r : roots) {
        rootsXYLevel_.push_back({r.x, r.y}), rootLevel_.push_back(r.level);
        topLevel_ = std::max(topLevel_, r.level);
        layerArea_ += std::int64_t(1) << (2 * r.level);
    }
    clear();
}

void TileAllocator::clear() {
    free_.assign(kLevels, {});
    inUse_.assign(std::size_t(layers_), 0);
    opened_ = 0;
}

void TileAllocator::openLayer() {
    for (std::size_t r = 0; r < rootLevel_.size(); ++r)
        free_[std::size_t(rootLevel_[r])].insert({opened_, rootsXYLevel_[r].first, rootsXYLevel_[r].second});
    ++opened_;
}

int TileAllocator::rootLevelAt(int x, int y) const {
    for (std::size_t r = 0; r < rootLevel_.size(); ++r) {
        const int s = 1 << rootLevel_[r];
        const auto [rx, ry] = rootsXYLevel_[r];
        if (x >= rx && x < rx + s && y >= ry && y < ry + s) return rootLevel_[r];
    }
    throw std::logic_error("TileAllocator: a block outside every root");
}

TilePlacement TileAllocator::allocate(int size) {
    if (!isPowerOfTwo(size) || levelOf(size) < minLevel_)
        throw std::invalid_argument("TileAllocator: tile size " + std::to_string(size) +
                                    " is not a power of two >= the minimum");
    const int level = levelOf(size);
    // The free block in the lowest layer; among those, the smallest (least splitting). A layer
    // not opened yet is wholly free and above every opened one: it is opened when no opened
    // layer has room.
    int best = -1;
    for (int l = level; l < kLevels; ++l)
        if (!free_[std::size_t(l)].empty() &&
            (best < 0 || free_[std::size_t(l)].begin()->layer < free_[std::size_t(best)].begin()->layer))
            best = l;
    if (best < 0 && opened_ < layers_ && topLevel_ >= level) {
        openLayer();
        for (int l = level; l < kLevels && best < 0; ++l)
            if (!free_[std::size_t(l)].empty()) best = l;
    }
    if (best < 0) return {-1, -1, 0, 0, size};
    Block b = *free_[std::size_t(best)].begin();
    free_[std::size_t(best)].erase(free_[std::size_t(best)].begin());
    for (int l = best; l > level; --l) {  // split: keep the bottom-left quadrant, free the others
        const int half = 1 << (l - 1);
        for (int q = 1; q < 4; ++q)
            free_[std::size_t(l - 1)].insert({b.layer, b.x + (q & 1) * half, b.y + (q >> 1) * half});
    }
    ++inUse_[std::size_t(b.layer)];
    return {-1, b.layer, b.x, b.y, size};
}

void TileAllocator::free(const TilePlacement& t) {
    if (t.pass < 0 || t.pass >= layers_ || !isPowerOfTwo(t.size))
        throw std::invalid_argument("TileAllocator: not an allocated tile");
    --inUse_[std::size_t(t.pass)];
    int level = levelOf(t.size);
    Block b{t.pass, t.x, t.y};
    const int top = rootLevelAt(t.x, t.y);
    for (; level < top; ++level) {  // merge with the three buddies while they are free
        const int s = 1 << level, px = b.x & ~(2 * s - 1), py = b.y & ~(2 * s - 1);
        std::set<Block>& f = free_[std::size_t(level)];
        std::array<std::set<Block>::iterator, 3> buddies;
        int found = 0;
        for (int q = 0; q < 4; ++q) {
            const Block o{b.layer, px + (q & 1) * s, py + (q >> 1) * s};
            if (o.x == b.x && o.y == b.y) continue;
            const auto it = f.find(o);
            if (it == f.end()) break;
            buddies[std::size_t(found++)] = it;
        }
        if (found < 3) break;
        for (auto it : buddies) f.erase(it);
        b = {b.layer, px, py};
    }
    free_[std::size_t(level)].insert(b);
}

int TileAllocator::layersUsed() const {
    for (int l = layers_; l > 0; --l)
        if (inUse_[std::size_t(l - 1)] > 0) return l;
    return 0;
}

std::int64_t TileAllocator::freeArea() const {
    std::int64_t a = std::int64_t(layers_ - opened_) * layerArea_;
    for (int l = 0; l < kLevels; ++l) a += std::int64_t(free_[std::size_t(l)].size()) << (2 * l);
    return a;
}

}  // namespace nephele
