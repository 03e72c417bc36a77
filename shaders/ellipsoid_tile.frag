// Eq. (2) terms and the colour of one ellipsoid, per fragment of its tile.
#define MODEL_FN
#include "gardner_model.glsl"
#include "tiles.glsl"
flat in int tileIndex;
in vec3 relPosition;
layout(location = 0) out vec4 terms;   // (T2 g, 0, 0, I / D): blended into (T2, 0, 0, T1 / D)
layout(location = 1) out vec4 color;   // lit colour
uniform vec3 forward;                  // unit view direction
uniform float nearClip;                // m
uniform sampler2D falloff;             // projective radial falloff: F(b) = (1 - b^2)^(5/2) over [-1,1]^2
uniform sampler3D noiseVolume;         // tileable fBm, [-1, 1]
uniform vec3 eyeNoise;                 // fract(eye / noisePeriod)
uniform float noisePeriod;             // m
uniform float noiseAmp;                // medium.noise
uniform sampler3D lightVolume;         // per-cloud sun transmittance, clouds stacked along z
uniform int lightSize;                 // voxels per side; 0 = no self-shadowing
uniform int lightClouds;
layout(std430, binding = 1) readonly buffer LightBoxes { vec4 lightBoxes[]; };  // per cloud: minRel, extent
uniform vec3 sunDirection;
uniform vec3 sunRadiance;
uniform vec3 ambient;
uniform float albedo;

float sunTransmittance(int cloud, vec3 p) {
    if (lightSize == 0) return 1.0;
    vec3 uvw = (p - lightBoxes[2 * cloud].xyz) / lightBoxes[2 * cloud + 1].xyz;
    float n = float(lightSize);
    uvw = clamp(uvw, 0.5 / n, 1.0 - 0.5 / n);
    uvw.z = (float(cloud) + uvw.z) / float(lightClouds);
    return texture(lightVolume, uvw).r;
}

void main() {
    Tile t = tiles[tileIndex];
    vec3 d = normalize(relPosition);
    vec3 o = t.eyeUnitAc.xyz;
    vec3 du = toUnit(t, d);
    float len = length(du);
    vec3 dn = du / len;
    float tc = -dot(o, dn);
    vec3 perp = o + tc * dn;
    float b2 = dot(perp, perp);
    float ac = t.eyeUnitAc.w;
    bool cut = t.params.x > 0.5;
    float tStart = cut ? nearClip / dot(d, forward) : 0.0;
    float depth;
    if (cut) {
        depth = segmentDepth(o, du, tStart, 1e30);
    } else {
        // The projective texture: the ray's closest point to the centre, in a plane facing
        // the eye, at radius b.
        vec3 c = -normalize(o);
        vec3 e1 = normalize(cross(c, abs(c.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
        vec3 e2 = cross(c, e1);
        vec2 st = vec2(dot(perp, e1), dot(perp, e2));
        float r = length(st);
        st = r > 0.0 ? st * (sqrt(b2) / r) : st;
        depth = kChordScale * texture(falloff, st * 0.5 + 0.5).r / len;
    }
    float a = opacityOf(t.centerSigma.w * depth);
    float h = sqrt(max(1.0 - b2, 0.0));
    float tIn = (tc - h) / len, tOut = (tc + h) / len;
    float tShade = clamp(tc / len, max(tIn, tStart), tOut);
    vec3 shade = tShade * d;
    float n = texture(noiseVolume, shade / noisePeriod + eyeNoise + t.noiseOffset.xyz).r;
    terms = vec4(kTranslucence * termG(ac, noiseAmp, a / ac), 0.0, 0.0, termIOverD(ac, noiseAmp, n));
    vec3 normal = -d;
    if (tIn > tStart) {
        vec3 pu = o + tIn * du;  // entry point, unit space: the world normal is M^T pu
        normal = normalize(t.unit0.xyz * pu.x + t.unit1.xyz * pu.y + t.unit2.xyz * pu.z);
    }
    float sunT = sunTransmittance(int(t.params.y), shade);
    color = vec4(cloudColor(sunRadiance, sunT, dot(normal, sunDirection), ambient, albedo, noiseAmp, n), 1.0);
}
