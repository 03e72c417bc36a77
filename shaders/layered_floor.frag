// The layered bench's floor: the unavoidable pixel work of the layered sky's geometry alone.
// Every fragment of every annulus and billboard instance (the same vertex shader, the same
// depth test) fetches the 2D modulation texture once and is blended once: a plain textured
// mesh, no discard, no 3D texture, no lighting.
in vec3 rel;
out vec4 color;
uniform sampler2D modulation;
uniform vec2 uvModEye;       // fract((eye.xy - t wind) / modulationPeriod)
uniform float invModPeriod;  // 1/m
void main() {
    float r = texture(modulation, uvModEye + rel.xy * invModPeriod).r;
    color = vec4(vec3(0.5 * r), 0.25);
}
