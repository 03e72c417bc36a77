// `nephele export`: the scene's extinction field as an OpenVDB grid (export_command.hpp).
//
// The grid's voxel (i, j, k) holds the field at its centre, the world point origin + (i, j, k) v
// (OpenVDB's convention: a value sits at its voxel's index-space centre, and the linear
// transform maps index to world): origin is the field's box's low corner, and the voxels run
// until their centres pass the high corner, so that every point of the box lies within half a
// voxel of a centre. Sampled slab by slab (k), each slab in parallel; only values > 0 are
// stored (the background is 0), so memory follows the matter, not the box.
#include "export_command.hpp"

#include "output_files.hpp"
#include "render_command.hpp"  // reportError

#include "nephele/gardner.hpp"  // NoiseSettings
#include "nephele/layer_volume.hpp"
#include "nephele/limits.hpp"
#include "nephele/pathtrace.hpp"
#include "nephele/scene.hpp"
#include "parallel.hpp"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <vector>

namespace nephele::cli {

namespace {

std::string metres(double v) {
    char text[64];
    std::snprintf(text, sizeof text, "%.6g", v);
    return text;
}
std::string whole(double v) {  // a count of voxels, every digit
    char text[400];
    std::snprintf(text, sizeof text, "%.0f", v);
    return text;
}

}  // namespace

double defaultVoxelSize(double dx, double dy, double dz) {
    // A flat or thin box (a layer, one ellipsoid's slab) shares its volume among the voxels
    // as well; a zero extent counts as one voxel's.
    const double longest = std::max({dx, dy, dz});
    if (!(longest > 0)) return 1;
    double v = std::cbrt(std::max(dx, longest * 1e-6) * std::max(dy, longest * 1e-6) * std::max(dz, longest * 1e-6) /
                         double(1 << 24));
    const double unit = std::pow(10.0, std::floor(std::log10(v)) - 1);  // two significant digits
    return std::ceil(v / unit) * unit;
}

namespace {

// The field to export and its voxels: centres origin + (i, j, k) v, n of them per axis.
struct ExportGrid {
    NoiseVolume noise;  // the field reads it (by address): it lives as long as the field
    std::unique_ptr<ExtinctionField> field;
    Vec3 origin{0.0};
    glm::i64vec3 n{0};
    double v = 0;
};

// The scene's field at --time and its voxels (--voxel, else defaultVoxelSize), within the
// limit. Throws (a bad output path, scene or voxel size, no matter to export).
void prepareGrid(const ExportOptions& o, ExportGrid& g) {
    g.v = o.voxel;
    resolveOutput("--vdb", o.vdb);  // a folder or a device is refused before any work
    Scene scene = loadScene(o.scene);
    scene.medium.detail.drift = scene.medium.detail.wind * o.time;  // the detail, carried to --time
    if (scene.medium.noise > 0) {
        const NoiseSettings ns;  // the path tracer's (PathTraceSettings has no others)
        g.noise = makeNoiseVolume(ns);
    }
    std::shared_ptr<const LayerVolumes> layers;
    const Vec3 eye = cameraAt(scene, o.time).position;
    if (!scene.layers.empty()) {
        LayeredSettings ls;
        ls.cacheDir = o.cacheDir;
        layers = std::make_shared<LayerVolumes>(scene, ls, o.time);
    }
    g.field = std::make_unique<ExtinctionField>(scene, &g.noise, layers, eye);
    if (g.field->empty())
        throw std::invalid_argument(o.scene +
                                    ": the scene holds no cloud matter to export (no ellipsoid or layer "
                                    "with density > 0, or medium.extinction 0)");
    const Vec3 extent = g.field->hi() - g.field->lo();
    if (g.v == 0) g.v = defaultVoxelSize(extent.x, extent.y, extent.z);
    Vec3 cells;  // centres lo + i v for i in 0..cells-1, the last at or past hi
    for (int a = 0; a < 3; ++a) cells[a] = std::ceil(extent[a] / g.v) + 1;
    const double count = cells.x * cells.y * cells.z;
    if (!withinLimit(count, limits::kExportVoxels))
        throw std::invalid_argument("--voxel " + metres(g.v) + " m gives " + whole(cells.x) + " x " + whole(cells.y) +
                                    " x " + whole(cells.z) + " = " + whole(count) +
                                    " voxels over the field's extent (" + metres(extent.x) + " x " + metres(extent.y) +
                                    " x " + metres(extent.z) + " m), over the limit " +
                                    limitText(limits::kExportVoxels) + "; give a larger --voxel");
    g.n = glm::i64vec3(cells);
    g.origin = g.field->lo();
}

// Samples the field into a FloatGrid and writes it to --vdb (all or nothing); returns the
// active voxels. Throws.
std::int64_t writeGrid(const ExportOptions& o, const ExportGrid& g) {
    const Vec3& origin = g.origin;
    const glm::i64vec3& n = g.n;
    const double v = g.v;
    openvdb::initialize();
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    openvdb::math::Transform::Ptr xform = openvdb::math::Transform::createLinearTransform(v);
    xform->postTranslate(openvdb::Vec3d(origin.x, origin.y, origin.z));
    grid->setTransform(xform);
    grid->insertMeta("units", openvdb::StringMetadata("1/m"));
    grid->insertMeta("source", openvdb::StringMetadata("nephele export " + o.scene));
    std::vector<float> slab(std::size_t(n.x) * std::size_t(n.y));
    openvdb::FloatGrid::Accessor acc = grid->getAccessor();
    std::int64_t active = 0;
    for (std::int64_t k = 0; k < n.z; ++k) {
        parallelFor(int(n.y), [&](int j) {
            for (std::int64_t i = 0; i < n.x; ++i)
                slab[std::size_t(j) * std::size_t(n.x) + std::size_t(i)] =
                    float((*g.field)(origin + Vec3(double(i), double(j), double(k)) * v));
        });
        for (std::int64_t j = 0; j < n.y; ++j)
            for (std::int64_t i = 0; i < n.x; ++i)
                if (const float s = slab[std::size_t(j) * std::size_t(n.x) + std::size_t(i)]; s > 0) {
                    acc.setValue(openvdb::Coord(int(i), int(j), int(k)), s);
                    ++active;
                }
    }
    OutputFiles files;
    files.add(
        o.vdb,
        [&](const std::string& path) {
            openvdb::io::File file(path);
            file.write({grid});
            file.close();
        },
        "--vdb");
    files.checkPaths();
    files.commit();
    return active;
}

}  // namespace

int runExport(const ExportOptions& o) {
    ExportGrid g;
    try {
        prepareGrid(o, g);
    } catch (const std::exception& e) {
        return reportError(e, "export");
    }
    try {
        const std::int64_t active = writeGrid(o, g);
        std::cerr << "nephele: export: " << o.vdb << ": grid 'density' (1/m), voxel " << metres(g.v) << " m, " << g.n.x
                  << " x " << g.n.y << " x " << g.n.z << " voxels sampled, " << active << " active\n";
        return 0;
    } catch (const std::exception& e) {
        return reportError(e, "export");
    }
}

}  // namespace nephele::cli
