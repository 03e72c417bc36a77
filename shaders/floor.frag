// The bench's floor: the unavoidable pixel work alone. In the atlas: a constant blended
// once per tile pixel; on the screen: a plain textured quad per tile.
#include "tiles.glsl"
flat in int tileIndex;
in vec2 atlasCoord;
uniform int onScreen;
uniform sampler2DArray atlasColor;
uniform vec2 atlasSize;
out vec4 result;
void main() {
    result = onScreen == 1 ? texture(atlasColor, vec3(atlasCoord / atlasSize, tiles[tileIndex].atlasRect.w))
                           : vec4(0.5);
}
