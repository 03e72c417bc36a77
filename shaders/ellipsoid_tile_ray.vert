// The ellipsoid pass with the model per pixel (EllipsoidSettings::geometry = Polygon): per
// ellipsoid one flat polygon that circumscribes its silhouette, the tile's place in the
// atlas folded into the projection. The tangent cone from the eye touches the ellipsoid
// along the circle where its polar plane cuts it (in unit space: centre o / |o|^2, radius
// sqrt(1 - 1 / |o|^2), o the eye); an octagon circumscribing that circle in that plane
// projects to an octagon circumscribing the silhouette (tangency survives projection),
// 5% larger in area than the ellipse, where the whole tile is 27% larger. The octagon's
// points are on the plane, so their interpolated (perspective-correct) positions are
// exact points of each pixel's ray.
// CUT (ellipsoids cut by the near plane, or around the eye): the whole tile, a quad at the
// near plane (draw 4 vertices).
#include "tiles.glsl"
uniform int instanceBase;                // first tile of this draw
uniform vec2 atlasSize;                  // px
uniform int foldAtlas;                   // 1: the tile's place is folded into the projection (instanced)
                                         // 0: the caller set the viewport to the tile (one draw per ellipsoid)
uniform vec3 eyeNoise;                   // fract(eye / noisePeriod)
out vec3 ray;                            // camera-relative point on the pixel's ray (m)
out vec3 rayUnit;                        // M ray: the same in the ellipsoid's unit space
flat out vec4 instance;                  // Ac, sigma (1/m), unused, 1 if cut by the near plane
flat out vec3 eyeUnit;                   // M (eye - c)
flat out vec3 unitRow0, unitRow1, unitRow2;  // rows of M
flat out vec3 noiseBase;                 // noise texture coordinates of the eye
flat out int cloud;                      // the scene cloud: its radiance grid
const float kOctagon = 1.0823922;        // 1 / cos(pi / 8): the octagon circumscribes the unit circle

void main() {
    int tileIndex = instanceBase + gl_InstanceID;
    Tile t = tiles[tileIndex];
    vec3 o = t.eyeUnitAc.xyz;
#ifdef CUT
    // Fan order around the tile: (-1,-1), (1,-1), (1,1), (-1,1).
    vec2 corner = vec2(gl_VertexID == 1 || gl_VertexID == 2 ? 1.0 : -1.0, gl_VertexID >= 2 ? 1.0 : -1.0);
    ray = t.rayCentre.xyz + corner.x * t.rayX.xyz + corner.y * t.rayY.xyz;
    vec4 clip = vec4(corner, 0.0, 1.0);
#else
    float inv = 1.0 / dot(o, o);
    vec3 c = o * inv;                    // the circle's centre, unit space
    float r = sqrt(max(1.0 - inv, 0.0)) * kOctagon;
    vec3 a = normalize(o);
    vec3 e1 = normalize(cross(a, abs(a.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    vec3 e2 = cross(a, e1);
    float phi = 0.78539816 * float(gl_VertexID);
    vec3 pu = c + r * (cos(phi) * e1 + sin(phi) * e2);
    ray = t.centerSigma.xyz + tileAxes(t) * pu;
    vec4 clip = t.tileViewProj * vec4(ray, 1.0);
    // Keep the octagon inside its tile (it overhangs the silhouette's rectangle).
    gl_ClipDistance[0] = clip.w + clip.x;
    gl_ClipDistance[1] = clip.w - clip.x;
    gl_ClipDistance[2] = clip.w + clip.y;
    gl_ClipDistance[3] = clip.w - clip.y;
#endif
    rayUnit = vec3(dot(t.unit0.xyz, ray), dot(t.unit1.xyz, ray), dot(t.unit2.xyz, ray));
    if (foldAtlas == 1) {
        vec2 scale = vec2(t.atlasRect.z) / atlasSize;
        vec2 offset = (2.0 * t.atlasRect.xy + t.atlasRect.z) / atlasSize - 1.0;
        clip.xy = clip.xy * scale + offset * clip.w;
    }
    gl_Position = clip;
    instance = vec4(t.eyeUnitAc.w, t.centerSigma.w, 0.0, t.params.x);
    eyeUnit = o;
    unitRow0 = t.unit0.xyz;
    unitRow1 = t.unit1.xyz;
    unitRow2 = t.unit2.xyz;
    noiseBase = eyeNoise + t.noiseOffset.xyz;
    cloud = int(t.params.y);
}
