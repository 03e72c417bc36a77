// The layered sky's light (issue #10): ONE source compiled as GLSL by layered_cloud.frag and as
// C++ (layered/src/layer_model.hpp) by the precomputation and the tests, after
// gardner_model.glsl (whose cloud_light.glsl lights every other method: the same source
// function is used here). Same subset and MODEL_FN prefix as gardner_model.glsl.
//
// A fragment of the layer at point x, seen along d, sends S(x, d) per unit opacity, with the
// shared source function (cloud_light.glsl)
//   S = albedo [ E (p(d . s) exp(-tauSun) + J_sun) + J_sky ]
// where the layer's own statistics stand in for a cloud's radiance grid:
// - tauSun = tauAbove / s_z, the optical depth of the column above x along the sun's slant;
// - J_sun and J_sky from the mean diffuse light of points of the layer with the same optical
//   depth above and below them in their column (tauAbove, tauBelow), photon-traced through
//   the lighting volume's density with the medium's physics (layered/src/layer_light.cpp).
// The column depths come from the lighting volume's rgb: the optical depth from x up to the
// layer's top per unit density D, at the thresholds theta_k = 0.25, 0.5, 0.75 of eq. (16)
// (D max(A - theta, 0)), encoded as exp(-tau / kLayerTauScale); at a fragment's own threshold
// theta = r + 1 - C they are interpolated (0 at theta = 1, where no A <= 1 has matter).

const vec3 kLayerKnots = vec3(0.25f, 0.5f, 0.75f);  // the thresholds theta_k of the knots
const float kLayerTauScale = 4.0f;    // encoding of the knots: e = exp(-tau / scale)
const float kLayerTableTau = 2.0f;    // table coordinate u = tau / (tau + kLayerTableTau)

MODEL_FN float decodeLayerTau(float e) { return -kLayerTauScale * log(max(e, 0.001953125f)); }
MODEL_FN float encodeLayerTau(float tau) { return exp(-tau / kLayerTauScale); }

// The optical depth per unit D at threshold theta from the knots' (theta 0.25, 0.5, 0.75; 0 at
// 1): piecewise linear, continued below 0.25 with the first piece's slope.
MODEL_FN float tauAtThreshold(vec3 knots, float theta) {
    vec3 k = kLayerKnots;
    if (theta >= 1.0f) return 0.0f;
    if (theta >= k.z) return knots.z * (1.0f - theta) / (1.0f - k.z);
    if (theta >= k.y) return knots.y + (knots.z - knots.y) * (theta - k.y) / (k.z - k.y);
    return max(knots.x + (knots.y - knots.x) * (theta - k.x) / (k.y - k.x), 0.0f);
}

// The column's optical depths (above, below) at a fragment: encoded knots above it and of its
// whole column, the fragment's threshold theta and density D.
MODEL_FN vec3 layerColumnDepths(vec3 encodedAbove, vec3 encodedColumn, float theta, float density) {
    vec3 above = vec3(decodeLayerTau(encodedAbove.x), decodeLayerTau(encodedAbove.y), decodeLayerTau(encodedAbove.z));
    vec3 column =
        vec3(decodeLayerTau(encodedColumn.x), decodeLayerTau(encodedColumn.y), decodeLayerTau(encodedColumn.z));
    float a = density * tauAtThreshold(above, theta);
    float c = density * tauAtThreshold(column, theta);
    return vec3(a, max(c - a, 0.0f), 0.0f);
}

MODEL_FN float layerTableCoord(float tau) { return tau / (tau + kLayerTableTau); }

// S(x, d) of the layer from the light tables read at (layerTableCoord(above),
// layerTableCoord(below)): sunTable = (phi0, phi1 along the sun's horizontal direction, phi1 z
// of the sun's light scattered 1 to kFewScatterings times, per unit irradiance; c20 of the
// sky's luminance), sunManyTable = the same (phi0, phi1 x, phi1 z, 0) of the rest, skyTable = (the
// sky's and the ground's fluence rgb, phi1 z of its luminance); sunHorizontal = the sun's
// horizontal unit direction; tauSun = the column's depth on the sun's side over |s_z|.
// A sun table's node as a lobe for lightScalars(): (phi1 xyz, phi0), its horizontal flux along
// the sun's horizontal direction.
MODEL_FN vec4 sunTableLobe(vec4 table, vec3 sunHorizontal) {
    return vec4(sunHorizontal.x * table.y, sunHorizontal.y * table.y, table.z, table.x);
}

MODEL_FN vec3 layerSource(vec4 sunTable, vec4 sunManyTable, vec4 skyTable, float tauSun, vec3 d, vec3 sunDirection,
                          vec3 sunHorizontal, float g, vec3 sunIrradiance, float albedo) {
    vec4 sunFew = sunTableLobe(sunTable, sunHorizontal), sunMany = sunTableLobe(sunManyTable, sunHorizontal);
    vec4 skyTau = vec4(skyTable.x, skyTable.y, skyTable.z, tauSun);
    vec4 skyFlux = vec4(0.0f, 0.0f, skyTable.w, sunTable.w);
    // The sun's diffuse light in the two parts of the clouds' (cloud_light.glsl): a forward lobe
    // of the few-times scattered, the diffusion regime's l <= 1 harmonics of the rest. (One lobe
    // for all of it gave, 100 m under a deck looking up 20 degrees, 0.71 of the path tracer's sun
    // light, 0.60 at 7 degrees up; all of it as harmonics, 1.04 there but 1.12-1.26 in the other
    // views.)
    vec3 scalars = lightScalars(sunFew, sunMany, skyTau, skyFlux, d, sunDirection, g);
    return sourceFromScalars(scalars, sunIrradiance, skyChroma(vec3(skyTable.x, skyTable.y, skyTable.z)), albedo);
}
