// The `cloudscene` version 1 scene, as loaded and validated.
// The contract is data/scene-format.md (a copy of shared/scene-format.md); the keys of
// `generate` entries, which that format leaves to the project, are documented there too
// in the section "generate keys (Nephele)".
//
// World frame: right-handed, z up, x east, y north. Lengths in metres, angles in
// degrees, colours linear RGB. Every field below carries the format's default.
#pragma once

#include "nephele/api.hpp"
#include <glm/glm.hpp>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

using Vec3 = glm::dvec3;
using Vec2 = glm::dvec2;

// A scene that failed to load. what() is "FILE: JSON.PATH: fault", e.g.
// "scene.json: clouds[2].ellipsoids[5].radii[1]: must be > 0, got -3".
class SceneError : public std::runtime_error {
public:
    SceneError(std::string file, std::string jsonPath, std::string fault);
    const std::string& file() const { return file_; }
    const std::string& jsonPath() const { return path_; }  // "" for the whole document
    const std::string& fault() const { return fault_; }

private:
    std::string file_, path_, fault_;
};

struct Camera {
    Vec3 position{0.0};
    Vec3 direction{0, 1, 0};  // unit view direction (from look_at or direction)
    Vec3 up{0, 0, 1};         // up hint as given (not orthogonalised); not parallel to direction
    double fovYDeg = 60.0;    // vertical field of view, degrees, 1 < fov < 179
    double nearClip = 0.5;    // m, 0 < near < far
    double farClip = 100000.0;
    int width = 640;  // pixels, 1..16384
    int height = 480;
};

struct Sun {
    Vec3 direction = glm::normalize(Vec3(0.3, 0.2, 0.93));  // unit, towards the sun
    Vec3 color{1.0};
    double intensity = 3.0;  // a white Lambertian plane facing the sun reflects color*intensity/pi
    bool operator==(const Sun&) const = default;
};

struct Sky {
    Vec3 zenith{0.10, 0.22, 0.55};
    Vec3 horizon{0.40, 0.50, 0.65};
    Vec3 ground{0.12, 0.12, 0.10};
    bool operator==(const Sky&) const = default;
};

// Cloud matter given physically (data/scene-format.md, "medium"): the extinction coefficient at
// density 1 of droplets of effective radius r_eff (um) holding liquid water content LWC (g/m^3)
// on average over one ellipsoid of density 1:
//   extinction = (35/8) * 3 LWC / (2 rho_w r_eff), rho_w = 1e6 g/m^3 (Stephens 1978),
// 35/8 being 1 / the mean of the profile (1 - q)^2 over the ellipsoid, so that the mean
// extinction of the ellipsoid is the physical 3 LWC / (2 rho_w r_eff). LWC 0.5 and r_eff 10
// give a mean of 0.075 /m and an extinction at density 1 of 0.328125 /m.
inline constexpr double kWaterDensity = 1e6;        // g/m^3
inline constexpr double kProfileMean = 8.0 / 35.0;  // mean of (1 - q)^2 over the unit ball
inline constexpr double kLiquidWaterMin = 0.0;      // g/m^3, exclusive
inline constexpr double kLiquidWaterMax = 5.0;      // g/m^3: cumulonimbus cores
inline constexpr double kDropletRadiusMin = 1.0;    // um
inline constexpr double kDropletRadiusMax = 100.0;  // um: drizzle; rain drops are not cloud matter
inline constexpr double meanExtinctionFromWater(double lwcGramsPerCubicMetre, double reffMicrometres) {
    return 3.0 * lwcGramsPerCubicMetre / (2.0 * kWaterDensity * reffMicrometres * 1e-6);
}
inline constexpr double extinctionFromWater(double lwcGramsPerCubicMetre, double reffMicrometres) {
    return meanExtinctionFromWater(lwcGramsPerCubicMetre, reffMicrometres) / kProfileMean;
}
// The liquid water content (g/m^3) at a point of extinction `extinction` (1/m) in droplets of
// effective radius reff: the same relation, point by point (LWC = 2 rho_w r_eff sigma / 3).
inline constexpr double liquidWaterFromExtinction(double extinction, double reffMicrometres) {
    return 2.0 * kWaterDensity * reffMicrometres * 1e-6 * extinction / 3.0;
}

// The matter of a cumulus generator with "medium": "cumulus": liquid water content
// kCumulusLiquidWater (g/m^3, on average over the volume the cloud fills) in droplets of
// effective radius kCumulusDropletRadius (um): a mean extinction of 0.075 /m.
inline constexpr double kCumulusLiquidWater = 0.5;
inline constexpr double kCumulusDropletRadius = 10.0;
inline constexpr double kCumulusExtinction =
    extinctionFromWater(kCumulusLiquidWater, kCumulusDropletRadius);  // 1/m at density 1

struct Medium {
    double extinction = 0.04;  // 1/m at density 1 (the peak of an ellipsoid of density 1), >= 0;
                               // the loader sets it from liquid_water_content and
                               // droplet_effective_radius when the scene gives those instead
    double albedo = 0.99;      // [0, 1]
    double hgG = 0.85;         // Henyey-Greenstein asymmetry, (-1, 1)
    double noise = 0.3;        // relative amplitude of procedural detail, >= 0; 0 = exact field
    double noiseScale = 60.0;  // m, > 0
    // medium.detail: the eroding detail field (shaders/detail.glsl, docs/detail.md). erosion 0
    // (the default) leaves every method's field and images exactly as without it.
    struct Detail {
        enum class Kind { Nephele, Reference };
        Kind kind = Kind::Nephele;  // the project's own (a tileable Worley texture) or the exactly defined one
        double erosion = 0.0;       // E in [0, 4]: how deep the detail bites (the rim moves in to 1 / (1 + E D))
        double scale = 256.0;       // m: the largest octave's wavelength, in [smallest, 1e5]
        double smallest = 1.0;      // m: the smallest wavelength drawn, in [0.05, scale]
        Vec3 wind{0.0};             // m/s: the air's motion that carries the detail, |wind| <= 200
        Vec3 drift{0.0};            // m: how far the wind has carried it. Set in code (time * wind by
                                    // the CLI's renders, integrated by a host), never read from a file
        bool on() const { return erosion > 0; }
    } detail;
};

struct Ellipsoid {
    Vec3 center{0.0};
    Vec3 radii{1.0};        // semi-axes along local x, y, z, each > 0
    Vec3 rotationDeg{0.0};  // R = Rz(rz) * Ry(ry) * Rx(rx)
    double density = 1.0;   // >= 0
    double maxRadius() const { return std::max({radii.x, radii.y, radii.z}); }  // its bounding sphere's
};

struct Cloud {
    std::string name;
    std::vector<Ellipsoid> ellipsoids;
    // Set in code, never read from a scene file (the near LOD sets them, nephele/near_lod.hpp):
    double weight = 1.0;        // [0, 1]: multiplies the optical depth the eye sees through the cloud,
                                // not the matter that shadows it (its radiance grid is the whole
                                // cloud's), so a cloud fades without changing colour. Honoured by the
                                // compositor, gardner-exact and exactDensityOpacity (one code path,
                                // ellipsoid/src/gardner.cpp); the ray-marcher and the path tracer
                                // ignore it.
    std::uint64_t noiseId = 0;  // 0: the noise offsets of its ellipsoids come from the cloud's index in
                                // scene.clouds; else from this id, so that the cloud keeps its detail
                                // when clouds before it come and go
    // The horizontal rectangle (m, world) of a layer that the cloud is one piece of (none unless
    // tileMax > tileMin on both axes). Its radiance grid then spans the rectangle across (and the
    // cloud's height) and its light is traced with the rectangle's opposite sides joined, as one
    // tile of an endless layer of its kind: its neighbours shadow it and send it light as the
    // layer's own would (nephele/cloud_radiance.hpp). Its ellipsoids may reach past it.
    Vec2 tileMin{0.0}, tileMax{0.0};
    bool tiled() const { return tileMax.x > tileMin.x && tileMax.y > tileMin.y; }
};

// A procedural cloud, validated on load; expanded into a Cloud by later stages.
struct Generator {
    enum class Type { Cumulus, Mesh, LSystem };
    Type type = Type::Cumulus;
    std::string name;  // default "<type><index>", e.g. "cumulus0"
    unsigned seed = 1;
    double density = 1.0;  // density of every ellipsoid it makes, >= 0

    // cumulus (Jimenez de Parga & Gomez Palomo 2018, section 3.6.1)
    Vec3 center{0.0};                 // required for cumulus and lsystem
    int count = 35;                   // ellipsoids placed, 1..limits::kEllipsoidsPerEntry
    Vec3 sigma{300.0, 300.0, 120.0};  // m, Gaussian placement std-dev per axis, > 0
    Vec3 clampLo{-2.0, -2.0, -0.5};   // placement clamped to [lo, hi] * sigma per axis
    Vec3 clampHi{2.0, 2.0, 2.0};
    double maxRadius = 250.0;    // m, radius at the centre (eq. 16's epsilon), > 0
    Vec3 aspect{1.0, 1.0, 0.7};  // radii multipliers per local axis, > 0
    bool hollow = true;          // drop ellipsoids in the core (eq. 17 region)
    bool pruneContained = true;  // drop ellipsoids inside another one
    // "medium": "cumulus" (opt-in): real cumulus matter whatever the scene's medium. The loader
    // sets `density` to kCumulusExtinction / medium.extinction (one ellipsoid alone would have
    // the mean extinction meanExtinctionFromWater(kCumulusLiquidWater, kCumulusDropletRadius));
    // the expansion then scales its ellipsoids' densities by kProfileMean / the mean of their
    // summed density over the volume they fill, so that the cloud as a whole has that mean.
    bool cumulusMedium = false;

    // mesh (one ellipsoid per triangle of a Wavefront OBJ)
    std::string path;             // as written in the scene
    std::string resolvedPath;     // relative to the scene file's folder
    Vec3 position{0.0};           // m, translation applied to the mesh
    double scale = 1.0;           // > 0
    Vec3 rotationDeg{0.0};        // R = Rz * Ry * Rx, applied before translation
    double thicknessRatio = 0.5;  // normal semi-axis / smaller in-plane semi-axis, > 0

    // lsystem
    std::string axiom;                                // non-empty
    std::vector<std::pair<char, std::string>> rules;  // one rule per symbol
    double angleDeg = 25.0;
    int iterations = 3;    // 0..8
    double step = 100.0;   // m, branch step, > 0
    double radius = 80.0;  // m, sphere radius at a symbol, > 0
    double jitter = 0.2;   // proportional random factor, [0, 1)
};

// What expanding one generator did (nephele/generate.hpp). kept = placed - prunedHollow -
// prunedContained - degenerate = the ellipsoids of its cloud.
struct GenerateStats {
    std::string name;            // the generator's (and its cloud's) name
    int placed = 0;              // cumulus: count; mesh: triangles read; lsystem: spheres placed (F)
    int prunedHollow = 0;        // cumulus: dropped in the hollow core
    int prunedContained = 0;     // cumulus: dropped as inside another ellipsoid
    int degenerate = 0;          // mesh: triangles without area (or thinner than limits::kSmallestRadius), skipped
    int kept = 0;                // ellipsoids in the cloud
    std::uint64_t objBytes = 0;  // mesh: bytes of the OBJ file read (limits::kObjBytesPerScene)
    std::int64_t symbols = 0;    // lsystem: length of the rewritten string (limits::kLSystemSymbols)
};

struct CityGlow {
    Vec3 color{1.0, 0.6, 0.3};
    double strength = 1.0;  // >= 0
    bool operator==(const CityGlow&) const = default;
};

struct Layer {
    double base = 0.0;        // m, cloud base altitude (required)
    double thickness = 0.0;   // m, > 0 (required)
    double coverage = 0.6;    // [0, 1]
    double density = 1.0;     // [0, 1]
    Vec2 wind{0.0};           // m/s
    double extent = 20000.0;  // m, > 0
    unsigned seed = 1;
    bool nearLod = true;
    std::optional<CityGlow> cityGlow;
    // Set in code, never read from a scene file: the pattern's displacement at t = 0 (m), so that
    // at time t it has moved by windOffset + t * wind (SkyRenderer::update keeps that continuous
    // when the wind changes).
    Vec2 windOffset{0.0};
    // Set in code, never read from a scene file: the thickness (m) its lighting volume is made
    // for, when not its own (0: its own). A weather transition ramps the thickness but lights the
    // layer for the thickness it ramps to, so that one volume is made per change, not one a frame.
    double lightingThickness = 0.0;
    bool operator==(const Layer&) const = default;
};

struct Skylight {
    Vec3 direction{0, 0, 1};  // unit (required in the file)
    Vec3 color{1.0};
    double intensity = 1.0;  // >= 0
};

struct Lightning {
    Vec3 position{0.0};      // required
    double intensity = 0.0;  // required, >= 0; lights matter at distance d with I/d^2
    double start = 0.0;      // s
    double duration = 0.2;   // s, > 0
};

struct Object {
    enum class Type { Box, Sphere };
    Type type = Type::Box;
    Vec3 center{0.0};     // required
    Vec3 size{1.0};       // box: full edge lengths, each > 0 (required for a box)
    double radius = 1.0;  // sphere: > 0 (required for a sphere)
    Vec3 rotationDeg{0.0};
    Vec3 color{0.5};  // linear albedo
};

// What lights the scene's opaque objects (the top-level key "object_light"): Sun, the format's
// default, is Lambert under the sun alone (the path tracer shadows it by the clouds); All makes
// them Lambertian receivers of all light: the sun through the clouds and the diffuse light of
// the sky, the ground and the clouds (data/scene-format.md, "object_light").
enum class ObjectLight { Sun, All };

struct Keyframe {
    double t = 0.0;  // s, strictly increasing along the path
    Vec3 position{0.0};
    Vec3 lookAt{0.0};
};

struct Scene {
    std::string file;  // where it was loaded from ("" if built in code)
    Camera camera;
    Sun sun;
    Sky sky;
    Medium medium;
    std::vector<Cloud> clouds;
    std::vector<Generator> generators;     // as loaded; expanded into `clouds` by loadScene
    std::vector<GenerateStats> generated;  // generated[i]: expansion of generators[i] (generate.hpp)
    std::vector<Layer> layers;
    std::optional<Skylight> skylight;
    std::vector<Lightning> lightning;
    std::vector<Object> objects;
    ObjectLight objectLight = ObjectLight::Sun;
    std::vector<Keyframe> path;
    // Set in code, never read from a scene file: the sun direction (unit) and the sky the
    // clouds' radiance grids are made for, when not the scene's own (computeCloudRadiance and
    // their cache key read it). A weather transition lights the clouds for the sun and sky it
    // goes to, so that a cloud's grid is made once per change, not once a frame (as
    // Layer::lightingThickness does for the layers); the sun's single scattering follows the
    // ramp frame by frame.
    struct Lighting {
        Vec3 sunDirection{0, 0, 1};
        Sky sky;
    };
    std::optional<Lighting> lighting;
};

// Loads and validates a scene file. Throws SceneError (never renders from a bad scene).
Scene loadScene(const std::string& file);
// The same from text already in memory; `file` names it in messages and anchors relative paths.
Scene parseScene(const std::string& text, const std::string& file);

// Rotation matrix R = Rz(rz) * Ry(ry) * Rx(rx) for angles in degrees about the world axes.
glm::dmat3 rotationFromDegrees(const Vec3& deg);

// The camera at time t: the scene camera, or the `path` interpolated linearly (clamped at
// the ends) when the scene has one.
Camera cameraAt(const Scene& scene, double t);

// The scene lit by the sun alone (a black sky and ground) or by the sky and ground alone (a
// dark sun): every renderer is linear in its light sources, so the two sum to the scene (the
// accuracy bench's and the light component tests' split by light).
Scene sunOnly(Scene scene);
Scene skyOnly(Scene scene);

}  // namespace nephele
NEPHELE_API_END
