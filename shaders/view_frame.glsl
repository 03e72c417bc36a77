// The frame a pass draws into and reads the depth of (nephele::View; setViewFrameUniforms in
// core/src/frame_depth.cpp sets these): where the view's viewport lies, and the frame's depth
// convention (any perspective projection, reversed Z and [0, 1] clip depth included).
#ifndef VIEW_FRAME_GLSL
#define VIEW_FRAME_GLSL
uniform vec2 viewportOrigin;  // pixels: gl_FragCoord.xy - viewportOrigin = the pixel in the view
uniform vec3 viewDepth;       // x, y: 1 / eye depth = x d + y for window depth d; z: the depth of no surface (1, or 0)
uniform vec2 depthOrigin;     // the texel of the view's pixel (0, 0) in the depth texture read

// This fragment's pixel in the view (0 .. width - 1, 0 .. height - 1 from the lower left).
ivec2 viewPixel() { return ivec2(gl_FragCoord.xy - viewportOrigin); }
// The frame's window depth at a pixel of the view.
float frameDepthAt(sampler2D depthTexture, ivec2 pixel) {
    return texelFetch(depthTexture, pixel + ivec2(depthOrigin), 0).r;
}
// Eye-space depth (m, along the view axis) of window depth d.
float eyeDepthOf(float d) { return 1.0 / max(d * viewDepth.x + viewDepth.y, 1e-30); }
// Whether window depth d is a surface (not the cleared far plane).
bool isSurface(float d) { return viewDepth.z > 0.5 ? d < 1.0 : d > 0.0; }
// The depth of no surface (what a pass without a depth texture reads).
float noSurfaceDepth() { return viewDepth.z; }
#endif
