// Tile-atlas packer for the per-ellipsoid impostor tiles (Elinas & Stuerzlinger 2000): every cloud
// ellipsoid is rendered into its own square power-of-two tile of a back-buffer atlas; tiles are
// placed largest first, first fit, and those that no longer fit spill to further passes (the same
// atlas is reused pass after pass).
//
// Coordinates follow the GL window convention: origin at the bottom-left corner of the atlas, x to
// the right, y up. A placement's (x, y) is the tile's bottom-left corner; it covers the pixels
// [x, x + size) x [y, y + size), which is what glViewport(x, y, size, size) selects.
#pragma once

#include <cstdint>
#include <set>
#include <vector>

namespace nephele {

struct TileRequest {
    int id;    // caller's handle; must be unique within one packTiles call
    int size;  // edge length in pixels, a power of two >= 1
};

struct TilePlacement {
    int id;
    int pass;  // 0-based atlas pass the tile is rendered in
    int x, y;  // bottom-left corner, bottom-left origin (GL convention); multiples of size
    int size;
    bool operator==(const TilePlacement&) const = default;
};

struct PackResult {
    std::vector<TilePlacement> placements;  // one per request, in placement order (largest first)
    int passes = 0;                         // number of passes used (0 if no tiles)
    std::vector<double> utilisation;        // per pass: area of its tiles / area of the atlas, in [0,1]
    double meanUtilisation() const;         // mean over passes, 0 if none
};

// Rounds a screen extent in pixels up to a power of two, clamped to [minSize, maxSize] (both
// powers of two, minSize <= maxSize, else std::invalid_argument). A non-finite (NaN or +-inf) or
// <= 0 extent gives minSize.
int tileSizeFor(double pixelExtent, int minSize, int maxSize);

// Packs square power-of-two tiles into an atlasWidth x atlasHeight atlas (any positive sizes).
//
// Order: size descending, ties by id ascending, so the result does not depend on the input order.
// Each tile goes into the first pass (0, 1, ...) that has a free position for it, at the first
// free position in scan order. Positions are aligned to multiples of the tile size; the scan order
// is the Morton (Z-order) code of the bottom-left corner, x in the even bits and y in the odd bits:
// recursively the quadrants bottom-left, bottom-right, top-left, top-right. (For a 4x4 atlas of
// 1-pixel tiles: (0,0) (1,0) (0,1) (1,1) (2,0) (3,0) (2,1) (3,1) (0,2) ...)
//
// Throws std::invalid_argument for a non-positive atlas size, a size that is not a power of two,
// a tile larger than the atlas in either dimension, or a duplicate id.
//
// Cost: O(n + passes * roots * levels), roots being the maximal aligned squares of the atlas no
// smaller than the smallest tile (a few dozen for common window sizes): a radix sort, then a bump
// pointer per root per pass, see packer.cpp.
PackResult packTiles(std::vector<TileRequest> tiles, int atlasWidth, int atlasHeight);

}  // namespace nephele

namespace nephele {

// Tiles that live across frames (EllipsoidSettings::reuse): a buddy allocator over the atlas's
// layers, each layer decomposed into the same root blocks as packTiles. A tile is allocated
// where it can stay, freed when its ellipsoid leaves the view or changes size, and freed
// blocks merge with their buddies again, so that a long flight does not fragment the atlas
// into small blocks. Allocation takes the free block in the lowest layer (then the smallest
// block, then Morton order): the layers in use stay few.
class TileAllocator {
public:
    // `layers` layers of atlasWidth x atlasHeight; blocks down to minSize (a power of two).
    TileAllocator(int atlasWidth, int atlasHeight, int minSize, int layers);
    // A place for a tile of `size` (a power of two >= minSize), or pass = -1 when no layer has
    // room. The placement's id is -1 (the caller's to set).
    TilePlacement allocate(int size);
    // Gives a tile's place back (a placement allocate() returned and not freed since).
    void free(const TilePlacement& tile);
    void clear();                   // everything free
    int layersUsed() const;         // the highest layer with a tile in it, + 1
    std::int64_t freeArea() const;  // px, over all layers

private:
    struct Block {
        int layer, x, y;
        bool operator<(const Block& o) const;
    };
    int minLevel_, layers_;
    std::vector<std::pair<int, int>> rootsXYLevel_;  // x, y of each root (its level in rootLevel_)
    std::vector<int> rootLevel_;
    int topLevel_ = -1;           // the largest root's level
    std::int64_t layerArea_ = 0;  // px, one layer's
    // The free blocks of layers [0, opened_), by level; a layer is opened (its roots put in)
    // only when the layers before it have no room: an atlas of W x 1 px with 1 px tiles has W
    // roots a layer, and 2048 layers of them up front took 2.2 GB at 16384 px (issue 38).
    std::vector<std::set<Block>> free_;
    int opened_ = 0;
    std::vector<int> inUse_;  // tiles per layer
    int rootLevelAt(int x, int y) const;
    void openLayer();
};

}  // namespace nephele
