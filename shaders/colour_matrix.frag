// The colour-matrix copy of section 3.4: the atlas layer onto itself (after a texture
// barrier, each fragment reads only its own texel) through a 4x4 colour matrix; the
// blend (reverse subtract, alpha only) subtracts the result from what is there.
flat in vec4 atlasRect;
uniform sampler2DArray atlasTerms;
uniform mat4 colourMatrix;         // red -> alpha, scaled by 1 / D
out vec4 result;
void main() {
    vec4 texel = texelFetch(atlasTerms, ivec3(gl_FragCoord.xy, int(atlasRect.w)), 0);
    result = colourMatrix * texel;
}
