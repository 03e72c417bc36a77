// Lambert under the sun, no ambient term (data/scene-format.md, "sun" and "objects"; opaque.glsl).
// SPHERE: the mesh is the sphere's bounding box drawn by its back faces, and each
// fragment ray-casts the exact sphere (exact silhouette and depth, as the CPU reference).
// CLOUD_LIGHT (object_light "all", drawn by the compositor once the clouds' grids are made): the
// object is a Lambertian receiver of all the light (docs/light.md, "Objects lit by the clouds"):
// the sun times its transmittance through the clouds, the open sky's irradiance, and each
// cloud's grid's change to it (what its cloud hides and what it scatters).
#define MODEL_FN
#include "opaque.glsl"
#ifdef CLOUD_LIGHT
#include "gardner_model.glsl"
#include "cloud_light_grid.glsl"
uniform int cloudCount;      // grids in cloudLightBoxes
uniform vec3 sunIrradiance;  // sun.color * sun.intensity
uniform vec3 skyZenith;
uniform vec3 skyHorizon;
uniform vec3 skyGround;
#endif
in vec3 relPosition;
in vec3 worldNormal;
out vec4 color;
uniform vec3 albedo;
uniform vec3 sunDirection;   // unit, towards the sun
uniform vec3 sunRadiance;    // sun.color * sun.intensity / pi
#ifdef SPHERE
uniform vec3 sphereCenter;   // camera-relative, m
uniform float sphereRadius;  // m
uniform mat4 viewProjection;
#endif

#ifdef CLOUD_LIGHT
// The irradiance (W/m^2, linear RGB) on unit normal n at camera-relative point p.
vec3 objectIrradiance(vec3 p, vec3 n) {
    vec3 s = sunDirection;
    // The slab test's 1 / s without infinities times zero.
    vec3 invS = 1.0 / (s + vec3(equal(s, vec3(0.0))) * 1e-9);
    vec3 open = openSkyIrradiance(skyZenith, skyHorizon, skyGround, n);
    vec3 sky = open;
    float sunDiffuse = 0.0, transmittance = 1.0;
    for (int c = 0; c < cloudCount; ++c) {
        vec3 lo = cloudLightBoxes[3 * c].xyz, extent = 1.0 / cloudLightBoxes[3 * c + 1].xyz;
        // The sun's transmittance through this cloud (boxEntry), 1 if the ray misses its box.
        float tIn = boxEntry(p, invS, lo, lo + extent);
        if (tIn >= 0.0) transmittance *= textureLod(lightSunTransmittance, lightTexels(c, p + tIn * s).sun, 0.0).r;
        // Its diffuse light, faded away from the box.
        float outside = length(p - clamp(p, lo, lo + extent));
        float fade = gridFade(outside, (extent.x + extent.y + extent.z) / 6.0);
        if (fade < 1e-3) continue;
        LightTexels t = lightTexels(c, p);
        vec4 skyTau = textureLod(lightSkyTau, t.uvw, 0.0);
        vec2 e = gridIrradiance(textureLod(lightSunFew, t.uvw, 0.0), textureLod(lightSunMany, t.uvw, 0.0), skyTau,
                                textureLod(lightSkyFlux, t.uvw, 0.0), n);
        sunDiffuse += fade * e.x;
        sky += fade * (skyChroma(skyTau.rgb) * e.y - open);
    }
    return sunIrradiance * (max(dot(n, s), 0.0) * transmittance + sunDiffuse) + max(sky, vec3(0.0));
}
#endif

void main() {
#ifdef SPHERE
    vec3 d = normalize(relPosition);
    float b = dot(sphereCenter, d);
    float h = b * b - dot(sphereCenter, sphereCenter) + sphereRadius * sphereRadius;
    if (h < 0.0) discard;
    float t = b - sqrt(h);
    if (t < 0.0) t = b + sqrt(h);  // the eye is inside the sphere: its far side
    vec3 hit = t * d;
    vec3 n = (hit - sphereCenter) / sphereRadius;
    if (dot(n, d) > 0.0) n = -n;
    vec4 clip = viewProjection * vec4(hit, 1.0);
    gl_FragDepth = clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
#else
    vec3 n = normalize(worldNormal);
    if (!gl_FrontFacing) n = -n;
    vec3 hit = relPosition;
#endif
#ifdef CLOUD_LIGHT
    color = vec4(albedo / kLightPi * objectIrradiance(hit, n), 0.0);
#else
    color = vec4(lambertRadiance(albedo, sunRadiance, n, sunDirection), 0.0);
#endif
}
