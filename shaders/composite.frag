// Compositing (section 3.6): the tile as a textured rectangle at its screen place, "over".
#define MODEL_FN
#include "gardner_model.glsl"
#include "tiles.glsl"
flat in int tileIndex;
flat in vec4 atlasRect;
in vec2 atlasCoord;
in vec2 ndc;
uniform sampler2DArray atlasTerms;    // green: sunLight, blue: noise modulation / 2, alpha: eq. (2)
uniform mat4 colourMatrix;            // zero when the colour-matrix pass already ran; else red / D -> alpha
uniform vec3 sunRadiance, ambient;
uniform float albedo;
uniform vec2 atlasSize;
uniform int fraction;                 // 1: weight by the optical depth in front of the opaque depth
uniform sampler2D sceneDepth;         // copy of the frame's depth (fraction mode)
uniform vec2 frameSize;
uniform vec3 forward, rightScaled, upScaled;
uniform float nearClip, farClip;
out vec4 result;
void main() {
    // Stay half a texel inside the tile so that filtering never reads a neighbour.
    vec2 lo = atlasRect.xy + 0.5, hi = atlasRect.xy + atlasRect.z - 0.5;
    vec3 uv = vec3(clamp(atlasCoord, lo, hi) / atlasSize, atlasRect.w);
    vec4 terms = texture(atlasTerms, uv);
    float alpha = clamp(terms.a - (colourMatrix * terms).a, 0.0, 1.0);
    vec3 color = cloudColor(sunRadiance, terms.g, ambient, albedo, 2.0 * terms.b);
    if (fraction == 1 && alpha > 0.0) {
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
    result = vec4(color, alpha);
}
