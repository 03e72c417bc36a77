// The format's sky (data/scene-format.md, "sky"); the CPU twin is skyRadiance() in
// core/src/opaque_cpu.cpp.
vec3 skyRadiance(vec3 zenith, vec3 horizon, vec3 ground, vec3 d) {
    if (d.z < 0.0) return ground;
    return horizon + (zenith - horizon) * max(d.z, 0.0);
}
