// What a weather transition shows (SkyRenderer::update): each layer as itself and the share of
// it drawn, so that a layer fading in or out keeps its own density for the near LOD's cells
// (made once, their weights faded) while the far field draws density x fade. blendWeather
// (nephele/weather.hpp) is this with the fade folded into the density. Internal to layered/ and sky/.
#pragma once

#include "nephele/api.hpp"
#include "nephele/weather.hpp"

#include <map>

NEPHELE_API_BEGIN
namespace nephele {

struct ShownLayer {
    Layer layer;      // unfaded
    double fade = 1;  // [0, 1]: the share drawn (the far field's density x fade, the near clouds' weights x fade)
};

struct ShownWeather {
    Sun sun;
    Sky sky;
    std::map<int, ShownLayer> layers;  // by CIGI layer id: the enabled layers and those fading out
};

// `w`'s sun, sky and enabled layers, each at fade 1.
ShownWeather shownOf(const Weather& w);
// The way from `from` (what is shown, possibly mid-way of another transition) to `to` at s in
// [0, 1] (s >= 1: shownOf(to)), as blendWeather says; a layer fading from `from`'s fade f
// reaches 1 (in `to`) or 0 (not) linearly from f. A layer in `to` is kept at fade 0 (its
// lighting is asked for from the first frame); one only in `from` is dropped at fade 0.
ShownWeather blendShown(const ShownWeather& from, const Weather& to, double s);
// The layers as the far field draws them: density x fade.
Layer farLayer(const ShownLayer& shown);

}  // namespace nephele
NEPHELE_API_END
