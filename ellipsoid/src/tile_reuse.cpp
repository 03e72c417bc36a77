#include "tile_reuse.hpp"

#include "fingerprint.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/gl.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace nephele {

namespace {

using namespace reuse;

// A repack leaves this share of the memory budget's layers free, so that the frames after it
// find room for the tiles that grow without packing again.
constexpr double kRepackFill = 0.8;

double pixelRadiusOf(const EllipsoidProjection& p) { return 0.5 * std::max(p.pixelWidth, p.pixelHeight); }

}  // namespace

std::uint64_t reuse::imageInputs(const Scene& scene, double noisePeriod) {
    return Fingerprint()
        .add(scene.sun.direction)
        .addMedium(scene.medium)
        .addDetail(scene.medium.detail)
        .add(noisePeriod)
        .value();
}

double reuse::sunPhase(const Vec3& centre, const View& view, const Scene& scene) {
    const Vec3 d = glm::normalize(centre - view.eye);
    return model::hgPhase(float(glm::dot(d, scene.sun.direction)), float(scene.medium.hgG));
}

namespace {
// The detail's drift counts four times its pixels: on a near cloud its finest octaves are a pixel
// or two across and speckle where the compositor's pieces cut them, so a quarter of a pixel of
// drift changes a reused tile as much as a pixel of parallax (TheDetailsDriftRendersTilesAgain:
// 38.8 dB of fresh at 1x, 39.6 at 2x, 39.9 at 3x, 42.8 at 4x).
constexpr double kDetailDriftWeight = 4.0;
}  // namespace

double reuse::parallaxPixels(double r, const Vec3& eyeFromCentreThen, const Vec3& eyeFromCentreNow, double radius,
                             double drift) {
    const double then = glm::length(eyeFromCentreThen), now = glm::length(eyeFromCentreNow);
    const double angle = std::acos(std::clamp(glm::dot(eyeFromCentreNow, eyeFromCentreThen) / (now * then), -1.0, 1.0));
    return r * angle + r * std::abs(then / now - 1) * std::min(1.0, radius / now) + drift * r / radius;
}

double reuse::reshapeMetres(const glm::dmat3& axesThen, const glm::dmat3& axesNow, const Vec3& loThen,
                            const Vec3& loNow, const Vec3& hiThen, const Vec3& hiNow) {
    const glm::dmat3 d = axesNow - axesThen;
    const double surface =
        std::sqrt(glm::dot(d[0], d[0]) + glm::dot(d[1], d[1]) + glm::dot(d[2], d[2]));  // Frobenius >= spectral
    return std::max({surface, glm::length(loNow - loThen), glm::length(hiNow - hiThen)});
}

double reuse::outsidePixels(const glm::dvec4& quad, const ScreenRect& inView, const View& view) {
    const double pxX = 0.5 * view.camera.width, pxY = 0.5 * view.camera.height;
    return std::max({(quad.x - inView.x0) * pxX, (inView.x1 - quad.z) * pxX, (quad.y - inView.y0) * pxY,
                     (inView.y1 - quad.w) * pxY});
}

bool reprojectImage(const Vec3& eyeFromCentre, const Vec3& centre, const Vec3& rc, const Vec3& rx, const Vec3& ry,
                    const glm::dmat4& viewProj, const Vec3& eye, glm::dmat4& reproject, glm::dvec4& rect) {
    // Tile clip (x, y) -> the ray rc + x rx + y ry from the eye it was rendered from -> its
    // point on the plane through the centre facing that eye, moved with the centre (wind) ->
    // the frame's clip space. Homogeneous, so one matrix.
    const double dist = glm::length(eyeFromCentre);
    if (!(dist > 0)) return false;
    const Vec3 nrm = -eyeFromCentre / dist;
    const Vec3 a = eyeFromCentre + centre - eye;
    auto column = [&](const Vec3& r) {
        return viewProj * glm::dvec4(a * glm::dot(nrm, r) + r * dist, glm::dot(nrm, r));
    };
    reproject = glm::dmat4(column(rx), column(ry), glm::dvec4(0.0), column(rc));
    rect = glm::dvec4(1e300, 1e300, -1e300, -1e300);
    for (int k = 0; k < 4; ++k) {
        const double x = (k & 1) ? 1 : -1, y = (k & 2) ? 1 : -1;
        const glm::dvec4 clip = reproject * glm::dvec4(x, y, 0, 1);
        if (!(glm::dot(nrm, rc + x * rx + y * ry) > 0 && clip.w > 1e-9 * dist)) return false;
        const double px = clip.x / clip.w, py = clip.y / clip.w;
        rect = {std::min(rect.x, px), std::min(rect.y, py), std::max(rect.z, px), std::max(rect.w, py)};
    }
    return true;
}

// One visible ellipsoid's tile this frame: its image's inputs, and whether and how badly its
// kept image (if any) is stale.
struct TileReuse::Candidate {
    int index = 0;
    std::uint64_t key = 0;
    std::uint64_t noise = 0, light = 0;
    Vec3 lightLo{0.0}, lightHi{0.0};
    int need = 0;      // tile size it would be rendered at now
    double error = 0;  // >= 1: stale
    bool must = true;  // no usable image: rendered whatever the budget
    Live* live = nullptr;
    glm::dmat4 reproject{1.0};
    glm::dvec4 rect{0.0};
};

void TileReuse::beginFrame(const ReuseSettings& s, std::size_t n) {
    if (!allocator_ || allocatedFor_.atlasWidth != s.atlasWidth || allocatedFor_.atlasHeight != s.atlasHeight ||
        allocatedFor_.minTile != s.minTile || allocatedFor_.maxLayers != s.maxLayers) {
        allocator_ = std::make_unique<TileAllocator>(s.atlasWidth, s.atlasHeight, s.minTile, s.maxLayers);
        live_.clear();
        limit_ = s.maxTile;
    }
    // The largest tile size: halved when a repack needs it to stay within the memory budget,
    // and kept so (the next frames' tiles would not fit either); doubled again while the
    // layers in use leave room for its tiles four times over.
    limit_ = std::clamp(limit_, s.minTile, s.maxTile);
    if (limit_ < s.maxTile && 4 * allocator_->layersUsed() <= s.budgetLayers) limit_ *= 2;
    allocatedFor_ = s;
    fresh_.assign(n, nullptr);
}

std::vector<TileReuse::Candidate> TileReuse::candidates(const ReuseSettings& s, const Scene& scene, const View& view,
                                                        const PreparedClouds& prepared,
                                                        const std::vector<PlacedRadiance>& light) {
    // What a tile's image depends on besides the view.
    const std::uint64_t global = imageInputs(scene, prepared.noisePeriod);
    const glm::dmat4 viewProj = view.projectionMatrix * glm::lookAt(Vec3(0.0), view.forward, view.up);
    const std::size_t n = prepared.ellipsoids.size();
    std::vector<Candidate> cands(n);
    std::unordered_map<std::uint64_t, int> ordinal;  // identical keys in one frame (a hostile scene)
    for (std::size_t i = 0; i < n; ++i) {
        const PreparedEllipsoid& e = prepared.ellipsoids[i];
        const Cloud& cloud = scene.clouds[std::size_t(e.cloud)];
        const std::uint64_t id =
            Fingerprint().add(cloud.noiseId ? cloud.noiseId : std::uint64_t(e.cloud)).add(e.index).value();
        Candidate& c = cands[i];
        c.index = int(i), c.key = Fingerprint().add(id).add(ordinal[id]++).value();
        c.noise = Fingerprint().add(e.noiseOffset).value();
        const PlacedRadiance& pl = light[std::size_t(e.cloud)];
        // The grid itself (its own box tells two grids apart that came to the same address); where
        // it is placed on the cloud is measured with the shape (staleness()).
        c.light = Fingerprint().add(global).add(pl.grid.get()).add(pl.grid->boxMin).add(pl.grid->boxExtent).value();
        c.lightLo = pl.lo - e.shape.center, c.lightHi = pl.lo + pl.extent - e.shape.center;
        c.need = tileSizeFor(tileExtent(e), s.minTile, limit_);
        auto it = live_.find(c.key);
        c.live = it == live_.end() ? nullptr : &it->second;
        staleness(c, s, scene, view, e, viewProj);
    }
    return cands;
}

void TileReuse::staleness(Candidate& c, const ReuseSettings& s, const Scene& scene, const View& view,
                          const PreparedEllipsoid& e, const glm::dmat4& viewProj) const {
    const EllipsoidProjection& p = e.projection;
    if (!c.live || p.crossesNear || !c.live->reusable || c.live->noise != c.noise) return;
    const Live& L = *c.live;
    if (!reprojectImage(L.eyeFromCentre, e.shape.center, L.rc, L.rx, L.ry, viewProj, view.eye, c.reproject, c.rect))
        return;
    const double r = pixelRadiusOf(p);
    const double rMax = e.shape.maxRadius();
    const double reshaped = reshapeMetres(L.axes, e.axes, L.lightLo, c.lightLo, L.lightHi, c.lightHi) * r / rMax;
    // Part of what is in view now outside the tile's quad (a tile cut by the view's edge
    // then): a visible cut, rendered now. An ellipsoid that grew reaches past its quad by
    // as much as it grew: that part is the reshape's error, counted below.
    if (outsidePixels(c.rect, p.rect, view) > s.errorPixels + reshaped) return;
    c.must = false;
    // How far textures moved through the cloud since: the world-fixed noise by the cloud's own
    // move, the detail by its drift less that move (the detail and the cloud each go with their wind).
    const Vec3 moved = e.shape.center - L.centre;
    const Medium::Detail& detail = scene.medium.detail;
    const double drift = (scene.medium.noise > 0 ? glm::length(moved) : 0.0) +
                         (detail.on() ? kDetailDriftWeight * glm::length(detail.drift - L.detailDrift - moved) : 0.0);
    const double px = parallaxPixels(r, L.eyeFromCentre, view.eye - e.shape.center, rMax, drift);
    c.error = (px + reshaped) / s.errorPixels;
    // The phase towards the eye, as the eye moves (a new sun is a change of light, below).
    if (L.light == c.light)
        c.error = std::max(c.error, std::abs(sunPhase(e.shape.center, view, scene) / L.phase - 1) / kPhaseChange);
    if (c.error >= kMustError) c.must = true;  // before the extinction and the light: those may wait
    // A changed extinction (a weather ramp, a near-LOD cloud fading) is itself gradual:
    // stale, caught up worst first within the budget, never rendered whatever the budget.
    c.error = std::max(c.error, std::abs(e.sigma / L.sigma - 1) / kSigmaChange);
    if (c.need > L.place.size) c.error = std::max(c.error, 1.0 + std::log2(double(c.need) / L.place.size));
    // Two sizes too large: sixteen times the atlas area it needs, rendered again smaller
    // when the budget allows (its image is still right meanwhile).
    if (4 * c.need <= L.place.size) c.error = std::max(c.error, 1.0);
    if (L.light != c.light) c.error = std::max(c.error, kLightChanged + r);
}

void TileReuse::releaseUnseen(const std::vector<Candidate>& cands, const std::vector<char>& keep, std::uint64_t frame) {
    for (const Candidate& c : cands)
        if (c.live) c.live->seen = frame;
    for (auto it = live_.begin(); it != live_.end();) {
        const int cloud = it->second.cloud;
        const bool kept = cloud >= 0 && std::size_t(cloud) < keep.size() && keep[std::size_t(cloud)];
        if (it->second.seen != frame && !kept) {
            allocator_->free(it->second.place);
            it = live_.erase(it);
        } else {
            ++it;
        }
    }
}

// The frame's re-renders: every tile without a usable image, then the stale ones worst
// first within what the budget has left after those, but at least half of it (a frame
// with many new tiles catches up on fewer stale ones, so the frames stay more even; the
// half keeps stale tiles from starving while new ones keep coming, as they do inside a
// cloud). The worst stale one is taken even when it alone is over that (a tile larger
// than the budget would wait for ever); the others while it lasts, strictly worst first.
std::vector<int> TileReuse::chooseRenders(const ReuseSettings& s, const std::vector<Candidate>& cands, int& must) {
    const double budget = s.budget * double(s.frameWidth) * double(s.frameHeight);
    double spent = 0;
    std::vector<int> render;
    std::vector<int> stale;
    for (const Candidate& c : cands) {
        if (c.must) render.push_back(c.index), ++must, spent += double(c.need) * c.need;
        else if (c.error >= 1) stale.push_back(c.index);
    }
    std::stable_sort(stale.begin(), stale.end(), [&](int a, int b) { return cands[a].error > cands[b].error; });
    spent = std::min(spent, 0.5 * budget);
    bool first = true;
    for (int i : stale) {
        const double px = double(cands[i].need) * cands[i].need;
        if (s.budget <= 0 || (!first && spent + px > budget)) break;
        spent += px, first = false;
        render.push_back(i);
    }
    return render;
}

// Places: a re-render of another size moves; then new places, largest first. false: the atlas
// is too full or too fragmented.
bool TileReuse::placeRenders(const ReuseSettings& s, std::vector<Candidate>& cands, std::vector<int>& render) {
    for (int i : render) {
        Candidate& c = cands[std::size_t(i)];
        if (c.live && c.live->place.size != c.need) {
            allocator_->free(c.live->place);
            c.live->place.pass = -1;
        }
    }
    std::stable_sort(render.begin(), render.end(), [&](int a, int b) { return cands[a].need > cands[b].need; });
    for (int i : render) {
        Candidate& c = cands[std::size_t(i)];
        if (c.live && c.live->place.pass >= 0) continue;
        const TilePlacement place = allocator_->allocate(c.need);
        if (place.pass < 0 || place.pass >= std::min(s.layers, s.budgetLayers)) {
            if (place.pass >= 0) allocator_->free(place);
            return false;
        }
        if (!c.live) c.live = &live_[c.key];
        c.live->place = place;
    }
    return true;
}

// The atlas packed anew, everything rendered (as without reuse), the largest tiles halved until
// the memory budget holds.
void TileReuse::repack(const ReuseSettings& s, const PreparedClouds& prepared, std::vector<Candidate>& cands,
                       std::vector<int>& render, ReusePlan& out) {
    const std::size_t n = cands.size();
    out.reset = true;
    out.must = int(n);
    for (Candidate& c : cands) c.live = nullptr;
    render.clear();
    for (std::size_t i = 0; i < n; ++i) render.push_back(int(i));
    const int fill = std::max(1, int(kRepackFill * s.budgetLayers));
    for (int limit = s.maxTile;; limit /= 2) {
        allocator_->clear();
        live_.clear();
        for (Candidate& c : cands)
            c.need = tileSizeFor(tileExtent(prepared.ellipsoids[std::size_t(c.index)]), s.minTile, limit);
        std::stable_sort(render.begin(), render.end(), [&](int a, int b) { return cands[a].need > cands[b].need; });
        bool all = true;
        for (int i : render) {
            Candidate& c = cands[std::size_t(i)];
            const TilePlacement place = allocator_->allocate(c.need);
            if (place.pass < 0) {
                all = false;
                break;
            }
            c.live = &live_[c.key];
            c.live->place = place;
        }
        limit_ = out.maxTile = limit;
        if (all && (allocator_->layersUsed() <= fill || limit <= s.minTile)) break;
        if (limit <= s.minTile)
            throw gl::GlError("ellipsoid atlas: " + std::to_string(n) + " visible ellipsoids do not fit " +
                              std::to_string(s.maxLayers) + " layers of " + std::to_string(s.atlasWidth) + "x" +
                              std::to_string(s.atlasHeight) + " even with " + std::to_string(s.minTile) +
                              " px tiles; give a larger atlas (--atlas) or smaller tiles (--min-tile)");
    }
}

// The plan, and what each fresh tile will be rendered from.
void TileReuse::writePlan(const Scene& scene, const View& view, const PreparedClouds& prepared,
                          const std::vector<Candidate>& cands, const std::vector<int>& render, std::uint64_t frame,
                          ReusePlan& out) {
    const std::size_t n = cands.size();
    std::vector<char> isFresh(n, 0);
    for (int i : render) {
        isFresh[std::size_t(i)] = 1;
        const Candidate& c = cands[std::size_t(i)];
        const PreparedEllipsoid& e = prepared.ellipsoids[std::size_t(i)];
        Live& L = *c.live;
        L.noise = c.noise, L.light = c.light, L.sigma = e.sigma;
        L.axes = e.axes, L.lightLo = c.lightLo, L.lightHi = c.lightHi;
        L.cloud = e.cloud;
        L.reusable = !e.projection.crossesNear;
        L.eyeFromCentre = view.eye - e.shape.center;
        L.centre = e.shape.center;
        L.detailDrift = scene.medium.detail.drift;
        L.phase = sunPhase(e.shape.center, view, scene);
        L.seen = frame;
        fresh_[std::size_t(i)] = &L;
        out.fresh.push_back({i, L.place.pass, L.place.x, L.place.y, L.place.size});
    }
    for (std::size_t i = 0; i < n; ++i) {
        if (isFresh[i]) continue;
        const Candidate& c = cands[i];
        out.reused.push_back({int(i), c.live->place.pass, c.live->place.x, c.live->place.y, c.live->place.size});
        out.reproject.push_back(glm::mat4(c.reproject));
        out.screenRect.push_back(glm::vec4(c.rect));
    }
}

ReusePlan TileReuse::plan(const ReuseSettings& s, const Scene& scene, const View& view, const PreparedClouds& prepared,
                          const std::vector<PlacedRadiance>& light, const std::vector<char>& keep) {
    ReusePlan out;
    const std::uint64_t frame = ++frame_;
    beginFrame(s, prepared.ellipsoids.size());
    out.maxTile = limit_;
    std::vector<Candidate> cands = candidates(s, scene, view, prepared, light);
    releaseUnseen(cands, keep, frame);  // tiles no longer in view give their place back
    std::vector<int> render = chooseRenders(s, cands, out.must);
    if (!placeRenders(s, cands, render)) repack(s, prepared, cands, render, out);
    writePlan(scene, view, prepared, cands, render, frame, out);
    out.layers = allocator_->layersUsed();
    std::int64_t used = 0;
    for (const auto& [key, t] : live_) used += std::int64_t(t.place.size) * t.place.size;
    out.utilisation = out.layers ? double(used) / (double(out.layers) * s.atlasWidth * s.atlasHeight) : 0;
    return out;
}

void TileReuse::rendered(int preparedIndex, const Vec3& rc, const Vec3& rx, const Vec3& ry) {
    Live* L = fresh_.at(std::size_t(preparedIndex));
    if (!L) return;
    L->rc = rc, L->rx = rx, L->ry = ry;
}

}  // namespace nephele
