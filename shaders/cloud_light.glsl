// Nephele's light model of cloud matter, part of the one model source gardner_model.glsl
// (which includes this file at its end): compiled as GLSL by the compositor's tile pass and
// the ray-marcher and as C++ with glm by gardner-exact and the tests (nephele/gardner_model.hpp,
// namespace nephele::model), so that every method lights the clouds alike. Same subset and
// MODEL_FN prefix as gardner_model.glsl. The grids it reads are made by
// ellipsoid/src/cloud_radiance.cpp (see nephele/cloud_radiance.hpp).
//
// The source function (radiance per unit of extinction sent towards the eye; a ray's radiance
// is the integral of T sigma_t S along it, plus T times what is behind):
//   S(x, d) = albedo * [ E (p(d . s) exp(-tauSun(x)) + J_sun(x, d)) + J_sky(x, d) ]
// d: the view ray's unit direction (from the eye); s: unit, towards the sun; E = sun.color *
// sun.intensity; p: the medium's Henyey-Greenstein phase (asymmetry g); tauSun: the optical
// depth to the sun. J_sun and J_sky: the in-scattering of the light already scattered in the
// cloud (the sun's, per unit irradiance) and of the sky's and the ground's light (scattered or
// not), from their angular moments on the grid:
// - the sun's diffuse light is strongly forward-peaked: taken as a Henyey-Greenstein lobe of
//   mean cosine |phi1| / phi0 about its net flux phi1; HG convolved with HG is exactly HG with
//   the product of the asymmetries (their Legendre coefficients g^l multiply), so
//   J_sun = phi0 HG(-d . m; g |phi1| / phi0);
// - the sky's light is broad (bright towards the horizon, dark below it): its luminance by its
//   spherical harmonics l = 0, 1 and the zonal l = 2 term, each band scaled by g^l (Funk-Hecke),
//   coloured by the local fluence's colour.
// Measured against path-traced components on the shared scenes (README, "The light"): the lobe
// beats low-order harmonics for the sun's light (which they smear backwards), the harmonics
// beat the lobe for the sky's (which a lobe about "down" makes too dark at the horizon).

const float kLightPi = 3.14159265f;
const vec3 kLuminance = vec3(0.2126f, 0.7152f, 0.0722f);

// Henyey-Greenstein, per steradian; cosTheta between the light's travel and the scattered ray.
MODEL_FN float hgPhase(float cosTheta, float g) {
    float g2 = g * g;
    float d = max(1.0f + g2 - 2.0f * g * cosTheta, 1e-6f);
    return (1.0f - g2) / (4.0f * kLightPi * d * sqrt(d));
}

// Single scattering of the sun per unit irradiance: p(d . s) exp(-tauSun).
MODEL_FN float singleScatter(vec3 d, vec3 sunDirection, float g, float tauSun) {
    return hgPhase(dot(d, sunDirection), g) * exp(-tauSun);
}

// J_sun per unit irradiance. sunDiffuse = (phi1 xyz, phi0).
MODEL_FN float sunInScatter(vec4 sunDiffuse, vec3 d, float g) {
    float phi0 = sunDiffuse.w;
    vec3 phi1 = vec3(sunDiffuse.x, sunDiffuse.y, sunDiffuse.z);
    float f = length(phi1);
    if (phi0 <= 0.0f) return 0.0f;
    if (f <= 1e-6f * phi0) return phi0 / (4.0f * kLightPi);
    return phi0 * hgPhase(-dot(d, phi1) / f, g * min(f / phi0, 0.999f));
}

// The luminance of J_sky: phi0 / 4 pi + g 3 / (4 pi) phi1 . o + g^2 c20 Y20(o), o = -d the
// direction the light leaves towards the eye, Y20(o) = sqrt(5 / 16 pi) (3 o_z^2 - 1).
// skyFlux = (phi1 of the luminance xyz, c20 = its integral against Y20).
MODEL_FN float skyInScatterLuminance(float phi0, vec4 skyFlux, vec3 d, float g) {
    vec3 o = -d;
    vec3 phi1 = vec3(skyFlux.x, skyFlux.y, skyFlux.z);
    float j = phi0 / (4.0f * kLightPi) + g * 0.2387324f * dot(phi1, o) +
              g * g * skyFlux.w * 0.3153916f * (3.0f * o.z * o.z - 1.0f);
    return max(j, 0.0f);
}

// The sky's fluence colour scaled to unit luminance (white where there is none).
MODEL_FN vec3 skyChroma(vec3 skyFluence) {
    float l = dot(skyFluence, kLuminance);
    return l > 0.0f ? skyFluence / l : vec3(1.0f, 1.0f, 1.0f);
}

// The two scalars a point contributes per unit of the sun's irradiance and of the sky's
// chroma: (single + J_sun, luminance of J_sky). The grid's three texels at the point:
// sunDiffuse = (phi1, phi0) of the sun's light, skyTau = (sky fluence rgb, tauSun),
// skyFlux = (phi1 of the sky's luminance, c20).
MODEL_FN vec3 lightScalars(vec4 sunDiffuse, vec4 skyTau, vec4 skyFlux, vec3 d, vec3 sunDirection, float g) {
    float sun = singleScatter(d, sunDirection, g, skyTau.w) + sunInScatter(sunDiffuse, d, g);
    float sky = skyInScatterLuminance(dot(vec3(skyTau.x, skyTau.y, skyTau.z), kLuminance), skyFlux, d, g);
    return vec3(sun, sky, 0.0f);
}

// S(x, d) from the scalars: albedo (E sun + chroma sky).
MODEL_FN vec3 sourceFromScalars(vec3 scalars, vec3 sunIrradiance, vec3 chroma, float albedo) {
    return albedo * (sunIrradiance * scalars.x + chroma * scalars.y);
}

// ---- Along one ellipsoid's chord (the compositor and gardner-exact shade each ellipsoid by
// its own chord; the ray-marcher integrates instead). The radiance the chord sends to the eye
// is its opacity times the mean of S weighted by T sigma_t, T the transmittance from the
// chord's start: estimated by kChordSamples points, each at the middle of an equal share of
// that weight, where the optical depth from the start reaches -ln(1 - (k + 1/2) alpha / K).
const int kChordSamples = 3;

// The distance along the ray (m) of sample k (0 <= k < samples) of an ellipsoid's chord beyond
// tStart; the ray is o' + t d' in the ellipsoid's unit space, sigma its extinction (1/m). The
// primitive is monotone on the chord: bisection, 20 halvings (the chord to 1e-6 of its length).
MODEL_FN float chordSampleDepth(vec3 oUnit, vec3 dUnit, float tStart, float sigma, int k, int samples) {
    float len = length(dUnit);
    vec3 dn = dUnit / len;
    float tc = -dot(oUnit, dn);
    vec3 perp = oUnit + tc * dn;
    float h2 = 1.0f - dot(perp, perp);
    if (h2 <= 0.0f) return max(tc / len, tStart);
    float h = sqrt(h2);
    float u0 = clamp(tStart * len - tc, -h, h);
    float p0 = chordPrimitive(u0, h2);
    float whole = (chordPrimitive(h, h2) - p0) / len;  // m of (1 - q)^2: the chord's depth / sigma
    float share = (float(k) + 0.5f) / float(samples);
    float alpha = 1.0f - exp(-sigma * whole);
    float target = (alpha < 1e-4f ? share * whole : -log(1.0f - share * alpha) / sigma) * len;
    float lo = u0, hi = h;
    for (int i = 0; i < 20; ++i) {
        float mid = 0.5f * (lo + hi);
        if (chordPrimitive(mid, h2) - p0 < target) lo = mid;
        else hi = mid;
    }
    return (0.5f * (lo + hi) + tc) / len;
}
