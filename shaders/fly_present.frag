// `nephele fly`: the linear float frame onto the window, clamped to [0, 1] and sRGB-encoded
// as the PNG writer encodes it (core/src/image.cpp), so the window shows what `render` writes.
in vec2 ndc;
out vec4 color;
uniform sampler2D frame;

float srgb(float c) {
    c = clamp(c, 0.0, 1.0);
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

void main() {
    vec3 c = texture(frame, ndc * 0.5 + 0.5).rgb;
    color = vec4(srgb(c.r), srgb(c.g), srgb(c.b), 1.0);
}
