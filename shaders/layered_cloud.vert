// Wang, Ji & Zhang 2011 geometry: LOD1 annuli at H_i = base + i thickness / (N - 1), eq. (12),
// one instance per layer; LOD0 vertical billboard slices across the disc around the eye,
// width and height by eq. (13), one instance per (slice, vertical piece). Positions are
// relative to the eye (float precision stays at the eye); instances go far to near.
layout(location = 0) in vec3 vertex;  // annulus: (x, y) in m around the eye; billboard: corner in [-0.5, 0.5]^2
uniform int mode;                     // 0 = annuli (LOD1), 1 = billboards (LOD0)
uniform float annulusRadius;          // m, the layer's extent (the mesh has radius 1)
uniform mat4 viewProjection;          // eye-relative world -> clip
uniform float base, thickness;        // m
uniform float eyeHeight;              // m, eye z
uniform int layerCount;               // N
uniform int firstAbove;               // index of the first layer above the eye (N if none)
uniform vec2 sliceAxis;               // unit horizontal direction the billboards face
uniform float lod0Radius, lod0Spacing;  // m
uniform int slices, pieces;           // billboard slices along sliceAxis and pieces per slice vertically
out vec3 rel;                         // m, fragment position relative to the eye
void main() {
    int j = gl_InstanceID;
    vec3 p;
    if (mode == 0) {
        // Layers above the eye top down, then those below bottom up: within each set the
        // farther along any ray comes first, and the sets never share a pixel.
        int above = layerCount - firstAbove;
        int i = j < above ? layerCount - 1 - j : j - above;
        p = vec3(vertex.xy * annulusRadius, base + float(i) * thickness / float(layerCount - 1) - eyeHeight);
    } else {
        int k = slices - 1 - j / pieces;
        int m = j - (j / pieces) * pieces;
        float pd = float(k + 1) * lod0Spacing;
        float c = pd - 0.5 * lod0Spacing;
        float halfWidth = sqrt(max(lod0Radius * lod0Radius - c * c, 0.0));  // W_p / 2, eq. (13)
        float ph = thickness / float(pieces);
        vec2 side = vec2(-sliceAxis.y, sliceAxis.x);
        p.xy = sliceAxis * pd + side * (vertex.x * 2.0 * halfWidth);
        p.z = base + (float(m) + 0.5 + vertex.y) * ph - eyeHeight;
    }
    rel = p;
    gl_Position = viewProjection * vec4(p, 1.0);
}
