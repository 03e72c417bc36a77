// Lambert under the sun, no ambient term (data/scene-format.md, "sun" and "objects").
// SPHERE: the mesh is the sphere's bounding box drawn by its back faces, and each
// fragment ray-casts the exact sphere (exact silhouette and depth, as the CPU reference).
in vec3 relPosition;
in vec3 worldNormal;
out vec4 color;
uniform vec3 albedo;
uniform vec3 sunDirection;   // unit, towards the sun
uniform vec3 sunRadiance;    // sun.color * sun.intensity / pi
#ifdef SPHERE
uniform vec3 sphereCenter;   // camera-relative, m
uniform float sphereRadius;  // m
uniform mat4 viewProjection;
#endif
void main() {
#ifdef SPHERE
    vec3 d = normalize(relPosition);
    float b = dot(sphereCenter, d);
    float h = b * b - dot(sphereCenter, sphereCenter) + sphereRadius * sphereRadius;
    if (h < 0.0) discard;
    float t = b - sqrt(h);
    if (t < 0.0) t = b + sqrt(h);  // the eye is inside the sphere: its far side
    vec3 hit = t * d;
    vec3 n = (hit - sphereCenter) / sphereRadius;
    if (dot(n, d) > 0.0) n = -n;
    vec4 clip = viewProjection * vec4(hit, 1.0);
    gl_FragDepth = clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
#else
    vec3 n = normalize(worldNormal);
    if (!gl_FrontFacing) n = -n;
#endif
    color = vec4(albedo * sunRadiance * max(dot(n, sunDirection), 0.0), 0.0);
}
