// Objects lit by the clouds in the compositor (model/internal/object_light_pass.hpp).
#include "compositor_impl.hpp"

namespace nephele {

void EllipsoidRenderer::Impl::drawLitObjects(const Scene& scene, const View& view, const HostFrame& frame) {
    lightTextures.setBoxes(light, view.eye);
    objectLight.draw(scene, view, frame, lightTextures, light);
}

SurfaceLight EllipsoidRenderer::lightAt(const Scene& scene, const Vec3& point, const Vec3& normal) const {
    return ObjectLightPass::lightAt(scene, impl_->light, point, normal);
}

}  // namespace nephele
