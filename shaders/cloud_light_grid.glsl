// The clouds' radiance grids on the GPU (nephele/cloud_light_textures.hpp fills them): four
// RGBA16F 3D textures holding every cloud's grid in a slot of its own, a fifth (R16F) holding
// its sun transmittance T^p on a grid lightSunRefinement times finer per axis in the same slot
// scaled so, and per cloud three vec4 in a storage buffer: (grid min - eye (m), 0), (1 / grid
// extent (1/m), 1 / p), (the slot's first texel, the grid's voxels per side: a slot holds the
// largest grid, a smaller one its corner). Read with GL_LINEAR, clamped to the slot's outermost
// voxel centres, as sampleRadiance() reads them on the CPU.
// The buffer's binding point is CloudLightTextures::kBoxesBinding, set on the program by bind().
layout(std430) readonly buffer CloudLightBoxes { vec4 cloudLightBoxes[]; };
// lightSunFew: (phi1 xyz, phi0) of the sun's light scattered 1..kFewScatterings times, per unit irradiance.
uniform sampler3D lightSunFew;
uniform sampler3D lightSunMany;     // the same of the sun's light scattered more often
uniform sampler3D lightSkyTau;      // (sky fluence rgb, unused)
uniform sampler3D lightSkyFlux;     // (net flux of the sky light's luminance, its c20)
uniform sampler3D lightSunTransmittance;  // exp(-p tauSun), interpolated as that (CloudRadiance::sunPower)
uniform float lightSunRefinement;   // kSunRefinement: its texels per axis per texel of the others
uniform vec3 lightInvTexels;        // 1 / the four textures' size in texels

// Where camera-relative point `rel` of cloud `cloud` is read: xyz in the four textures, and in
// the sun's (each clamped to its grid's outermost voxel centres).
struct LightTexels {
    vec3 uvw, sun;
    float invSunPower;  // 1 / p: the sun's texture holds T^p (CloudRadiance::sunPower)
};
LightTexels lightTexels(int cloud, vec3 rel) {
    vec3 u = (rel - cloudLightBoxes[3 * cloud].xyz) * cloudLightBoxes[3 * cloud + 1].xyz;
    vec4 slot = cloudLightBoxes[3 * cloud + 2];
    float fine = lightSunRefinement * slot.w;
    LightTexels t;
    t.uvw = (clamp(u * slot.w, vec3(0.5), vec3(slot.w - 0.5)) + slot.xyz) * lightInvTexels;
    t.sun = (clamp(u * fine, vec3(0.5), vec3(fine - 0.5)) + lightSunRefinement * slot.xyz) * lightInvTexels /
            lightSunRefinement;
    t.invSunPower = cloudLightBoxes[3 * cloud + 1].w;
    return t;
}
// The optical depth to the sun: the sun's texture holds T^p, so that it is interpolated as that
// (sampleRadiance() on the CPU).
float sunDepthAt(LightTexels t) {
    return -log(max(textureLod(lightSunTransmittance, t.sun, 0.0).r, kMinSunTransmittance)) * t.invSunPower;
}
// (sky fluence rgb, optical depth to the sun).
vec4 skyTauAt(LightTexels t) { return vec4(textureLod(lightSkyTau, t.uvw, 0.0).rgb, sunDepthAt(t)); }
// The grids of cloud `cloud` at camera-relative point `rel`, as sampleRadiance() reads them on
// the CPU (RadianceSample, nephele/cloud_radiance.hpp) but for skyTau.w, left as the texture's
// (unused: the sun's transmittance is read on its own, gridSunTransmittance).
struct RadianceSample {
    vec4 sunFew, sunMany, skyTau, skyFlux;
};
RadianceSample gridSample(int cloud, vec3 rel) {
    LightTexels t = lightTexels(cloud, rel);
    RadianceSample g;
    g.sunFew = textureLod(lightSunFew, t.uvw, 0.0);
    g.sunMany = textureLod(lightSunMany, t.uvw, 0.0);
    g.skyTau = textureLod(lightSkyTau, t.uvw, 0.0);
    g.skyFlux = textureLod(lightSkyFlux, t.uvw, 0.0);
    return g;
}
float gridSunTransmittance(int cloud, vec3 rel) {
    return exp(-sunDepthAt(lightTexels(cloud, rel)));
}
vec3 cloudLightAt(int cloud, vec3 rel, vec3 d, vec3 sunDirection, float g) {
    LightTexels t = lightTexels(cloud, rel);
    return lightScalars(textureLod(lightSunFew, t.uvw, 0.0), textureLod(lightSunMany, t.uvw, 0.0), skyTauAt(t),
                        textureLod(lightSkyFlux, t.uvw, 0.0), d, sunDirection, g);
}

// S(x, d) of cloud `cloud` at camera-relative point `rel` (cloud_light.glsl), the sky light
// coloured by the fluence's own colour there.
vec3 cloudSourceAt(int cloud, vec3 rel, vec3 d, vec3 sunDirection, float g, vec3 sunIrradiance, float albedo) {
    LightTexels t = lightTexels(cloud, rel);
    vec4 skyTau = skyTauAt(t);
    vec3 scalars = lightScalars(textureLod(lightSunFew, t.uvw, 0.0), textureLod(lightSunMany, t.uvw, 0.0), skyTau,
                                textureLod(lightSkyFlux, t.uvw, 0.0), d, sunDirection, g);
    return sourceFromScalars(scalars, sunIrradiance, skyChroma(skyTau.rgb), albedo);
}

// The mean light scalars of an ellipsoid's chord beyond tStart (as chordLight() in gardner.cpp):
// the ray o' + t d' in its unit space, d its unit camera-relative direction, sigma its extinction.
vec2 chordLightAt(int cloud, vec3 oUnit, vec3 dUnit, vec3 d, float tStart, float sigma, vec3 sunDirection, float g) {
    vec2 sum = vec2(0.0);
    for (int k = 0; k < kChordSamples; ++k) {
        float t = chordSampleDepth(oUnit, dUnit, tStart, sigma, chordShare(k));
        sum += chordWeight(k) * cloudLightAt(cloud, t * d, d, sunDirection, g).xy;
    }
    return sum;
}
