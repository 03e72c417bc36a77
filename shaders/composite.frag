// Compositing (section 3.6): the tile as a textured rectangle at its screen place, "over".
// Variants by #define (llvmpipe runs both sides of every branch, so what a frame does not
// need is compiled out rather than skipped at run time):
//   FUSED     the colour-matrix copy is applied here as the atlas is read (no pass of its own)
//   FRACTION  objects inside clouds: weight by the optical depth in front of the opaque depth
#define MODEL_FN
#include "gardner_model.glsl"
#include "tiles.glsl"
flat in int tileIndex;
flat in vec4 atlasRect;
in vec2 atlasCoord;
in vec2 ndc;
uniform sampler2DArray atlasTerms;    // green: sunLight, blue: noise modulation / 2, alpha: eq. (2)
#ifdef FUSED
uniform mat4 colourMatrix;            // red / D -> alpha (what the colour-matrix pass would subtract)
#endif
uniform vec3 sunRadiance, ambient;
uniform float albedo;
uniform vec2 atlasSize;
#ifdef FRACTION
uniform sampler2D sceneDepth;         // copy of the frame's depth
uniform vec3 forward, rightScaled, upScaled;
uniform float nearClip, farClip;      // m
#endif
out vec4 result;
void main() {
    // Stay half a texel inside the tile so that filtering never reads a neighbour.
    vec2 lo = atlasRect.xy + 0.5, hi = atlasRect.xy + atlasRect.z - 0.5;
    vec3 uv = vec3(clamp(atlasCoord, lo, hi) / atlasSize, atlasRect.w);
    vec4 terms = texture(atlasTerms, uv);
#ifdef FUSED
    float alpha = clamp(terms.a - (colourMatrix * terms).a, 0.0, 1.0);
#else
    float alpha = clamp(terms.a, 0.0, 1.0);
#endif
    vec3 color = cloudColor(sunRadiance, terms.g, ambient, albedo, 2.0 * terms.b);
#ifdef FRACTION
    if (alpha > 0.0) {
        float z = texelFetch(sceneDepth, ivec2(gl_FragCoord.xy), 0).r;
        if (z < 1.0) {
            Tile t = tiles[tileIndex];
            vec3 d = normalize(forward + ndc.x * rightScaled + ndc.y * upScaled);
            float zEye = 2.0 * nearClip * farClip / (farClip + nearClip - (2.0 * z - 1.0) * (farClip - nearClip));
            float cosF = dot(d, forward);
            float tObj = zEye / cosF;
            vec3 o = t.eyeUnitAc.xyz, du = toUnit(t, d);
            float tStart = t.params.x > 0.5 ? nearClip / cosF : 0.0;
            float whole = segmentDepth(o, du, tStart, 1e30);
            float front = segmentDepth(o, du, tStart, tObj);
            alpha = opacityInFront(alpha, front, whole);
        }
    }
#endif
    result = vec4(color, alpha);
}
