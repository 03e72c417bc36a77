// A reduced-resolution image (core/internal/reduced_target.hpp: the layered sky's layers, the
// compositor's magnified close tiles) composited over the full-resolution frame, with the
// layers' cloud shadows fused in (dual-source blending: dst = cloud + dst * keep, keep.rgb =
// S (1 - alpha), keep.a = 1 - alpha; S = 1 when shadowLayerCount is 0). Nearest-depth
// upsampling: of the four bilinear neighbours, those whose reduced depth (the farthest of
// their block) matches this pixel's depth keep their bilinear weights; if none does, the
// neighbour nearest in depth is taken; so the cloud drawn past an object's silhouette does
// not bleed onto the object.
#include "layered_shadow.glsl"
in vec2 ndc;
layout(location = 0, index = 0) out vec4 color;  // premultiplied cloud
layout(location = 0, index = 1) out vec4 keep;   // what is kept of the frame
uniform sampler2D cloud;       // reduced, premultiplied (linear filtering)
uniform vec2 scale;            // reduced size / full size
#ifdef NO_DEPTH
// A frame without depth: bilinear (what the weights below come to when every neighbour matches).
void main() {
    vec2 frag = gl_FragCoord.xy - viewportOrigin;  // in the view
    color = texture(cloud, frag * scale / vec2(textureSize(cloud, 0)));
    float shadow = cloudShadow(ndc, noSurfaceDepth());
    keep = vec4(vec3(shadow * (1.0 - color.a)), 1.0 - color.a);
}
#else
uniform sampler2D cloudDepth;  // reduced depth
uniform sampler2D frameDepth;  // the frame's depth (a copy)

float linearDepth(float d) { return eyeDepthOf(d); }

void main() {
    vec2 size = vec2(textureSize(cloud, 0));
    vec2 frag = gl_FragCoord.xy - viewportOrigin;  // in the view
    vec2 uv = frag * scale / size;
    float raw = frameDepthAt(frameDepth, viewPixel());
    // (llvmpipe runs every branch of a shader, so one path for all pixels: a gather of the four
    // neighbours' depths, four fetches, weights.)
    float d = linearDepth(raw);
    vec4 g = textureGather(cloudDepth, uv, 0);  // (i0, j1), (i1, j1), (i1, j0), (i0, j0)
    // A texel reused from the last frame holds the near plane's depth (reduced_depth.frag): its
    // block had no surface.
    g = mix(g, vec4(noSurfaceDepth()), equal(g, vec4(1.0 - noSurfaceDepth())));
    vec4 err = abs(vec4(linearDepth(g.x), linearDepth(g.y), linearDepth(g.z), linearDepth(g.w)) - d);
    vec2 p = frag * scale - 0.5;
    ivec2 i0 = ivec2(floor(p));
    vec2 f = p - vec2(i0);
    vec4 w = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
    vec4 mw = w * vec4(lessThanEqual(err, vec4(0.01 * d)));
    if (mw.x + mw.y + mw.z + mw.w <= 0.0) {  // no neighbour on this surface: the nearest in depth alone
        float m = min(min(err.x, err.y), min(err.z, err.w));
        mw = vec4(equal(err, vec4(m)));
    }
    ivec2 hi = ivec2(size) - 1;
    vec4 sum = mw.x * texelFetch(cloud, clamp(i0 + ivec2(0, 1), ivec2(0), hi), 0) +
               mw.y * texelFetch(cloud, clamp(i0 + ivec2(1, 1), ivec2(0), hi), 0) +
               mw.z * texelFetch(cloud, clamp(i0 + ivec2(1, 0), ivec2(0), hi), 0) +
               mw.w * texelFetch(cloud, clamp(i0, ivec2(0), hi), 0);
    color = sum / (mw.x + mw.y + mw.z + mw.w);
    float shadow = cloudShadow(ndc, raw);
    keep = vec4(vec3(shadow * (1.0 - color.a)), 1.0 - color.a);
}
#endif
