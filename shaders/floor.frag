// The bench's floor: the unavoidable pixel work alone. In the atlas: a constant blended
// once per tile pixel; on the screen: a plain textured quad per tile.
flat in vec4 atlasRect;
in vec2 atlasCoord;
uniform int onScreen;
uniform sampler2DArray atlasTerms;
uniform vec2 atlasSize;
out vec4 result;
void main() {
    result = onScreen == 1 ? texture(atlasTerms, vec3(atlasCoord / atlasSize, atlasRect.w))
                           : vec4(0.5);
}
