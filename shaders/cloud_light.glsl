// Nephele's light model of cloud matter, part of the one model source gardner_model.glsl
// (which includes this file at its end): compiled as GLSL by the compositor's tile pass and
// the ray-marcher and as C++ with glm by gardner-exact and the tests (nephele/gardner_model.hpp,
// namespace nephele::model), so that every method lights the clouds alike. Same subset and
// MODEL_FN prefix as gardner_model.glsl. The grids it reads are made by
// model/src/cloud_radiance.cpp (see nephele/cloud_radiance.hpp).
//
// The source function (radiance per unit of extinction sent towards the eye; a ray's radiance
// is the integral of T sigma_t S along it, plus T times what is behind):
//   S(x, d) = albedo * [ E (p(d . s) exp(-tauSun(x)) + J_few(x, d) + J_many(x, d)) + J_sky(x, d) ]
// d: the view ray's unit direction (from the eye); s: unit, towards the sun; E = sun.color *
// sun.intensity; p: the medium's Henyey-Greenstein phase (asymmetry g); tauSun: the optical
// depth to the sun. J_few, J_many and J_sky: the in-scattering of the light already scattered
// in the cloud (the sun's, per unit irradiance) and of the sky's and the ground's light
// (scattered or not), from their angular moments on the grid:
// - the sun's diffuse light, in two parts by how often it has scattered in the cloud:
//   - J_few, scattered 1 to kFewScatterings times: sharply forward-peaked, taken as a
//     Henyey-Greenstein lobe of mean cosine |phi1| / phi0 about its net flux phi1; HG
//     convolved with HG is exactly HG with the product of the asymmetries (their Legendre
//     coefficients g^l multiply), so J_few = phi0 HG(-d . m; g |phi1| / phi0);
//   - J_many, scattered more often: the diffusion regime, where radiance is its l <= 1
//     harmonics, phi0 / 4 pi + 3 / (4 pi) phi1 . w (Eddington), and its in-scattering the
//     same with the l = 1 band scaled by g (Funk-Hecke).
//   One lobe for all the diffuse light could not hold both shapes: at the cloud's surface the
//   many-times scattered light leaves in a broad half-space, which a lobe of its mean cosine
//   makes 2-4x too bright along the normal; finer grids resolved that surface and got worse
//   (a cumulus seen from 600 m: 15% off at 16^3, 21% at 32^3; with the two parts 10-11% at
//   16^3 to 48^3, with as many photons per voxel: README "The light");
// - the sky's light is broad (bright towards the horizon, dark below it): its luminance by its
//   spherical harmonics l = 0, 1 and the zonal l = 2 term, each band scaled by g^l (Funk-Hecke),
//   coloured by the local fluence's colour.
// Measured against path-traced components on the shared scenes (README, "The light"): a lobe
// beats low-order harmonics for the sun's few-times scattered light (which they smear
// backwards), the harmonics beat a lobe for its many-times scattered light (above) and for
// the sky's (which a lobe about "down" makes too dark at the horizon).

const float kLightPi = 3.14159265f;
const vec3 kLuminance = vec3(0.2126f, 0.7152f, 0.0722f);

// Henyey-Greenstein, per steradian; cosTheta between the light's travel and the scattered ray.
MODEL_FN float hgPhase(float cosTheta, float g) {
    float g2 = g * g;
    float d = max(1.0f + g2 - 2.0f * g * cosTheta, 1e-6f);
    return (1.0f - g2) / (4.0f * kLightPi * d * sqrt(d));
}

// A radiance grid's sun transmittance is interpolated between voxel centres as a transmittance,
// not as an optical depth: across a lit surface the optical depth jumps from 0 to many within
// a voxel, and its interpolation darkened the single scattering of what the eye sees there
// (cumulus27 at 32^3: 0.91 of the path tracer's; as a transmittance 1.01). The GPU stores it in
// RGBA16F: this floor (optical depth 18.4) keeps its logarithm finite.
const float kMinSunTransmittance = 1e-8f;

// Single scattering of the sun per unit irradiance: p(d . s) exp(-tauSun).
MODEL_FN float singleScatter(vec3 d, vec3 sunDirection, float g, float tauSun) {
    return hgPhase(dot(d, sunDirection), g) * exp(-tauSun);
}

// J_few per unit irradiance. lobe = (phi1 xyz, phi0).
MODEL_FN float sunInScatter(vec4 lobe, vec3 d, float g) {
    float phi0 = lobe.w;
    vec3 phi1 = vec3(lobe.x, lobe.y, lobe.z);
    float f = length(phi1);
    if (phi0 <= 0.0f) return 0.0f;
    if (f <= 1e-6f * phi0) return phi0 / (4.0f * kLightPi);
    return phi0 * hgPhase(-dot(d, phi1) / f, g * min(f / phi0, 0.999f));
}

// J_many per unit irradiance: the in-scattering of a radiance field phi0 / 4 pi + 3 / (4 pi)
// phi1 . w, lobe = (phi1 xyz, phi0); o = -d the direction the light leaves towards the eye.
// Not negative where the flux outweighs the fluence (|phi1| > phi0 / 3 g, at the surface).
MODEL_FN float sunDiffuseInScatter(vec4 lobe, vec3 d, float g) {
    vec3 phi1 = vec3(lobe.x, lobe.y, lobe.z);
    return max(lobe.w / (4.0f * kLightPi) - g * 0.2387324f * dot(phi1, d), 0.0f);
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
// chroma: (single + J_few + J_many, luminance of J_sky). The grid's four texels at the point:
// sunFew, sunMany = (phi1, phi0) of the sun's light in its two parts, skyTau = (sky fluence
// rgb, tauSun), skyFlux = (phi1 of the sky's luminance, c20).
MODEL_FN vec3 lightScalars(vec4 sunFew, vec4 sunMany, vec4 skyTau, vec4 skyFlux, vec3 d, vec3 sunDirection, float g) {
    float sun = singleScatter(d, sunDirection, g, skyTau.w) + sunInScatter(sunFew, d, g) +
                sunDiffuseInScatter(sunMany, d, g);
    float sky = skyInScatterLuminance(dot(vec3(skyTau.x, skyTau.y, skyTau.z), kLuminance), skyFlux, d, g);
    return vec3(sun, sky, 0.0f);
}

// S(x, d) from the scalars: albedo (E sun + chroma sky).
MODEL_FN vec3 sourceFromScalars(vec3 scalars, vec3 sunIrradiance, vec3 chroma, float albedo) {
    return albedo * (sunIrradiance * scalars.x + chroma * scalars.y);
}

// ---- Along one ellipsoid's chord (the compositor and gardner-exact shade each ellipsoid by
// its own chord; the ray-marcher integrates instead). The radiance the chord sends to the eye
// is the integral of S over the opacity seen from the chord's start, from 0 to the chord's
// alpha: estimated by three-point Gauss-Legendre quadrature in that opacity, at the points
// where the opacity in front reaches chordShare(k) alpha, weighted chordWeight(k). It is exact
// for an S that is a polynomial of degree 5 in the opacity. The midpoint rule it replaced
// (three equal shares, each at its middle) is exact for degree 1 only, and the sun's
// transmittance along a chord is curved: with the sun's exact optical depth at every point,
// the single scattering of cumulus27 was 0.948 of the path tracer's by the midpoint rule, 0.970
// by this rule and 0.983 by 48 points.
const int kChordSamples = 3;
MODEL_FN float chordShare(int k) { return k == 0 ? 0.11270167f : (k == 1 ? 0.5f : 0.88729833f); }
MODEL_FN float chordWeight(int k) { return k == 1 ? 0.44444444f : 0.27777778f; }

// The distance along the ray (m) of the point of an ellipsoid's chord beyond tStart where the
// opacity in front reaches `share` (0..1) of the chord's; the ray is o' + t d' in the
// ellipsoid's unit space, sigma its extinction (1/m). The primitive is monotone on the chord:
// bisection, 20 halvings (the chord to 1e-6 of its length).
MODEL_FN float chordSampleDepth(vec3 oUnit, vec3 dUnit, float tStart, float sigma, float share) {
    ChordSpan c = chordBeyond(oUnit, dUnit, tStart);
    if (c.h2 <= 0.0f) return max(c.tc / c.len, tStart);
    float p0 = chordPrimitive(c.u0, c.h2);
    float whole = (chordPrimitive(c.h, c.h2) - p0) / c.len;  // m of (1 - q)^2: the chord's depth / sigma
    float alpha = 1.0f - exp(-sigma * whole);
    float target = (alpha < 1e-4f ? share * whole : -log(1.0f - share * alpha) / sigma) * c.len;
    float lo = c.u0, hi = c.h;
    for (int i = 0; i < 20; ++i) {
        float mid = 0.5f * (lo + hi);
        if (chordPrimitive(mid, c.h2) - p0 < target) lo = mid;
        else hi = mid;
    }
    return (0.5f * (lo + hi) + c.tc) / c.len;
}

// ---- Objects lit by the clouds (object_light "all", data/scene-format.md; docs/light.md,
// "Objects lit by the clouds"). A Lambertian surface of unit normal n at a point x reflects
// albedo / pi times the irradiance E(n) = integral of L_i(x, w) max(n . w, 0) dw over the
// directions w the light comes from. The grids hold the light by its harmonics in the direction
// it travels, v = -w: L(v) = phi0 / 4 pi + 3 / (4 pi) phi1 . v + c20 Y20(v) (+ higher bands). The
// clamped cosine keeps of band l the factor A_l: A0 = pi, A1 = 2 pi / 3, A2 = pi / 4 (Ramamoorthi
// and Hanrahan 2001), so E(n) = pi phi0 / 4 pi - 2 pi / 3 * 3 / (4 pi) phi1 . n + pi / 4 c20 Y20(n)
// (band 1 odd: travelling along -n is arriving from n), that is
//   E(n) = phi0 / 4 - phi1 . n / 2 + (pi / 4) c20 Y20(n).
// Checks: uniform radiance L (phi0 = 4 pi L, phi1 = 0, c20 = 0): E = pi L; a beam of irradiance E0
// onto the surface (phi0 = E0, phi1 = -E0 n): 3/4 E0 from bands 0 and 1, 17/16 E0 with band 2.
// Clamped at 0 (a truncated series can dip below it where little light comes).
const float kY20 = 0.3153916f;  // sqrt(5 / (16 pi)): Y20(w) = kY20 (3 w.z^2 - 1)
MODEL_FN float harmonicIrradiance(float phi0, vec3 phi1, float c20, vec3 n) {
    float y20 = kY20 * (3.0f * n.z * n.z - 1.0f);
    return max(0.25f * phi0 - 0.5f * dot(phi1, n) + 0.7853982f * c20 * y20, 0.0f);
}

// The irradiance of a Henyey-Greenstein lobe (J_few's shape: fluence phi0, net flux phi1, mean
// cosine |phi1| / phi0 about m = phi1 / |phi1|), to band 2: its band-l coefficients are phi0 (2l +
// 1) / (4 pi) g^l P_l(v . m), so E(n) = phi0 (1/4 - g (m . n) / 2 + 5/16 g^2 P2(m . n)), P2(c) =
// (3 c^2 - 1) / 2. Band 2 matters for a sharp lobe: a beam onto the surface gets 17/16 of its
// irradiance with it, 3/4 without; a beam along the surface 0.09 with it, 0.25 without (exact: 0).
MODEL_FN float lobeIrradiance(vec4 lobe, vec3 n) {
    float phi0 = lobe.w;
    vec3 phi1 = vec3(lobe.x, lobe.y, lobe.z);
    float f = length(phi1);
    if (phi0 <= 0.0f) return 0.0f;
    float c = f > 1e-6f * phi0 ? dot(phi1, n) / f : 0.0f;
    float g = min(f / phi0, 1.0f);
    return max(phi0 * (0.25f - 0.5f * g * c + 0.15625f * g * g * (3.0f * c * c - 1.0f)), 0.0f);
}

// One cloud's grid at a point, as an object's light: (the irradiance of the sun's light scattered
// in the cloud per unit of the sun's irradiance, the luminance irradiance of the sky's and the
// ground's light there, seen through the cloud and scattered by it); texels as lightScalars().
MODEL_FN vec2 gridIrradiance(vec4 sunFew, vec4 sunMany, vec4 skyTau, vec4 skyFlux, vec3 n) {
    float sun =
        lobeIrradiance(sunFew, n) + harmonicIrradiance(sunMany.w, vec3(sunMany.x, sunMany.y, sunMany.z), 0.0f, n);
    float skyPhi0 = dot(vec3(skyTau.x, skyTau.y, skyTau.z), kLuminance);
    float sky = harmonicIrradiance(skyPhi0, vec3(skyFlux.x, skyFlux.y, skyFlux.z), skyFlux.w, n);
    return vec2(sun, sky);
}

// The open sky's irradiance (no cloud) on unit normal n, in closed form from the format's sky
// (horizon + (zenith - horizon) max(w.z, 0) above, ground below): a uniform upper hemisphere
// gives pi (1 + n.z) / 2, the lower pi (1 - n.z) / 2, and the integral of max(w.z, 0) max(w . n, 0)
// over the sphere is 2/3 ((pi - a) cos a + sin a), a the angle between n and the zenith
// (2 pi / 3 facing up, 2/3 sideways, 0 facing down).
MODEL_FN vec3 openSkyIrradiance(vec3 zenith, vec3 horizon, vec3 ground, vec3 n) {
    float c = clamp(n.z, -1.0f, 1.0f);
    float a = acos(c);
    float lobe = 0.6666667f * ((kLightPi - a) * c + sqrt(max(1.0f - c * c, 0.0f)));
    return horizon * (0.5f * kLightPi * (1.0f + c)) + (zenith - horizon) * lobe +
           ground * (0.5f * kLightPi * (1.0f - c));
}

// How much of a cloud's grid (its light there minus the open sky's) an object at `outside` m
// from the grid's box keeps: 1 inside the box, then (R / (R + outside))^2, R half the box's mean
// side: the solid angle of a body of radius R seen from R + outside from its centre, relative to
// that at its surface. The grid holds the light inside its box only; outside, its edge's light
// fades as the cloud shrinks in the sky (an approximation: the light at the edge stands for the
// cloud's whole glow).
MODEL_FN float gridFade(float outside, float radius) {
    float k = radius / (radius + max(outside, 0.0f));
    return k * k;
}

// Smits' slab test of the ray t d from the origin against the box [lo, hi]: the ray's [t0, t1]
// inside it (empty when t0 > t1); invDir = 1 / d with d's zero components nudged off zero (no
// infinity times zero).
MODEL_FN vec2 boxSlab(vec3 lo, vec3 hi, vec3 invDir) {
    vec3 a = lo * invDir, b = hi * invDir;
    vec3 tLo = min(a, b), tHi = max(a, b);
    return vec2(max(max(tLo.x, tLo.y), tLo.z), min(min(tHi.x, tHi.y), tHi.z));
}

// Where the ray p + t s (t >= 0) enters the box [lo, hi], or -1 if it misses it (boxSlab; invS
// as its invDir). A cloud's grid holds all its matter, so the grid's sun transmittance where the
// ray towards the sun enters it is the transmittance from p, wherever p is.
MODEL_FN float boxEntry(vec3 p, vec3 invS, vec3 lo, vec3 hi) {
    vec2 t = boxSlab(lo - p, hi - p, invS);
    float tIn = max(t.x, 0.0f);
    return tIn <= t.y ? tIn : -1.0f;
}
