// The detail field: world-anchored, multi-octave erosion of the ellipsoids' density (issue 34 §1;
// docs/detail.md; defined exactly in data/scene-format.md, "The detail field"). ONE source,
// compiled as GLSL by every shader that renders cloud matter and as C++ by the CPU methods
// (model/include/nephele/detail.hpp), so the two cannot drift. Include gardner_model.glsl first.
// Common subset: float, int, uint, vec3; every literal with a suffix; functions MODEL_FN.
//
// DETAIL_TEX / DETAIL_FETCH(tex, uvw): the "nephele" kind's tileable texture, three octaves in its
// three channels (vec3). GLSL: a sampler3D (GL_RGBA8, GL_LINEAR, GL_REPEAT); C++: a DetailVolume,
// whose sample() filters the same bytes in float.
#ifndef DETAIL_TEX
#define DETAIL_TEX sampler3D
#define DETAIL_FETCH(tex, uvw) textureLod(tex, uvw, 0.0).rgb
#endif

// What a renderer needs of medium.detail for one view. origin = eye - drift: the detail is
// anchored to the air, which the wind carries by `drift` (m); a point rel metres from the eye
// reads the detail at origin + rel.
struct DetailParams {
    vec3 origin;     // m: eye - drift
    float erosion;   // E in [0, 4]; 0: no detail
    float scale;     // m: L, the largest octave's wavelength
    float smallest;  // m: the smallest wavelength drawn (at most L)
    vec3 mean;       // mu: what a faded octave stands in with (the noise's mean): per channel of the
                     // nephele kind's texture (octave k reads channel k mod 3); the reference kind's in all three
    int octaves;     // K = floor(log2(L / smallest)) + 1
    int kind;        // kDetailNephele or kDetailReference
};
const int kDetailNephele = 0;
const int kDetailReference = 1;
// An octave is drawn in full while its wavelength spans at least 2 r, r = max(theta dist,
// smallest / 2), and fades out (in log2 of the wavelength) to nothing at r: about 4 and 2 pixels
// of a 640 x 480 view with a 50-60 degree field. So 1 m detail is whole from 125 m in, and a
// cloud 5 km away evaluates only its octaves of 40 m and more.
const float kDetailFadeAngle = 0.004f;  // theta (rad)
// G: octave k weighs G^k. With C below, chosen by the silhouette dimension of cumulus27 from 1 km
// (docs/detail.md): G 0.6-0.7 left the small octaves too weak to roughen the rim (1.0-1.2).
const float kDetailGain = 0.8f;
// Octave k reads its noise at y 2^k / L + k o: the offset keeps the octaves' lattices apart (with
// factor-2 wavelengths they would share lattice points, where gradient noise is 0).
const vec3 kDetailOctaveOffset = vec3(0.5698403f, 0.7548777f, 0.4301597f);
const uint kDetailSeed = 0x5EEDu;       // the reference kind's seed of octave 0
const uint kDetailSeedStep = 0x9E3779B9u;
// The nephele kind's texture holds in channel c Worley noise of 4 * 2^c cells per period (16, 8
// and 4 texels a cell; model/src/detail.cpp): one fetch reads octaves 3g, 3g + 1 and 3g + 2, at
// the coordinate of octave 3g (group g). On llvmpipe the detailed tiles' time was mostly these
// fetches, and one RGBA8 fetch costs about what one R32F fetch did (docs/detail.md). With 8 cells
// in channel 0, channel 2 had 2 texels a cell: too smooth to cut grooves.
const float kDetailTextureCells = 4.0f;
const int kDetailGroup = 3;

// PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano 2020), as model/src/noise.cpp.
MODEL_FN uint detailHash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Perlin 2002's grad(): one of 12 cube-edge directions (16 entries) by the hash's top 4 bits.
MODEL_FN float detailGrad(uint hash, float x, float y, float z) {
    uint b = hash >> 28u;
    float u = b < 8u ? x : y;
    float v = b < 4u ? y : ((b == 12u || b == 14u) ? x : z);
    return ((b & 1u) == 0u ? u : -u) + ((b & 2u) == 0u ? v : -v);
}

MODEL_FN float detailCorner(int i, int j, int k, uint s, float x, float y, float z) {
    return detailGrad(detailHash(uint(i) ^ detailHash(uint(j) ^ detailHash(uint(k) ^ s))), x, y, z);
}

MODEL_FN float detailQuintic(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

// Improved Perlin noise on the unbounded integer lattice (no period), about [-1, 1].
MODEL_FN float detailPerlin(vec3 p, uint seed) {
    vec3 c = floor(p);
    vec3 f = p - c;
    int i = int(c.x), j = int(c.y), k = int(c.z);
    uint s = detailHash(seed);
    float n000 = detailCorner(i, j, k, s, f.x, f.y, f.z);
    float n100 = detailCorner(i + 1, j, k, s, f.x - 1.0f, f.y, f.z);
    float n010 = detailCorner(i, j + 1, k, s, f.x, f.y - 1.0f, f.z);
    float n110 = detailCorner(i + 1, j + 1, k, s, f.x - 1.0f, f.y - 1.0f, f.z);
    float n001 = detailCorner(i, j, k + 1, s, f.x, f.y, f.z - 1.0f);
    float n101 = detailCorner(i + 1, j, k + 1, s, f.x - 1.0f, f.y, f.z - 1.0f);
    float n011 = detailCorner(i, j + 1, k + 1, s, f.x, f.y - 1.0f, f.z - 1.0f);
    float n111 = detailCorner(i + 1, j + 1, k + 1, s, f.x - 1.0f, f.y - 1.0f, f.z - 1.0f);
    float u = detailQuintic(f.x), v = detailQuintic(f.y), w = detailQuintic(f.z);
    float x00 = n000 + u * (n100 - n000), x10 = n010 + u * (n110 - n010);
    float x01 = n001 + u * (n101 - n001), x11 = n011 + u * (n111 - n011);
    float y0 = x00 + v * (x10 - x00), y1 = x01 + v * (x11 - x01);
    return y0 + w * (y1 - y0);
}

// One octave's noise in [0, 1] at lattice point p: high on the creases between rounded cells,
// low inside them, so that erosion cuts grooves and leaves bulges (cauliflower).
// reference: (1 - |perlin|)^8, near 1 on the noise's zero sheets. nephele: the texture's
// squared Worley F1 distance (model/src/detail.cpp), high where cells meet.
MODEL_FN float detailReferenceOctave(vec3 p, int octave) {
    float a = 1.0f - min(abs(detailPerlin(p, kDetailSeed + uint(octave) * kDetailSeedStep)), 1.0f);
    float a2 = a * a;
    float a4 = a2 * a2;
    return a4 * a4;
}

// log2(L / r): octave k is drawn with weight clamp(c - k, 0, 1) (continuous in the distance: no pop).
MODEL_FN float detailOctaveCut(DetailParams dp, float dist) {
    return log2(dp.scale / max(kDetailFadeAngle * dist, 0.5f * dp.smallest));
}

// sum_k G^k f_k (N_k - mu) of the drawn octaves (below), at the moved point y. `top` =
// min(cut, K): f_k = clamp(top - k, 0, 1) is the fade and 0 past the last octave.
MODEL_FN float detailReferenceSum(DetailParams dp, vec3 y, float top) {
    float sum = 0.0f, weight = 1.0f, frequency = 1.0f / dp.scale;
    for (int k = 0; float(k) < top; ++k) {
        float f = clamp(top - float(k), 0.0f, 1.0f);
        sum += weight * f * (detailReferenceOctave(y * frequency + float(k) * kDetailOctaveOffset, k) - dp.mean.x);
        weight *= kDetailGain;
        frequency *= 2.0f;
    }
    return sum;
}
// The nephele kind: group g's fetch at y 8^g / L + g o, its channels octaves 3g .. 3g + 2.
MODEL_FN float detailNepheleSum(DETAIL_TEX tex, DetailParams dp, vec3 y, float top) {
    vec3 gains = vec3(1.0f, kDetailGain, kDetailGain * kDetailGain);
    float groupGain = kDetailGain * kDetailGain * kDetailGain;
    float sum = 0.0f, weight = 1.0f, frequency = 1.0f / dp.scale;
    for (int g = 0; float(g * kDetailGroup) < top; ++g) {
        vec3 n = DETAIL_FETCH(tex, (y * frequency + float(g) * kDetailOctaveOffset) * (1.0f / kDetailTextureCells));
        vec3 f = clamp(vec3(top - float(g * kDetailGroup)) - vec3(0.0f, 1.0f, 2.0f), 0.0f, 1.0f);
        sum += weight * dot(gains * f, n - dp.mean);
        weight *= groupGain;
        frequency *= 8.0f;
    }
    return sum;
}

// D >= 0 at the point rel metres from the eye: S = sum_k G^k (f_k N_k + (1 - f_k) mu) / sum_k G^k,
// D = max(1/2 + C (S - mu), 0). A faded octave stands in with the mean, so the erosion's mean does
// not change with distance. The contrast C spreads S (a mean of many octaves, so close to mu):
// the rim is cut deep where D is high and left whole where it is 0. No upper clamp: a clamp there
// flattened the small octaves wherever the large ones saturated it.
// The octaves past the cut are all their mean: the loops stop at the cut (reading none of them)
// and S - mu is the drawn octaves' share alone, sum_k G^k f_k (N_k - mu) / sum_k G^k.
// DETAIL_KIND: a GLSL program is built for one kind (DetailTexture::defines), which it reads
// whatever `kind` says: with the kind a uniform, the reference kind's Perlin octave was paid for
// in every octave of the nephele kind too on llvmpipe (the tiles' detail cost halved without it).
// Without DETAIL_KIND (C++), the kind is chosen at run time.
const float kDetailContrast = 6.0f;  // C
MODEL_FN float detailValue(DETAIL_TEX tex, DetailParams dp, vec3 rel) {
    vec3 y = dp.origin + rel;
    float top = min(detailOctaveCut(dp, length(rel)), float(dp.octaves));
    int kind = dp.kind;
#ifdef DETAIL_KIND
    kind = DETAIL_KIND;
#endif
    float sum = kind == kDetailReference ? detailReferenceSum(dp, y, top) : detailNepheleSum(tex, dp, y, top);
    float total = (1.0f - pow(kDetailGain, float(dp.octaves))) / (1.0f - kDetailGain);
    return max(0.5f + kDetailContrast * (sum / total), 0.0f);
}

// The erosion delta = E D at the point rel metres from the eye. It eats into each ellipsoid from
// its rim: the profile (1 - q)^2 becomes max(1 - q (1 + delta)^2, 0)^2, the ellipsoid's own profile
// shrunk to 1 / (1 + delta) of its radii where delta holds. The rim moves in by about delta of the
// radius, so every octave bites into the silhouette in proportion to its weight, whatever the
// density there (a subtraction from the density only thinned the rims it reached).
MODEL_FN float detailErosion(DETAIL_TEX tex, DetailParams dp, vec3 rel) {
    return dp.erosion * detailValue(tex, dp, rel);
}

// The eroded profile at unit-space squared radius q.
MODEL_FN float erodedProfile(float q, float delta) {
    float f = max(1.0f - q * (1.0f + delta) * (1.0f + delta), 0.0f);
    return f * f;
}

// The integral of erodedProfile(b^2 + u^2, delta) du over [u0, u1] (unit-space arc length u from
// the chord's closest approach, h2 = 1 - b^2), in closed form: with s = (1 + delta)^2 it is
// s^2 (H2 - u^2)^2 for |u| < sqrt(H2), H2 = 1 / s - b^2 (chordPrimitive: gardner_model.glsl).
MODEL_FN float erodedPiece(float h2, float u0, float u1, float delta) {
    float s = (1.0f + delta) * (1.0f + delta);
    float hh = h2 - (1.0f - 1.0f / s);
    if (hh <= 0.0f) return 0.0f;
    float uMax = sqrt(hh);
    float a = clamp(u0, -uMax, uMax), b = clamp(u1, -uMax, uMax);
    return s * s * (chordPrimitive(b, hh) - chordPrimitive(a, hh));
}

// segmentDepth of the eroded profile: the chord of the ray (unit world direction d from the
// eye; o' = M (eye - c), d' = M d) over [tMin, tMax] cut into `pieces` equal pieces, each eroded
// by the delta read at its middle.
MODEL_FN float erodedSegmentDepth(DETAIL_TEX tex, DetailParams dp, vec3 oUnit, vec3 dUnit, vec3 d, float tMin,
                                  float tMax, int pieces) {
    ChordSpan c = chordSpan(oUnit, dUnit, tMin, tMax);
    if (c.h2 <= 0.0f || tMax <= tMin) return 0.0f;
    float step = (c.u1 - c.u0) / float(pieces);
    float sum = 0.0f;
    for (int i = 0; i < pieces; ++i) {
        float ua = c.u0 + float(i) * step;
        float delta = detailErosion(tex, dp, d * ((c.tc + ua + 0.5f * step) / c.len));
        sum += erodedPiece(c.h2, ua, ua + step, delta);
    }
    return max(sum, 0.0f) / c.len;
}

// How much an ellipsoid's unit space grows (1 + delta) for the eroded ellipsoid about a ray to be
// its unit sphere: max(1 - q (1 + delta)^2, 0)^2 is the smooth profile of the sphere shrunk to
// 1 / (1 + delta). delta is read where the ray enters the eroded ellipsoid beyond tStart (two
// fixed-point steps from the smooth one's entry); 1 where the ray misses. The light's chord
// samples (chordLightAt) follow the eroded chord with it: the smooth chord's first mean free
// paths are what the detail took away, and the grids hold that air as air.
MODEL_FN float erodedGrowth(DETAIL_TEX tex, DetailParams dp, vec3 oUnit, vec3 dUnit, vec3 d, float tStart) {
    float grow = 1.0f;
    for (int i = 0; i < 2; ++i) {
        ChordSpan c = chordSpan(oUnit * grow, dUnit * grow, tStart, 1e30f);
        if (c.h2 <= 0.0f) break;
        grow = 1.0f + detailErosion(tex, dp, d * ((c.tc + c.u0) / c.len));
    }
    return grow;
}
