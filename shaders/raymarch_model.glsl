// The ray-marcher's light model: ONE source compiled as GLSL by shaders/raymarch.frag and as
// C++ (with glm) by volume/include/nephele/raymarch_model.hpp, which the tests integrate on
// the CPU. Common subset as in gardner_model.glsl: float and vec3 only, literals with an `f`
// suffix, functions prefixed RM_FN.
//
// Per unit length of the eye ray the marcher adds sigma_s(x) times
//   sunIrradiance * sum_k b^k HG(cos theta, c^k g) exp(-a^k tauSun)      (the sun)
// + mix(ground, skyUpper, wUp(x))                                          (the environment)
// with tauSun the optical depth (sigma_t, not reduced) from x to the sun, cos theta = d . sun.
//
// The sun: octave k = 0 is single scattering with the medium's own phase function; the
// further octaves stand for multiple scattering (Wrenninge, Kulla & Lundqvist 2013, "Oz: the
// great and volumetric", SIGGRAPH talk; Hillaire 2016, "Physically based sky, atmosphere and
// cloud rendering in Frostbite", §5.3): each is a less attenuated (a^k), weaker (b^k), less
// forward-peaked (c^k g) copy of the first. Single scattering alone leaves a cloud lit from the
// side or from above nearly black but for the sky (HG with g = 0.85 sends almost nothing
// sideways), where the path-traced reference shows a bright, nearly isotropic glow.
//
// The environment: sunless light inside a cloud of albedo ~1 tends to the mean of what
// surrounds it (with albedo 1 and a uniform environment it is exactly that: the white
// furnace). A point near the top sees more sky, one near the bottom more ground: with T' the
// similarity-reduced transmittance (extinction sigma_t (1 - albedo g)) straight up and
// straight down, wUp = 1/2 + (T'up - T'down) / 4, from 1/4 (bottom) to 3/4 (top).

// The octave constants (Hillaire's a, b, c; 0 < a, b, c <= 1). b = 1/2 as in both sources. The
// slow attenuation a = 1/4 and the slowly broadening phase c = 0.85 are van de Hulst's
// similarity relation in octave form: light scattered forward keeps its direction, so it
// travels as through a medium of extinction ~ sigma_t (1 - g) (1 - 0.85 = 0.15, 0.25^1..3 =
// 0.25..0.016) and stays forward-peaked. Chosen among (a, c) = (1/2, 1/2), (1/2, 0.85),
// (1/4, 0.85) on tests/calibrate.py's seven views against the path tracer: mean PSNR 29.7,
// 29.2, 31.0 dB; the first loses the back-lit clouds' glow (exposure off by 13-27%).
const float kRmOctaveAttenuation = 0.25f;   // a: optical depth scale per octave
const float kRmOctaveContribution = 0.5f;   // b: weight per octave
const float kRmOctaveEccentricity = 0.85f;  // c: HG asymmetry scale per octave
const int kRmOctaves = 4;

// Henyey-Greenstein, per steradian; cosTheta between the light's travel and the scattered ray.
RM_FN float rmHenyeyGreenstein(float cosTheta, float g) {
    float g2 = g * g;
    float d = max(1.0f + g2 - 2.0f * g * cosTheta, 1e-6f);
    return (1.0f - g2) / (12.5663706f * d * sqrt(d));
}

// The sun's in-scattered radiance per unit sigma_s and per unit irradiance (1/sr).
RM_FN float rmSunPhase(float cosTheta, float g, float tauSun) {
    float sum = 0.0f;
    float weight = 1.0f, depthScale = 1.0f, gk = g;
    for (int k = 0; k < kRmOctaves; ++k) {
        sum += weight * rmHenyeyGreenstein(cosTheta, gk) * exp(-depthScale * tauSun);
        weight *= kRmOctaveContribution;
        depthScale *= kRmOctaveAttenuation;
        gk *= kRmOctaveEccentricity;
    }
    return sum;
}

// The weight of the sky (upper hemisphere) in the environment seen at a point whose reduced
// optical depths straight up and straight down are tauUpReduced and tauDownReduced.
RM_FN float rmSkyWeight(float tauUpReduced, float tauDownReduced) {
    return 0.5f + 0.25f * (exp(-tauUpReduced) - exp(-tauDownReduced));
}

// The whole in-scattered radiance per unit sigma_s: sunIrradiance = sun.color * intensity;
// skyUpper = the sky's mean radiance over the upper hemisphere, (zenith + horizon) / 2;
// ground = sky.ground; reduction = 1 - albedo g.
RM_FN vec3 rmInScatter(vec3 sunIrradiance, vec3 skyUpper, vec3 ground, float cosTheta, float g, float reduction,
                       float tauSun, float tauUp, float tauDown) {
    float w = rmSkyWeight(reduction * tauUp, reduction * tauDown);
    return sunIrradiance * rmSunPhase(cosTheta, g, tauSun) + ground + w * (skyUpper - ground);
}
