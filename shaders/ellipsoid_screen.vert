// The stencil fly-through mode (section 4.3): the ellipsoid's front faces on the screen.
#include "tiles.glsl"
layout(location = 0) in vec3 position;
uniform int instanceBase;
uniform mat4 viewProjection;      // camera-relative world -> clip
void main() {
    Tile t = tiles[instanceBase + gl_InstanceID];
    gl_Position = viewProjection * vec4(t.centerSigma.xyz + tileAxes(t) * position, 1.0);
}
