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
#include "object_light.glsl"
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
// The irradiance (W/m^2, linear RGB) on unit normal n at camera-relative point p (object_light.glsl).
vec3 objectIrradiance(vec3 p, vec3 n) {
    ObjectIrradiance l = openSkyLight(skyZenith, skyHorizon, skyGround, n, sunDirection);
    for (int c = 0; c < cloudCount; ++c)
        l = addCloudLight(l, c, p, cloudLightBoxes[3 * c].xyz, 1.0 / cloudLightBoxes[3 * c + 1].xyz);
    return objectSunIrradiance(l, sunIrradiance) + objectDiffuseIrradiance(l, sunIrradiance);
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
