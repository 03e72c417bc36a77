// The format's sky behind everything (opaque.glsl).
#define MODEL_FN
#include "opaque.glsl"
in vec2 ndc;
out vec4 color;
uniform vec3 rayCentre;    // the ray through the view's centre (NDC 0, 0), unit component along the view axis
uniform vec3 rightScaled;  // camera right * half the frustum's width at unit distance
uniform vec3 upScaled;     // camera up * half its height
uniform vec3 zenith, horizon, ground;
void main() {
    vec3 d = normalize(rayCentre + ndc.x * rightScaled + ndc.y * upScaled);
    color = vec4(skyRadiance(zenith, horizon, ground, d), 0.0);  // alpha: no cloud
}
