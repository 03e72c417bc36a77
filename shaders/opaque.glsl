// The format's opaque world (data/scene-format.md, "sky", "sun" and "objects"): ONE source
// compiled as GLSL by sky.frag and object.frag and as C++ by their CPU twin, core/src/opaque_cpu.cpp
// (skyRadiance, lambertRadiance: the CPU reference the tests and the path tracer use), which
// OpaqueGLTest holds the GPU to. Functions prefixed MODEL_FN; unlike the model's files it is
// compiled as C++ in double (vec3 = glm::dvec3, the reference's precision), so its literals have
// no suffix: a float one would not mix with double in C++.

// The sky's radiance along unit direction d: the ground colour below the horizon, above it the
// horizon colour blended to the zenith's by d.z.
MODEL_FN vec3 skyRadiance(vec3 zenith, vec3 horizon, vec3 ground, vec3 d) {
    if (d.z < 0.0) return ground;
    return horizon + (zenith - horizon) * max(d.z, 0.0);
}

// An object's radiance under the sun alone (Lambert, no ambient term): albedo, sunRadiance =
// sun.color * sun.intensity / pi, unit normal n and unit direction towards the sun s.
MODEL_FN vec3 lambertRadiance(vec3 albedo, vec3 sunRadiance, vec3 n, vec3 s) {
    return albedo * sunRadiance * max(dot(n, s), 0.0);
}
