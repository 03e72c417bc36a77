// A layer's shadow on what is below it, Wang, Ji & Zhang 2011 eq. (19): ONE source compiled as
// GLSL by layered_shadow.glsl (the shadow pass and the fused upsampling) and as C++ by
// sunTransmittance() (layered/src/modulation.cpp, through layered/src/layer_model.hpp), which
// LayeredShadowResolutionGLTest holds the shader to. Same subset and MODEL_FN prefix as
// gardner_model.glsl.

// Where the ray from a point at height h towards the sun (unit s, s.z > 0) crosses the layer's
// middle, at height `middle`: its horizontal offset from the point (m).
MODEL_FN vec2 shadowRayOffset(vec3 s, float h, float middle) {
    return vec2(s.x, s.y) * ((middle - h) / max(s.z, 1e-6f));
}

// The layer's factor for the sun's light at height h, eq. (19) with T_S = 1 (the column's peak
// alpha): S = 1 - D max(T_S - (r + 1 - C), 0) = 1 - D max(C - r, 0), r the modulation texture's
// threshold where the ray towards the sun crosses the middle (shadowRayOffset), C the coverage,
// D the density. At or above the middle: 1, no shadow from it.
MODEL_FN float layerShadow(float h, float middle, float r, float coverage, float density) {
    return h < middle ? 1.0f - density * max(coverage - r, 0.0f) : 1.0f;
}
