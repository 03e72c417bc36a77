// The volumetric ray-marcher (Jiménez de Parga & Gómez Palomo 2018), one fragment per pixel
// over a full-screen triangle (fullscreen.vert). See volume/include/nephele/raymarch.hpp for
// the method; the CPU twin of the density and of the no-duplicate tracing is
// volume/src/raymarch_light.cpp. Positions are camera-relative (eye at 0), lengths in metres.
#include "raymarch_data.glsl"
#include "view_frame.glsl"
#define MODEL_FN
#include "gardner_model.glsl"
#include "detail.glsl"
#include "cloud_light_grid.glsl"

in vec2 ndc;
out vec4 result;

uniform vec3 forward;                         // unit view axis
uniform vec3 rayCentre, rightScaled, upScaled;  // the view: d = normalize(rayCentre + ndc.x right + ndc.y up)
uniform float nearClip, farClip;              // m
uniform int useDepth;                         // 1: end the rays at the opaque depth
uniform sampler2D sceneDepth;                 // the frame's depth (view_frame.glsl)
uniform int tilesX;                           // screen tiles per row (RM_TILE pixels each)
uniform float stepBase;                       // m, RaymarchSettings::step
uniform float invLod;                         // 1 / lodDistance (1/m), 0 = fixed step
uniform int maxSteps;
uniform float kappa;                          // medium.noise: the density's noise amplitude
uniform sampler3D noiseVolume;                // tileable fBm in [-1, 1], GL_REPEAT
uniform vec3 eyeNoise;                        // fract(eye / noisePeriod): the eye in noise coordinates
uniform float invNoisePeriod;                 // 1/m
uniform DetailParams detail;                  // medium.detail (detail.erosion 0: off)
uniform sampler3D detailVolume;               // the nephele kind's texture
uniform vec3 sunDirection;                    // unit, towards the sun
uniform vec3 sunIrradiance;                   // sun.color * sun.intensity
uniform float hgG, albedo;

const float kPi = 3.14159265;
const float kTransmittanceCut = 1e-4;  // early exit (the paper: 1e-6; below 1e-4 nothing shows)
const float kFar = 1e30;

// ---- The march state of this pixel.
vec3 dir;           // unit world direction of the ray
float transmittance = 1.0;
vec3 radiance = vec3(0.0);
int steps = 0;
bool finished() { return transmittance < kTransmittanceCut || steps >= maxSteps; }

// ---- Candidates of one cloud (Algorithm 1). A candidate's data stays where it was found,
// candData[slot] = (lc, qmin, a, sigma) with q(l) = a (l - lc)^2 + qmin its unit-space squared
// radius along the ray; the list sorted by entry is candKey[], each key the entry distance's
// float bits (positive floats order as their bits) with the slot in the low kSlotBits bits.
// Sorting 32-bit keys instead of whole records keeps the insertion sort cheap.
const uint kSlotBits = 6u;  // MAX_CANDIDATES <= 64
const uint kSlotMask = (1u << kSlotBits) - 1u;
vec4 candData[MAX_CANDIDATES];
uint candKey[MAX_CANDIDATES];
int candCount;
float candLimit;    // the nearest entry of a candidate left out (the list was full): march only up to it

float keyEntry(uint key) { return uintBitsToFloat(key & ~kSlotMask); }  // the entry, rounded down by < 2^-17

// Insertion sort (Algorithm 1's sortCandidates), each candidate inserted as it is found; when
// the list is full the farthest entry is left out and remembered in candLimit.
void insertCandidate(float tIn, vec4 data) {
    uint entryBits = floatBitsToUint(tIn) & ~kSlotMask;
    uint slot = uint(candCount);
    if (candCount == MAX_CANDIDATES) {
        uint last = candKey[MAX_CANDIDATES - 1];
        if (entryBits >= (last & ~kSlotMask)) {
            candLimit = min(candLimit, uintBitsToFloat(entryBits));
            return;
        }
        candLimit = min(candLimit, keyEntry(last));
        slot = last & kSlotMask;  // reuse the dropped candidate's slot
        candCount--;
    }
    candData[slot] = data;
    uint key = entryBits | slot;
    int h = candCount - 1;
    while (h >= 0 && key < candKey[h]) {
        candKey[h + 1] = candKey[h];
        h--;
    }
    candKey[h + 1] = key;
    candCount++;
}

// The ellipsoids of cloud `c` that the ray meets within [tMin, tMax] and not wholly before `from`
// (getCandidates): the noise scales the density, not the shape.
void getCandidates(RmCloud c, float tMin, float tMax, float from) {
    candCount = 0;
    candLimit = kFar;
    for (int i = c.range.x; i < c.range.x + c.range.y; ++i) {
        RmEllipsoid e = ellipsoids[i];
        vec3 o = e.eyeUnitSigma.xyz;
        vec3 du = vec3(dot(e.unit0.xyz, dir), dot(e.unit1.xyz, dir), dot(e.unit2.xyz, dir));
        float a = dot(du, du);
        float lc = -dot(o, du) / a;  // closest approach to the centre, m along the ray
        vec3 perp = o + lc * du;
        float qmin = dot(perp, perp);
        if (qmin >= 1.0) continue;
        float h = sqrt((1.0 - qmin) / a);
        float tIn = max(lc - h, tMin), tOut = min(lc + h, tMax);
        if (tOut <= max(tIn, from)) continue;
        insertCandidate(tIn, vec4(lc, qmin, a, e.eyeUnitSigma.w));
    }
}

// Extinction (1/m) at distance l: the candidates' (1 - q)^2 where q < 1, times the noise's
// density factor max(0, 1 + kappa n(x)), as the path tracer's field.
float extinctionAt(float l) {
    float sigma = 0.0;
    for (int k = 0; k < candCount; ++k) {
        vec4 c = candData[k];
        float u = l - c.x;
        float q = c.z * u * u + c.y;
        if (q < 1.0) {
            float f = 1.0 - q;
            sigma += c.w * f * f;
        }
    }
    if (kappa > 0.0 && sigma > 0.0)
        sigma *= max(0.0, 1.0 + kappa * textureLod(noiseVolume, eyeNoise + dir * (l * invNoisePeriod), 0.0).r);
    return sigma;
}

// With the detail: each candidate's profile eroded to max(1 - q (1 + e)^2, 0)^2, times the noise
// factor, with e read once at the point (detail.glsl), as the path tracer's field.
float erodedExtinctionAt(float l) {
    float nf = 1.0;
    if (kappa > 0.0) nf = max(0.0, 1.0 + kappa * textureLod(noiseVolume, eyeNoise + dir * (l * invNoisePeriod), 0.0).r);
    float e = -1.0;
    float sigma = 0.0;
    for (int k = 0; k < candCount; ++k) {
        vec4 c = candData[k];
        float u = l - c.x;
        float q = c.z * u * u + c.y;
        if (q < 1.0) {
            if (e < 0.0) e = detailErosion(detailVolume, detail, dir * l);
            sigma += c.w * erodedProfile(q, e) * nf;
        }
    }
    return sigma;
}

// One segment [l0, l1] with its extinction at the midpoint: Algorithm 3, with the light of
// the cloud's radiance grid (cloud_light.glsl) as the in-scattered radiance.
void shade(RmCloud c, float l0, float l1) {
    float mid = 0.5 * (l0 + l1);
#ifdef DETAIL
    float sigma = erodedExtinctionAt(mid);
#else
    float sigma = extinctionAt(mid);
#endif
    if (sigma <= 0.0) return;
    float dT = exp(-sigma * (l1 - l0));
    radiance +=
        transmittance * (1.0 - dT) * cloudSourceAt(c.range.z, dir * mid, dir, sunDirection, hgG, sunIrradiance, albedo);
    transmittance *= dT;
}

// The paper's distance-dependent LOD (Algorithm 1, line 50): longer steps farther away. Never
// under minStep (set per cloud: its span over maxSteps, so that the march crosses it whatever
// the step asked for) nor under 2^-20 of the distance, so that a step always moves l in float
// (a tiny step or a far cloud would otherwise mark time until maxSteps).
float minStep = 0.0;
// With the detail, a step spans at most the finest wavelength drawn at l (detail.glsl's r, twice:
// an octave is whole from 2 r), so that the march resolves the octaves it draws.
float detailStep(float l) {
#ifdef DETAIL
    return 2.0 * max(kDetailFadeAngle * l, 0.5 * detail.smallest);
#else
    return 1e30;
#endif
}
float stepAt(float l) {
    return max(max(min(stepBase * (1.0 + l * invLod), detailStep(l)), minStep), l * (1.0 / 1048576.0));
}

// One cloud over [tMin, tMax]: the sorted candidates marched front to back with the
// no-duplicate tracing of Algorithm 2 (lambda only moves forward: overlaps are marched once,
// gaps skipped). When more candidates meet the ray than the list holds, the march stops at
// the first one left out and the list is gathered again from there.
void marchCloud(RmCloud c, float tMin, float tMax) {
    float lambda = tMin;
    minStep = (tMax - tMin) / float(maxSteps);
    for (;;) {
        getCandidates(c, tMin, tMax, lambda);
        if (candCount == 0) return;
        if (++steps >= maxSteps) return;  // a gather counts as a step: the cap bounds every loop
        // More than MAX_CANDIDATES active at once: take a step with those we hold.
        if (candLimit <= lambda) candLimit = lambda + stepAt(lambda);
        for (int j = 0; j < candCount; ++j) {
            vec4 cj = candData[candKey[j] & kSlotMask];
            float h = sqrt(max(1.0 - cj.y, 0.0) / cj.z);
            float tIn = max(cj.x - h, tMin), tOut = min(min(cj.x + h, tMax), candLimit);
            if (lambda >= tOut) continue;  // Algorithm 2: already marched
            if (lambda < tIn) lambda = tIn;  // a gap: jump to the candidate
            while (lambda < tOut) {
                float l1 = min(lambda + stepAt(lambda), tOut);
                shade(c, lambda, l1);
                lambda = l1;
                steps++;
                if (finished()) return;
            }
            if (lambda >= candLimit) break;
        }
        if (candLimit >= kFar) return;
        lambda = max(lambda, candLimit);
    }
}

void main() {
    dir = normalize(rayCentre + ndc.x * rightScaled + ndc.y * upScaled);
    float cosF = dot(dir, forward);
    float tStart = nearClip / cosF, tEnd = farClip / cosF;
    if (useDepth == 1) {
        float z = frameDepthAt(sceneDepth, viewPixel());
        if (isSurface(z)) tEnd = min(tEnd, eyeDepthOf(z) / cosF);
    }
    // No component of dir exactly 0 in the slab test (0 * inf would be NaN).
    vec3 invDir = 1.0 / vec3(abs(dir.x) < 1e-20 ? 1e-20 : dir.x, abs(dir.y) < 1e-20 ? 1e-20 : dir.y,
                             abs(dir.z) < 1e-20 ? 1e-20 : dir.z);

    // The clouds front to back: batches of the nearest MAX_CLOUD_HITS by box entry (insertion
    // sort), each batch after the last cloud of the previous one in (entry, index) order.
    // Only the clouds binned to this pixel's tile (and those every pixel tests) can meet its
    // ray; the order they are tested in does not matter (entry, then index, decides).
    vec2 hitT[MAX_CLOUD_HITS];
    int hitIndex[MAX_CLOUD_HITS];
    float lastEntry = -kFar;
    int lastIndex = -1;
    ivec2 tileXY = viewPixel() / RM_TILE;
    int tile = 1 + tileXY.y * tilesX + tileXY.x;
    int everywhere = tileFirst[0], first = tileFirst[tile], count = everywhere + tileFirst[tile + 1] - first;
    for (;;) {
        int n = 0;
        bool more = false;
        for (int k = 0; k < count; ++k) {
            int c = tileClouds[k < everywhere ? k : first + k - everywhere];
            vec2 t = boxSlab(clouds[c].boxMin.xyz, clouds[c].boxMax.xyz, invDir);  // camera-relative box
            t.x = max(t.x, tStart);
            t.y = min(t.y, tEnd);
            if (t.x >= t.y) continue;
            if (t.x < lastEntry || (t.x == lastEntry && c <= lastIndex)) continue;  // done in a batch before
            if (n == MAX_CLOUD_HITS) {
                more = true;
                vec2 lt = hitT[n - 1];
                if (t.x > lt.x || (t.x == lt.x && c > hitIndex[n - 1])) continue;
                n--;
            }
            int h = n - 1;
            while (h >= 0 && (t.x < hitT[h].x || (t.x == hitT[h].x && c < hitIndex[h]))) {
                hitT[h + 1] = hitT[h];
                hitIndex[h + 1] = hitIndex[h];
                h--;
            }
            hitT[h + 1] = t;
            hitIndex[h + 1] = c;
            n++;
        }
        for (int k = 0; k < n && !finished(); ++k) marchCloud(clouds[hitIndex[k]], hitT[k].x, hitT[k].y);
        if (!more || n == 0 || finished()) break;
        lastEntry = hitT[n - 1].x;
        lastIndex = hitIndex[n - 1];
    }
    if (transmittance >= 1.0) discard;  // no cloud matter on this ray: the frame is left as it is
    // Premultiplied: blended with (ONE, ONE_MINUS_SRC_ALPHA) this is "over".
    result = vec4(radiance, 1.0 - transmittance);
}
