#include "broken_include.glsl"
out vec4 color;
void main() {
    color = vec4(missingFunction(), 1.0);
}
