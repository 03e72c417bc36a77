#include "sky.glsl"
in vec2 ndc;
out vec4 color;
uniform vec3 forward;      // unit view direction
uniform vec3 rightScaled;  // camera right * tan(half horizontal fov)
uniform vec3 upScaled;     // camera up * tan(half vertical fov)
uniform vec3 zenith, horizon, ground;
void main() {
    vec3 d = normalize(forward + ndc.x * rightScaled + ndc.y * upScaled);
    color = vec4(skyRadiance(zenith, horizon, ground, d), 0.0);  // alpha: no cloud
}
