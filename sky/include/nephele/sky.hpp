// `--method auto` as one library call: what an image generator links to draw all of a scene's
// clouds. The layered far field (layers with near_lod: true leave out a disc around the eye,
// faded across a blend band), then, in one compositor call, the scene's explicit ellipsoid
// clouds and the near LOD's cumulus that stand in for the layer near the eye (faded by the
// complement). A scene without layers is drawn exactly as EllipsoidRenderer draws it.
//
// The host API (see docs/embedding.md): prepare(scene) once; per frame update(dt,
// weather, eye) once, then draw(viewDesc) per display channel. All channels share the clouds,
// their light volumes, the layers' lighting and the near LOD; nothing is reallocated from frame
// to frame while the channels stay the same; weather changes never stall a frame (the layers'
// lighting is computed on a worker thread while the last good one is drawn).
#pragma once

#include "nephele/api.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/host_view.hpp"
#include "nephele/layered.hpp"
#include "nephele/near_lod.hpp"
#include "nephele/weather.hpp"

#include <memory>

NEPHELE_API_BEGIN
namespace nephele {

// `base` with auto's hand-off: nearRadius kAutoNearRadius and blendBand kAutoBlendBand where
// they are 0, and the billboard disc reaching kAutoLod0Margin beyond the band.
LayeredSettings autoLayeredSettings(LayeredSettings base = {});

// The compositor's settings for auto: `base` with tiles that last across frames (reuse, see
// EllipsoidSettings::reuse and docs/compositor.md, "Tiles that last") and far clouds as impostors
// (EllipsoidSettings::cloudLod, where base's composite allows them). Its composite is base's order,
// by default back to front: the compositor's noise being the path tracer's density noise, an
// order flip does not pop (the flicker bench: worst frame +0.009 over the
// exact per-pixel order, as the exact model's own per-ellipsoid order; the weighted composite
// with reuse +0.019 to +0.026), and back to front is cheaper and closer to the path tracer
// than the weighted composite (back-lit 19% against 28%; docs/compositor.md, "Composite order").
EllipsoidSettings autoEllipsoidSettings(EllipsoidSettings base = {});

// Near-LOD cells made per update() at most (nearest first): a change of a layer remakes its
// cells over a few frames instead of in one (render() makes them all).
inline constexpr int kCellsPerUpdate = 4;

struct SkySettings {
    LayeredSettings layered = autoLayeredSettings();
    NearLodSettings nearLod;
    EllipsoidSettings ellipsoid = autoEllipsoidSettings();
    bool timings = false;  // SkyStats' ms by part (gl::PartTimer: glFinish between the parts, slower)
    // Near-LOD cells update() makes at most after the first (nearest first); 0: every cell in
    // reach, as render() (a recorded flight that must equal `render --time`).
    int cellsPerUpdate = kCellsPerUpdate;
    // The background workers (the clouds' radiance grids, the layers' lighting and modulation):
    // priority, cores, cores per job and the host's completion signal (nephele/background.hpp).
    // Replaces layered.background and ellipsoid.light.backgroundWork. onIdle is called, on a
    // worker thread, when a worker runs dry and pending() is 0.
    BackgroundSettings background;
    // true: prepare() makes the layers' lighting and the explicit clouds' grids before it
    // returns (the first frame is lit as the last). false: it queues them and returns once the
    // shaders are built; until they are ready the clouds are lit by stand-ins and the layers are
    // drawn with the nearest lighting volume made, none before the first (pending() says how
    // much is left).
    bool prepareWaits = true;
};

struct SkyStats {
    LayeredStats layered;       // the far field (sceneLayers 0 when the scene has no layers)
    NearLodStats nearLod;       // what the near LOD spawned (render() only: update() reports it)
    EllipsoidStats ellipsoids;  // the compositor, explicit and near clouds together (tilesMs, compositeMs)
    // With SkySettings::timings, the wall time of each part (ms); else 0.
    double farFieldMs = 0;  // the layered sky
    double nearLodMs = 0;   // the near LOD's update (spawning and retiring cells)
};

struct SkyUpdateStats {
    NearLodStats nearLod;    // what the near LOD spawned and retired
    int lightVolumes = 0;    // clouds' radiance grids finished on the worker since the last update
    int lightPending = 0;    // grids still being made there (new near clouds, a new sun)
    int lightStandIns = 0;   // clouds lit by a stand-in meanwhile (model/internal/light_cache.hpp)
    double lightMs = 0;      // wall time of EllipsoidRenderer::updateLights (it never waits for a grid), ms
    int layers = 0;          // enabled layers
    int backgroundJobs = 0;  // lighting and modulation jobs queued or running
    // The weather transition's progress, 0..1: the share of the way from what was shown when the
    // last new weather came to it (Weather::transitionSeconds); 1 when it is done.
    double transition = 1;
};

// What the clouds hold at a point (SkyRenderer::insideCloud).
struct CloudPresence {
    bool inside = false;    // extinction >= kInsideCloudExtinction
    double extinction = 0;  // 1/m at the point
    double depth = 0;       // m: how far the nearest point outside is (0 outside; kCloudDepthReach
                            // when none is that near)
};
// Inside a cloud: where the visibility is under 1 km, the meteorological bound of cloud and fog,
// by Koschmieder's law (visibility = 3.912 / extinction at a contrast threshold of 2%).
inline constexpr double kInsideCloudExtinction = 3.912 / 1000;  // 1/m
inline constexpr double kCloudDepthReach = 5000;                // m: insideCloud looks no further

// Needs a current OpenGL 4.5 context; leaves the GL state as it found it.
class SkyRenderer {
public:
    // Throws std::invalid_argument for bad settings (naming the setting).
    explicit SkyRenderer(SkySettings settings = {});
    ~SkyRenderer();
    SkyRenderer(const SkyRenderer&) = delete;
    SkyRenderer& operator=(const SkyRenderer&) = delete;
    const SkySettings& settings() const;

    // ---- The host API.
    // Takes the scene (its explicit clouds, medium, sky, objects are not drawn; its sun and layers
    // are the weather until the first update), compiles every shader (and draws the scene once
    // off-screen, so that the driver builds its variants), and makes the lighting of its layers
    // and its clouds' light volumes: the one call that waits. Time starts at 0.
    void prepare(const Scene& scene);
    // Once per frame, before the channels draw: advances the time by dtSeconds (>= 0: wind,
    // lightning), takes the weather (sun, sky, cloud layers by CIGI layer id; a layer's drift is
    // integrated, so a change of wind moves its pattern on from where it is; a weather unlike the
    // last one given starts a transition of weather.transitionSeconds from what is shown now, see
    // blendWeather and SkyUpdateStats::transition), updates the near LOD around `eye` (the first
    // update after prepare() makes all its cells; later ones at most kCellsPerUpdate, nearest
    // first) and the clouds' light volumes, and queues what a changed layer needs on the worker
    // thread (one lighting volume per change, the target's; until it is done, the layer is drawn
    // with the nearest volume made: the one it had, or for a new layer another thickness's).
    // Throws std::logic_error before prepare(), std::invalid_argument for a bad dt or weather
    // (Weather::validate).
    SkyUpdateStats update(double dtSeconds, const Weather& weather, const Vec3& eye);
    // Per display channel, after the host drew its terrain and aircraft into the frame: every
    // cloud of the current weather over the channel's viewport (ViewDesc: the host's matrices,
    // depth convention, viewport, depth, colour encoding). Throws std::invalid_argument for a
    // bad ViewDesc (makeView), std::logic_error before prepare().
    SkyStats draw(const ViewDesc& view);
    double time() const;
    // Background jobs queued or running (layers' lighting and modulation); waitForBackgroundWork()
    // blocks until there are none, and until the clouds' radiance grids are made (tests and
    // benches; a host never needs to).
    int backgroundJobs() const;
    void waitForBackgroundWork();
    // All background work not yet done: the layers' jobs and the clouds' grids, queued or
    // running. Thread-safe. At 0 (SkySettings::background.onIdle tells when), the next update()
    // takes every grid made and draws every layer with its own lighting.
    int pending() const;

    // ---- Cloud queries (docs/embedding.md, "Cloud queries"): the matter of the clouds the last
    // update() (or prepare()) made, as drawn: the explicit clouds, the near LOD's clouds times
    // their weights, the layers faded as the layered sky fades them around the eye, the detail
    // seen from the update's eye. Thread-safe: any thread may call them at any time after
    // prepare(), also during update(), which makes the next field while they read the last.
    // CPU only (no GL). Throw std::logic_error before prepare(), std::invalid_argument for a
    // point or ray that is not finite.
    // The extinction coefficient at a world point (1/m): medium.extinction times the density.
    double densityAt(const Vec3& point) const;
    // The transmittance exp(-tau) along origin + t direction, t in [0, length] (length may be
    // infinite): closed form per ellipsoid for the smooth field, the noise and the detail by
    // quadrature along each chord, the layers by steps of at most 20 m.
    double transmittance(const Vec3& origin, const Vec3& direction, double length) const;
    // Whether the point is inside a cloud, and how deep: the distance to the nearest point whose
    // extinction is under kInsideCloudExtinction, searched along 26 directions (the cube's faces,
    // edges and corners) in radii growing by 15% (at least 2 m), then bisected: within about 10%
    // (the directions' spacing), and a clear gap thinner than the radii's step may be missed.
    CloudPresence insideCloud(const Vec3& point) const;

    // The light on a host's surface at world `point` with outward `normal` (any length > 1e-6):
    // the sun's irradiance through the clouds and the diffuse light of the sky, the ground and
    // the clouds, as the compositor lights a scene's objects with object_light "all"
    // (docs/embedding.md, "Lighting the aircraft"). The sun's shadow in it is the explicit and
    // near clouds', not the layers' (transmittance() along the sun has both). From the clouds'
    // grids of the last update(): call it on the thread that calls update() and draw(), between
    // them (not thread-safe, unlike the queries above). Throws std::logic_error before prepare(), std::invalid_argument
    // for a point or normal that is not finite or a normal too short.
    SurfaceLight lightAt(const Vec3& point, const Vec3& normal) const;

    // ---- One synchronous call for one view (the command line, tests): draws every cloud of
    // `scene` over `framebuffer` (as EllipsoidRenderer::render and LayeredRenderer::render:
    // colour attachment 0 rgb = radiance, a = cloud opacity; the opaque objects' depth in its
    // depth attachment when `opaqueDepth`), computing what it needs in the call. timeSeconds
    // drives wind, lightning and the near LOD's drift.
    SkyStats render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds, bool opaqueDepth);

    // For a host's debug views: the compositor (its last tiles and atlas), and the near LOD
    // (its cells; nullptr before the first scene with layers).
    const EllipsoidRenderer& compositor() const;
    const NearLod* nearLod() const;

private:
    struct Impl;  // sky/src/sky.cpp: the compositor, the layered sky, the near LOD and the host API's state
    std::unique_ptr<Impl> impl_;
};

}  // namespace nephele
NEPHELE_API_END
