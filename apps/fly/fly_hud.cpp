// The window's overlay, drawn with Dear ImGui: HUD, help, live controls, debug views.
#include "fly_app_state.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl_state.hpp"

#include <glm/trigonometric.hpp>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace nephele::fly {

const char* const kHelp =
    "W / S       forward / back\n"
    "A / D       sideways left / right\n"
    "E / Q       climb / descend\n"
    "arrows      yaw left / right, pitch up / down\n"
    "left drag   look (yaw and pitch with the mouse)\n"
    "Shift       fast (x5)\n"
    "no key      hover (the helicopter slows to a stop)\n"
    "P           follow the scene's path (again: fly from there)\n"
    "R           back to the scene's camera\n"
    "M           next method (auto, ellipsoid, raymarch, layered)\n"
    "O           composite order (weighted / back to front)\n"
    "Tab         live controls (method, sun, layers)\n"
    "F1          HUD    F2 atlas    F3 tile rectangles\n"
    "F4          near-LOD cells and the near/far blend band\n"
    "F12         screenshot (nephele_fly_N.png in the working directory)\n"
    "H           this help    Esc  quit";

namespace {
using namespace gl;
constexpr ImGuiWindowFlags kPanel = ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                                    ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav |
                                    ImGuiWindowFlags_NoMove;

void drawHud(const FlyApp::State& s) {
    const FlyFrameStats& st = s.stats;
    const EllipsoidStats& e = st.ellipsoids;
    ImGui::SetNextWindowPos(ImVec2(8, 8));
    ImGui::SetNextWindowBgAlpha(0.55f);
    ImGui::Begin("HUD", nullptr, kPanel);
    const FlyMethod method = s.host->settings().method;
    const bool compositor = method == FlyMethod::Auto || method == FlyMethod::Ellipsoid;
    ImGui::Text("%.1f fps   %.0f ms/frame   %dx%d   method %s%s", s.fps, st.totalMs, s.renderW, s.renderH,
                flyMethodName(method),
                !compositor                                   ? ""
                : s.host->order() == CompositeOrder::Weighted ? ", weighted composite"
                                                              : ", back-to-front composite");
    ImGui::Text("ms: opaque %.1f | far field %.1f | near-LOD update %.1f | tiles %.1f | composite %.1f", st.opaqueMs,
                st.farFieldMs, st.nearLodMs, st.tilesMs, st.compositeMs);
    if (method == FlyMethod::Raymarch)
        ImGui::Text("    ray-marched volume %.1f (a ray per %dx%d px)", st.volumeMs, st.marchDownsample,
                    st.marchDownsample);
    if (compositor)
        ImGui::Text(
            "ellipsoids %d: %d visible, %d culled | tiles %d rendered (%d without an image), %d reused%s | passes %d | "
            "atlas use %.0f%%",
            e.ellipsoids, e.visible, e.ellipsoids - e.visible, e.tilesRendered, e.tilesMust, e.tilesReused,
            e.atlasRepacked ? ", atlas repacked" : "", e.passes, 100 * e.utilisation);
    if (method == FlyMethod::Auto && s.host->order() == CompositeOrder::PerEllipsoid)
        ImGui::Text("cloud LOD: %d clouds as impostors, %d made this frame; %d close tiles at reduced resolution",
                    e.impostors, e.impostorsRendered, e.tilesDownsampled);
    if (method == FlyMethod::Auto && st.layered.sceneLayers > 0)
        ImGui::Text("near LOD: %d cells, %d cumulus (%d fading), %d ellipsoids | layers: %d instances in %d draws",
                    st.nearLod.cells, st.nearLod.clouds, st.nearLod.fading, st.nearLod.ellipsoids, st.layered.instances,
                    st.layered.drawCalls);
    const double speed = glm::length(s.pose.velocity);
    ImGui::Text("position (%.0f, %.0f) m   altitude %.0f m   heading %03.0f   pitch %+.0f   speed %.1f m/s (%.0f kt)",
                s.pose.position.x, s.pose.position.y, s.pose.position.z, s.pose.heading, s.pose.pitch, speed,
                speed * 1.943844);
    ImGui::Text("t %.1f s%s   scene %s (%s)   H: help", s.t, s.followPath ? ", following the path" : "",
                s.options.scene.c_str(), s.sceneStatus.c_str());
    if (!s.sceneError.empty()) {
        ImGui::PushTextWrapPos(ImGui::GetIO().DisplaySize.x * 0.8f);
        ImGui::TextColored(ImVec4(1, 0.35f, 0.3f, 1), "scene not reloaded, last good one kept: %s",
                           s.sceneError.c_str());
        ImGui::PopTextWrapPos();
    }
    ImGui::End();
}

void drawHelp() {
    const ImVec2 size = ImGui::GetIO().DisplaySize;
    ImGui::SetNextWindowPos(ImVec2(size.x * 0.5f, size.y * 0.5f), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
    ImGui::SetNextWindowBgAlpha(0.8f);
    ImGui::Begin("Keys", nullptr, kPanel);
    ImGui::TextUnformatted("nephele fly: keys");
    ImGui::Separator();
    ImGui::TextUnformatted(kHelp);
    ImGui::End();
}

void sunControls(Scene& scene) {
    Vec3& d = scene.sun.direction;
    float elevation = float(glm::degrees(std::asin(std::clamp(d.z, -1.0, 1.0))));
    float azimuth = float(std::fmod(glm::degrees(std::atan2(d.x, d.y)) + 360.0, 360.0));
    const bool a = ImGui::SliderFloat("sun elevation", &elevation, -10.0f, 90.0f, "%.1f deg");
    const bool b = ImGui::SliderFloat("sun azimuth", &azimuth, 0.0f, 360.0f, "%.0f deg from north");
    if (a || b) {
        const double e = glm::radians(double(elevation)), z = glm::radians(double(azimuth));
        d = Vec3(std::sin(z) * std::cos(e), std::cos(z) * std::cos(e), std::sin(e));
    }
}

void layerControls(Scene& scene) {
    static int index = 0;
    if (scene.layers.empty()) return ImGui::TextUnformatted("no layers in this scene");
    index = std::clamp(index, 0, int(scene.layers.size()) - 1);
    if (scene.layers.size() > 1) ImGui::SliderInt("layer", &index, 0, int(scene.layers.size()) - 1);
    Layer& l = scene.layers[index];
    float coverage = float(l.coverage), density = float(l.density), wind[2] = {float(l.wind.x), float(l.wind.y)};
    if (ImGui::SliderFloat("coverage", &coverage, 0.0f, 1.0f)) l.coverage = coverage;
    if (ImGui::SliderFloat("density", &density, 0.0f, 1.0f)) l.density = density;
    if (ImGui::SliderFloat2("wind (m/s, east, north)", wind, -40.0f, 40.0f)) l.wind = Vec2(wind[0], wind[1]);
}

void drawControls(FlyApp::State& s) {
    ImGui::SetNextWindowPos(ImVec2(ImGui::GetIO().DisplaySize.x - 8, 8), ImGuiCond_Always, ImVec2(1, 0));
    ImGui::SetNextWindowBgAlpha(0.75f);
    ImGui::Begin("Live controls (Tab)", nullptr, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove);
    int method = int(s.host->settings().method);
    if (ImGui::Combo("method", &method, "auto\0ellipsoid\0raymarch\0layered\0")) s.host->setMethod(kFlyMethods[method]);
    int order = s.host->order() == CompositeOrder::Weighted ? 1 : 0;
    if (ImGui::Combo("composite", &order, "back to front\0weighted\0"))
        s.host->setOrder(order == 1 ? CompositeOrder::Weighted : CompositeOrder::PerEllipsoid);
    sunControls(s.scene);
    layerControls(s.scene);
    ImGui::TextUnformatted("Edits last until the scene file changes on disk (then it is reloaded).");
    ImGui::End();
}

// The atlas, every layer of the last frame's passes, scaled down so that all fit on the window
// (rgba as the tile pass writes it, opaque).
void drawAtlas(FlyApp::State& s) {
    ImGui::SetNextWindowPos(ImVec2(8, ImGui::GetIO().DisplaySize.y - 8), ImGuiCond_Always, ImVec2(0, 1));
    ImGui::SetNextWindowBgAlpha(0.8f);
    ImGui::Begin("Atlas (F2)", nullptr, kPanel);
    const EllipsoidRenderer* c = s.host->compositor();
    const int passes = c ? std::min(c->atlasSize().z, s.stats.ellipsoids.passes) : 0;
    if (passes == 0) {
        ImGui::TextUnformatted(c ? "atlas: no tiles this frame" : "atlas: this method draws no tiles");
        return ImGui::End();
    }
    const glm::ivec3 size = c->atlasSize();
    const int columns = std::min(passes, std::max(4, int(std::ceil(std::sqrt(passes * 1.5)))));
    const int w = std::clamp(int(ImGui::GetIO().DisplaySize.x * 0.9f) / columns - 8, 32, 200);
    const int h = std::max(1, w * size.y / size.x);
    if (w != s.atlasViewW || h != s.atlasViewH) s.atlasViews.clear(), s.atlasViewW = w, s.atlasViewH = h;
    if (!s.atlasRead) s.atlasRead = Framebuffer::create(), s.atlasDraw = Framebuffer::create();
    GlStateGuard guard;
    resetPassState();
    for (int l = 0; l < passes; ++l) {
        if (int(s.atlasViews.size()) <= l) {
            Texture t = Texture::create(GL_TEXTURE_2D);
            glTextureStorage2D(t.id(), 1, GL_RGBA8, w, h);
            glTextureParameteri(t.id(), GL_TEXTURE_SWIZZLE_A, GL_ONE);
            s.atlasViews.push_back(std::move(t));
        }
        glNamedFramebufferTextureLayer(s.atlasRead.id(), GL_COLOR_ATTACHMENT0, c->atlasTexture(), 0, l);
        glNamedFramebufferReadBuffer(s.atlasRead.id(), GL_COLOR_ATTACHMENT0);
        glNamedFramebufferTexture(s.atlasDraw.id(), GL_COLOR_ATTACHMENT0, s.atlasViews[l].id(), 0);
        glBlitNamedFramebuffer(s.atlasRead.id(), s.atlasDraw.id(), 0, 0, size.x, size.y, 0, 0, w, h,
                               GL_COLOR_BUFFER_BIT, GL_LINEAR);
        if (l % columns != 0) ImGui::SameLine();
        ImGui::BeginGroup();
        ImGui::Text("pass %d", l);
        ImGui::Image(ImTextureID(std::intptr_t(s.atlasViews[l].id())), ImVec2(float(w), float(h)), ImVec2(0, 1),
                     ImVec2(1, 0));
        ImGui::EndGroup();
    }
    check("atlas debug view");
    ImGui::Text("%dx%d, %d pass(es), use %.0f%%", size.x, size.y, passes, 100 * s.stats.ellipsoids.utilisation);
    ImGui::End();
}

ImU32 passColour(int pass) {
    static const ImU32 colours[] = {IM_COL32(255, 230, 0, 255), IM_COL32(0, 230, 255, 255), IM_COL32(255, 80, 200, 255),
                                    IM_COL32(120, 255, 80, 255)};
    return colours[pass % 4];
}

void drawTiles(const FlyApp::State& s) {
    const EllipsoidRenderer* c = s.host->compositor();
    if (!c) return;
    const ImVec2 size = ImGui::GetIO().DisplaySize;
    ImDrawList* dl = ImGui::GetBackgroundDrawList();
    for (const TileDebug& t : c->lastTiles()) {
        const ImVec2 a((t.screen[0] * 0.5f + 0.5f) * size.x, (0.5f - t.screen[3] * 0.5f) * size.y);
        const ImVec2 b((t.screen[2] * 0.5f + 0.5f) * size.x, (0.5f - t.screen[1] * 0.5f) * size.y);
        dl->AddRect(a, b, passColour(t.pass));
    }
}

// A world segment on the window, clipped to the near plane; false when wholly behind it.
bool project(const View& v, Vec3 a, Vec3 b, ImVec2& pa, ImVec2& pb) {
    const double n = v.camera.nearClip;
    double za = glm::dot(a - v.eye, v.forward), zb = glm::dot(b - v.eye, v.forward);
    if (za < n && zb < n) return false;
    if (za < n) a += (b - a) * ((n - za) / (zb - za)), za = n;
    if (zb < n) b += (a - b) * ((n - zb) / (za - zb)), zb = n;
    const ImVec2 size = ImGui::GetIO().DisplaySize;
    auto screen = [&](const Vec3& p, double z) {
        const Vec3 d = p - v.eye;
        return ImVec2(float((glm::dot(d, v.right) / (z * v.tanHalfX) * 0.5 + 0.5) * size.x),
                      float((0.5 - glm::dot(d, v.up) / (z * v.tanHalfY) * 0.5) * size.y));
    };
    pa = screen(a, za), pb = screen(b, zb);
    return true;
}

void line(ImDrawList* dl, const View& v, const Vec3& a, const Vec3& b, ImU32 colour, float width = 1.5f) {
    ImVec2 pa, pb;
    if (project(v, a, b, pa, pb)) dl->AddLine(pa, pb, colour, width);
}

// The near LOD's cells on their layers' base (green: a cumulus, grey: none, yellow: fading in
// the blend band), and the band's inner and outer circles around the eye (red, orange).
void drawCells(const FlyApp::State& s) {
    const View v = makeView(s.camera);
    ImDrawList* dl = ImGui::GetBackgroundDrawList();
    const double cs = s.host->nearCellSize(), r0 = s.host->nearRadius(), r1 = r0 + s.host->blendBand();
    for (const NearCell* c : s.host->nearCells()) {
        const Layer& layer = s.scene.layers.at(c->layer);
        const Vec2 shift = layer.wind * s.t;
        const double z = layer.base, x0 = double(c->i) * cs + shift.x, y0 = double(c->j) * cs + shift.y;
        const double d = glm::length(c->spawn + shift - Vec2(v.eye));
        const ImU32 colour = c->cover <= 0 ? IM_COL32(160, 160, 160, 160)
                             : d > r0      ? IM_COL32(255, 220, 0, 230)
                                           : IM_COL32(60, 255, 90, 230);
        const Vec3 p[4] = {{x0, y0, z}, {x0 + cs, y0, z}, {x0 + cs, y0 + cs, z}, {x0, y0 + cs, z}};
        for (int k = 0; k < 4; ++k) line(dl, v, p[k], p[(k + 1) % 4], colour);
    }
    for (const Layer& layer : s.scene.layers) {
        if (!layer.nearLod || r1 <= 0) continue;
        for (int k = 0; k < 96; ++k) {
            const double a0 = 2 * std::numbers::pi * k / 96, a1 = 2 * std::numbers::pi * (k + 1) / 96;
            for (const auto& [r, colour] :
                 {std::pair{r0, IM_COL32(255, 60, 40, 255)}, std::pair{r1, IM_COL32(255, 150, 0, 255)}})
                line(dl, v, Vec3(v.eye.x + r * std::sin(a0), v.eye.y + r * std::cos(a0), layer.base),
                     Vec3(v.eye.x + r * std::sin(a1), v.eye.y + r * std::cos(a1), layer.base), colour, 2.0f);
        }
    }
}
}  // namespace

void drawOverlay(FlyApp::State& s) {
    if (s.views.tiles) drawTiles(s);
    if (s.views.cells) drawCells(s);
    if (s.views.hud) drawHud(s);
    if (s.views.atlas) drawAtlas(s);
    if (s.views.controls) drawControls(s);
    if (s.views.help) drawHelp();
}

}  // namespace nephele::fly
