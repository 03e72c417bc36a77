// The light on an object among the clouds (object_light "all"; docs/light.md, "Objects lit by the
// clouds"): ONE source compiled as GLSL by object.frag and as C++ by ObjectLightPass::lightAt
// (model/src/object_light_pass.cpp: what a host lights its own aircraft by), which
// ObjectLightGLTest holds to the objects the compositor draws. After gardner_model.glsl (the
// irradiance formulas of cloud_light.glsl); same subset and MODEL_FN prefix.
//
// A cloud's grid is CLOUD_GRID, read by two functions each side defines: gridSample(grid, p)
// (a RadianceSample: the four grids' values at p; skyTau's xyz only are read here) and
// gridSunTransmittance(grid, p), p in the frame of the point and box given to addCloudLight().
// GLSL: a cloud's index into cloud_light_grid.glsl's buffers, p relative to the eye.
#ifndef CLOUD_GRID
#define CLOUD_GRID int
#endif

// The light on a surface at a point, of unit normal n, summed cloud by cloud: the open sky's
// (openSkyLight), then each cloud's grid's change to it (addCloudLight).
struct ObjectIrradiance {
    vec3 n;
    vec3 s;               // unit, towards the sun
    vec3 invS;            // 1 / s, without infinities times zero (the slab test's)
    vec3 open;            // the open sky's irradiance (no cloud)
    float transmittance;  // the sun's, through the clouds
    float sunDiffuse;     // the sun's light the clouds scatter onto the surface, per unit of its irradiance
    vec3 sky;             // the sky's and the ground's, through the clouds and scattered by them
};

MODEL_FN ObjectIrradiance openSkyLight(vec3 zenith, vec3 horizon, vec3 ground, vec3 n, vec3 s) {
    ObjectIrradiance l;
    l.n = n;
    l.s = s;
    l.invS = 1.0f / (s + vec3(equal(s, vec3(0.0f))) * 1e-9f);
    l.open = openSkyIrradiance(zenith, horizon, ground, n);
    l.transmittance = 1.0f;
    l.sunDiffuse = 0.0f;
    l.sky = l.open;
    return l;
}

// One cloud's grid, over the box [lo, lo + extent], at point p (p and lo in the same frame).
MODEL_FN ObjectIrradiance addCloudLight(ObjectIrradiance l, CLOUD_GRID grid, vec3 p, vec3 lo, vec3 extent) {
    vec3 hi = lo + extent;
    // The sun's transmittance through this cloud (boxEntry), 1 if the ray misses its box.
    float tIn = boxEntry(p, l.invS, lo, hi);
    if (tIn >= 0.0f) l.transmittance *= gridSunTransmittance(grid, p + tIn * l.s);
    // Its diffuse light, faded away from the box.
    float fade = gridFade(length(p - clamp(p, lo, hi)), (extent.x + extent.y + extent.z) / 6.0f);
    if (fade < 1e-3f) return l;
    RadianceSample g = gridSample(grid, p);
    vec2 e = gridIrradiance(g.sunFew, g.sunMany, g.skyTau, g.skyFlux, l.n);
    l.sunDiffuse += fade * e.x;
    l.sky += fade * (skyChroma(vec3(g.skyTau.x, g.skyTau.y, g.skyTau.z)) * e.y - l.open);
    return l;
}

// The irradiance (W/m^2 per unit of the scene's radiance scale, linear RGB) from the sun's beam,
// and the rest (SurfaceLight's sun and diffuse), sunIrradiance = sun.color * sun.intensity.
MODEL_FN vec3 objectSunIrradiance(ObjectIrradiance l, vec3 sunIrradiance) {
    return sunIrradiance * (max(dot(l.n, l.s), 0.0f) * l.transmittance);
}
MODEL_FN vec3 objectDiffuseIrradiance(ObjectIrradiance l, vec3 sunIrradiance) {
    return sunIrradiance * l.sunDiffuse + max(l.sky, vec3(0.0f));
}
