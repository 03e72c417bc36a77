#include "cloud_impostors.hpp"

#include "fingerprint.hpp"
#include "nephele/gardner_model.hpp"
#include "tile_reuse.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <bit>
#include <cmath>

namespace nephele {

using namespace gl;

namespace {

using namespace reuse;  // as for tiles: phase, weight, must and light thresholds
// An impostor stays one while the cloud is beyond this share of cloudLodDistance (hysteresis:
// a cloud at the boundary does not switch every frame).
constexpr double kKeepDistance = 0.9;
constexpr int kMinImpostor = 8;  // px
// The share an impostor may be magnified on screen before it is stale (made again within the
// budget); six times that (kMustError) and it is made again whatever the budget.
constexpr double kImpostorMagnification = 0.05;

Vec3 quantised(const Vec3& v) { return glm::round(v * 1000.0); }  // mm: the wind moves all alike

}  // namespace

// The visible clouds: their tiles' rectangle, whether any is cut by the near plane, how many.
struct CloudImpostors::Group {
    int visible = 0;
    bool cut = false;
    ScreenRect rect{1e300, 1e300, -1e300, -1e300};
    std::vector<std::uint64_t> shapes;  // per visible ellipsoid: index, shape, place in the cloud
};

// A cloud that is an impostor this frame: where its image goes on screen, whether it must be
// made (else its error: stale at 1), and what it is made from.
struct CloudImpostors::Candidate {
    int cloud;
    std::uint64_t key;
    Live* live;
    bool must;
    double error;
    int px, py, w, h, need;
    glm::dmat4 reproject;
    std::uint64_t light;
    double phase, weight;
};

ImpostorPlan CloudImpostors::plan(const ImpostorSettings& s, const Scene& scene, const View& view,
                                  const PreparedClouds& prepared, const std::vector<PlacedRadiance>& light) {
    ImpostorPlan out;
    out.impostor.assign(scene.clouds.size(), 0);
    const std::uint64_t frame = ++frame_;
    if (!allocator_ || atlasSize_ != s.atlasSize || layers_ != s.layers) makeAtlas(s);
    const std::vector<Group> groups = groupClouds(prepared, scene.clouds.size());
    std::vector<Candidate> cands = candidates(s, scene, view, prepared, light, groups, frame, out);

    // Impostors no longer in use give their place back.
    for (auto it = live_.begin(); it != live_.end();) {
        if (it->second.seen != frame) {
            if (it->second.place.pass >= 0 && it->second.place.size > 0) allocator_->free(it->second.place);
            it = live_.erase(it);
        } else {
            ++it;
        }
    }

    const std::vector<char> fresh = makeImages(s, view, prepared, groups, cands, out);
    for (std::size_t i = 0; i < cands.size(); ++i) {
        const Candidate& k = cands[i];
        if (!k.live || !out.impostor[std::size_t(k.cloud)]) continue;
        ImpostorDraw d;
        d.cloud = k.cloud;
        d.fresh = fresh[i] != 0;
        d.place = k.live->place;
        d.px = k.px, d.py = k.py, d.w = k.live->w, d.h = k.live->h;
        d.reproject = glm::mat4(k.reproject);
        d.centre = prepared.spheres[std::size_t(k.cloud)].centre;
        d.radius = prepared.spheres[std::size_t(k.cloud)].radius;
        d.distance = glm::length(view.eye - d.centre);
        out.draws.push_back(d);
    }
    std::stable_sort(out.draws.begin(), out.draws.end(),
                     [](const ImpostorDraw& a, const ImpostorDraw& b) { return a.distance > b.distance; });
    return out;
}

// The atlas (its layers, a framebuffer each, and the allocator), made anew: every image is lost.
void CloudImpostors::makeAtlas(const ImpostorSettings& s) {
    fbos_.clear();
    texture_ = Texture::create(GL_TEXTURE_2D_ARRAY);
    checkTextureSize("the cloud impostor atlas", s.atlasSize, s.atlasSize, 0, s.layers);
    glTextureStorage3D(texture_.id(), 1, GL_RGBA16F, s.atlasSize, s.atlasSize, s.layers);
    checkAllocation("the cloud impostor atlas", std::uint64_t(s.atlasSize) * std::uint64_t(s.atlasSize) * s.layers * 8);
    for (int l = 0; l < s.layers; ++l) {
        Framebuffer fbo = Framebuffer::create();
        glNamedFramebufferTextureLayer(fbo.id(), GL_COLOR_ATTACHMENT0, texture_.id(), 0, l);
        checkFramebuffer(fbo.id(), "the cloud impostor atlas");
        fbos_.push_back(std::move(fbo));
    }
    allocator_ = std::make_unique<TileAllocator>(s.atlasSize, s.atlasSize, kMinImpostor, s.layers);
    atlasSize_ = s.atlasSize, layers_ = s.layers;
    live_.clear();
}

std::vector<CloudImpostors::Group> CloudImpostors::groupClouds(const PreparedClouds& prepared, std::size_t nClouds) {
    std::vector<Group> groups(nClouds);
    const std::vector<CloudSphere>& spheres = prepared.spheres;  // the clouds' bounding spheres
    for (const PreparedEllipsoid& e : prepared.ellipsoids) {
        Group& g = groups[std::size_t(e.cloud)];
        ++g.visible;
        g.cut = g.cut || e.projection.crossesNear;
        g.rect = {std::min(g.rect.x0, e.projection.rect.x0), std::min(g.rect.y0, e.projection.rect.y0),
                  std::max(g.rect.x1, e.projection.rect.x1), std::max(g.rect.y1, e.projection.rect.y1)};
        g.shapes.push_back(Fingerprint()
                               .add(e.index)
                               .add(quantised(e.shape.center - spheres[std::size_t(e.cloud)].centre))
                               .add(e.shape.radii)
                               .add(e.unit)
                               .add(e.noiseOffset)
                               .value());
    }
    for (Group& g : groups) std::sort(g.shapes.begin(), g.shapes.end());
    return groups;
}

// The clouds that are impostors this frame (out.impostor), each with its kept image's error,
// or must, when it has no usable one. Marks each seen this frame (a new one gets its entry).
std::vector<CloudImpostors::Candidate> CloudImpostors::candidates(const ImpostorSettings& s, const Scene& scene,
                                                                  const View& view, const PreparedClouds& prepared,
                                                                  const std::vector<PlacedRadiance>& light,
                                                                  const std::vector<Group>& groups, std::uint64_t frame,
                                                                  ImpostorPlan& out) {
    const std::vector<CloudSphere>& spheres = prepared.spheres;
    const std::uint64_t global = imageInputs(scene, prepared.noisePeriod);
    const glm::dmat4 viewProj = view.projectionMatrix * glm::lookAt(Vec3(0.0), view.forward, view.up);
    const double pxX = 0.5 * view.camera.width, pxY = 0.5 * view.camera.height;
    std::vector<Candidate> cands;
    for (int c = 0; c < int(groups.size()); ++c) {
        const Group& g = groups[std::size_t(c)];
        if (g.visible == 0 || g.cut) continue;
        const Cloud& cloud = scene.clouds[std::size_t(c)];
        const double weight = std::clamp(cloud.weight, 0.0, 1.0);
        const std::uint64_t key = Fingerprint().add(cloud.noiseId ? cloud.noiseId : std::uint64_t(c)).add(c).value();
        auto it = live_.find(key);
        Live* L = it == live_.end() ? nullptr : &it->second;
        const Vec3 toEye = view.eye - spheres[std::size_t(c)].centre;
        const double distance = glm::length(toEye);
        const double keep = L && L->seen + 1 == frame ? kKeepDistance : 1.0;
        if (!(distance > keep * s.distance * spheres[std::size_t(c)].radius)) continue;
        Candidate k;
        k.cloud = c, k.key = key, k.live = L, k.must = true, k.error = 0;
        k.px = int(std::floor((g.rect.x0 + 1) * pxX)), k.py = int(std::floor((g.rect.y0 + 1) * pxY));
        k.w = int(std::ceil((g.rect.x1 + 1) * pxX)) - k.px, k.h = int(std::ceil((g.rect.y1 + 1) * pxY)) - k.py;
        if (std::max(k.w, k.h) > s.maxPixels) continue;
        k.need = std::max(kMinImpostor, int(std::bit_ceil(unsigned(std::max({k.w, k.h, 1})))));
        if (k.need > s.atlasSize) continue;
        const PlacedRadiance& pl = light[std::size_t(c)];
        const std::uint64_t lightKey = Fingerprint()
                                           .add(global)
                                           .add(pl.grid.get())
                                           .add(quantised(pl.lo - spheres[std::size_t(c)].centre))
                                           .add(pl.extent)
                                           .value();
        const double phase = sunPhase(spheres[std::size_t(c)].centre, view, scene);
        const double r = 0.5 * std::max(k.w, k.h);
        glm::dvec4 rect;
        // Usable: every ellipsoid in view now is in the image, unchanged (those gone out of view
        // may stay in it: their part of it lies beyond the view's edge), and what is in view of
        // the cloud lies within the image's quad (a cloud cut by the view's edge when it was
        // made shows only what was in view then).
        const bool same =
            L && L->made && std::includes(L->shapes.begin(), L->shapes.end(), g.shapes.begin(), g.shapes.end());
        if (same &&
            reprojectImage(L->eyeFromCentre, spheres[std::size_t(c)].centre, L->rc, L->rx, L->ry, viewProj, view.eye,
                           k.reproject, rect) &&
            outsidePixels(rect, g.rect, view) <= s.errorPixels) {
            k.must = false;
            // The whole cloud's parallax: its depth is its bounding radius.
            const double drift = scene.medium.noise > 0 ? glm::length(spheres[std::size_t(c)].centre - L->centre) : 0.0;
            const double px = parallaxPixels(r, L->eyeFromCentre, toEye, spheres[std::size_t(c)].radius, drift);
            k.error = px / s.errorPixels;
            if (L->light == lightKey) k.error = std::max(k.error, std::abs(phase / L->phase - 1) / kPhaseChange);
            k.error = std::max(k.error, std::abs(weight / std::max(L->weight, 1e-9) - 1) / kSigmaChange);
            // Magnified: its image holds a texel per pixel of the view it was made from, and
            // reprojected larger it is a blur of the cloud (its rims against the ground and the
            // sky smeared: dark discs). The parallax above does not see it: a cloud the eye
            // closes in on grows without moving across the view.
            const double grown = std::max((rect.z - rect.x) * pxX / L->w, (rect.w - rect.y) * pxY / L->h);
            k.error = std::max(k.error, (grown - 1) / kImpostorMagnification);
            if (k.error >= kMustError) k.must = true;
            if (L->light != lightKey) k.error = std::max(k.error, kLightChanged + r);
        }
        if (!L) L = &live_[key];
        L->seen = frame;
        k.live = L;
        k.light = lightKey, k.phase = phase, k.weight = weight;
        cands.push_back(k);
        out.impostor[std::size_t(c)] = 1;
    }
    return cands;
}

// The frame's makes: every impostor without a usable image, then the stale ones worst first
// within the budget (the worst one always), each given its place in the atlas and its view.
// Returns, per candidate, whether it is made this frame. A candidate the full atlas has no
// place for is drawn as tiles (out.impostor 0, its entry gone).
std::vector<char> CloudImpostors::makeImages(const ImpostorSettings& s, const View& view,
                                             const PreparedClouds& prepared, const std::vector<Group>& groups,
                                             std::vector<Candidate>& cands, ImpostorPlan& out) {
    const int W = view.camera.width, H = view.camera.height;
    const double budget = s.budget * double(W) * double(H);
    double spent = 0;
    std::vector<std::size_t> make, stale;
    for (std::size_t i = 0; i < cands.size(); ++i) {
        if (cands[i].must) make.push_back(i);
        else if (cands[i].error >= 1) stale.push_back(i);
    }
    std::stable_sort(stale.begin(), stale.end(),
                     [&](std::size_t a, std::size_t b) { return cands[a].error > cands[b].error; });
    for (std::size_t i : stale) {
        const double px = double(cands[i].w) * cands[i].h;
        if (s.budget <= 0 || (spent > 0 && spent + px > budget)) break;
        spent += px;
        make.push_back(i);
    }
    std::vector<char> fresh(cands.size(), 0);
    for (std::size_t i : make) {
        Candidate& k = cands[i];
        Live& L = *k.live;
        if (L.place.size != k.need && L.place.size > 0) {
            allocator_->free(L.place);
            L.place = {-1, -1, 0, 0, 0};
        }
        if (L.place.size == 0) {
            const TilePlacement place = allocator_->allocate(k.need);
            if (place.pass < 0) {  // the atlas is full: this cloud is drawn as tiles
                out.impostor[std::size_t(k.cloud)] = 0;
                live_.erase(k.key);
                k.live = nullptr;
                continue;
            }
            L.place = place;
        }
        fresh[i] = 1;
        const Vec3 centre = prepared.spheres[std::size_t(k.cloud)].centre;
        L.made = true;
        L.shapes = groups[std::size_t(k.cloud)].shapes;
        L.light = k.light, L.phase = k.phase, L.weight = k.weight;
        L.w = k.w, L.h = k.h;
        L.eyeFromCentre = view.eye - centre;
        L.centre = centre;
        // Image clip (x, y) -> the view's NDC of the pixels it covers -> the ray through them.
        const double cx = (2.0 * k.px + k.w) / W - 1, cy = (2.0 * k.py + k.h) / H - 1;
        const double hx = double(k.w) / W, hy = double(k.h) / H;
        L.rc = view.rayCentre() + cx * view.rightScaled() + cy * view.upScaled();
        L.rx = hx * view.rightScaled(), L.ry = hy * view.upScaled();
        k.reproject =
            glm::dmat4(glm::dvec4(hx, 0, 0, 0), glm::dvec4(0, hy, 0, 0), glm::dvec4(0.0), glm::dvec4(cx, cy, 0, 1));
        ++out.rendered;
    }
    return fresh;
}

}  // namespace nephele
