// `nephele fly`: the ONE place where the fly app calls Nephele's renderers, through the public
// host API as an image generator does (nephele/sky.hpp: prepare once, then update() per frame
// and draw(ViewDesc) into its frame; ellipsoid and layered are SkyRenderer drawing the scene
// without layers or without ellipsoid clouds; raymarch, a reference method with no host API,
// RaymarchRenderer::render), so that a change of that API is a change here. It draws a frame into its own float frame
// (as `nephele render` does, so that recorded frames match `render --time`), presents it onto a window, and hands the
// HUD and the debug views what they show.
#pragma once

#include "nephele/ellipsoid.hpp"
#include "nephele/image.hpp"
#include "nephele/layered.hpp"
#include "nephele/near_lod.hpp"
#include "nephele/scene.hpp"
#include "nephele/sky.hpp"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace nephele::fly {

enum class FlyMethod { Auto, Ellipsoid, Raymarch, Layered };
inline constexpr FlyMethod kFlyMethods[] = {FlyMethod::Auto, FlyMethod::Ellipsoid, FlyMethod::Raymarch,
                                            FlyMethod::Layered};
const char* flyMethodName(FlyMethod method);
std::optional<FlyMethod> parseFlyMethod(const std::string& name);
// The composite order a method starts with, as `nephele render` has it.
CompositeOrder defaultOrder(FlyMethod method);

struct FlyHostSettings {
    FlyMethod method = FlyMethod::Auto;
    std::optional<CompositeOrder> order;  // the compositor's (auto, ellipsoid); default defaultOrder(method)
    std::string cacheDir;                 // the layered sky's lighting cache ("" = none)
    bool timings = true;                  // ms by part (glFinish between the parts)
    // Near-LOD cells made per frame after the first (SkySettings::cellsPerUpdate); 0: all, as
    // `render` (a recording that must equal `render --time`).
    int cellsPerUpdate = kCellsPerUpdate;
    // Each frame waits, after update(), for the layers' lighting and the clouds' radiance grids
    // (SkyRenderer::waitForBackgroundWork), as `render` makes them in the call: a recording.
    // Else new clouds are lit by a stand-in until their grids come from the worker (the window).
    bool waitEachFrame = false;
};

// One frame, as the HUD shows it. Parts in ms (0 where the method has no such part).
struct FlyFrameStats {
    double totalMs = 0, opaqueMs = 0, farFieldMs = 0, nearLodMs = 0, tilesMs = 0, compositeMs = 0, volumeMs = 0;
    int marchDownsample = 0;  // raymarch: a ray per this x this pixels (1 looking within the sun's phase peak)
    EllipsoidStats ellipsoids;
    LayeredStats layered;
    NearLodStats nearLod;
};

class FlyHost {
public:
    // Needs a current OpenGL 4.5 context. Throws std::invalid_argument for bad settings.
    explicit FlyHost(FlyHostSettings settings);
    ~FlyHost();
    const FlyHostSettings& settings() const { return settings_; }
    CompositeOrder order() const { return settings_.order.value_or(defaultOrder(settings_.method)); }
    void setMethod(FlyMethod method);     // the next draw uses it (its renderer made then)
    void setOrder(CompositeOrder order);  // PerEllipsoid or Weighted; remakes the compositor

    // The scene's sky, objects and clouds seen by `camera` (its size) at scene time t: the
    // first draw (and the first after sceneChanged(), a change of method or order, or t going
    // back) prepares the renderer with `scene`; then each draw updates it by the time since the
    // last (the scene's sun, sky and layers being the weather) and draws.
    FlyFrameStats draw(const Scene& scene, const Camera& camera, double t);
    // The scene's clouds, medium or objects changed (a reload): the next draw prepares again.
    // Its sun, sky and layers (the live controls) need no call: they are the weather.
    void sceneChanged();
    // The last frame onto `framebuffer` (0: the window's), scaled to w x h, sRGB-encoded.
    void present(GLuint framebuffer, int w, int h);
    Image readColor() const;  // the last frame, RGBA linear, top row first (as `render` reads it)

    // Debug views of the last draw: the compositor's tiles and atlas (none under raymarch and
    // layered), and the near LOD's cells (auto, with layers).
    const EllipsoidRenderer* compositor() const;
    std::vector<const NearCell*> nearCells() const;
    double nearRadius() const, blendBand() const;  // m, auto's hand-off (0 for other methods)
    double nearCellSize() const;                   // m

private:
    struct Renderers;
    void drawSky(const Scene& scene, const View& view, double t, FlyFrameStats& stats);
    FlyHostSettings settings_;
    std::unique_ptr<Renderers> r_;
};

}  // namespace nephele::fly
