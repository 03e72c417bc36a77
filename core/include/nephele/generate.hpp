// Expansion of the scene format's procedural `generate` entries into ellipsoid clouds
// (keys: data/scene-format.md, section "generate keys (Nephele)"), after Jimenez de Parga
// & Gomez Palomo 2018 (shared/papers/jimenez-de-parga-2018-volumetric-spheroids.txt).
//
// Every expansion is a pure function of the Generator: the same entry (seed included) gives
// the same cloud, bit for bit, on every machine. Random numbers come from std::mt19937 (its
// output sequence is fixed by the standard) mapped to uniform and normal variates by our own
// code (the std:: distributions differ between standard libraries); what remains machine-
// dependent is the last bit of libm's log/sin/cos/sqrt in the Box-Muller step and turtle.
//
// How a Scene is expanded: parseScene/loadScene call expandGenerators at the end of loading,
// so renderers only ever read `scene.clouds`. `scene.generators` is kept as loaded (what
// the file said, e.g. for `nephele info`); `scene.generated[i]` holds the statistics of
// generators[i] and marks it as expanded: expandGenerators expands only the generators that
// have no entry in `scene.generated` yet, so calling it again (e.g. after a host added a
// Generator in code) never duplicates a cloud.
#pragma once

#include "nephele/api.hpp"
#include "nephele/limits.hpp"
#include "nephele/scene.hpp"  // Generator, Cloud, Scene, GenerateStats

#include <stdexcept>
#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// A Wavefront OBJ that cannot be read as a triangle mesh. what() is "FILE:LINE: fault"
// (line 0 when the fault is not on one line, e.g. "no triangles"). expandGenerators turns it
// into a SceneError "SCENE: generate[i].path: FILE:LINE: fault".
class ObjError : public std::runtime_error {
public:
    ObjError(std::string file, int line, std::string fault);
    const std::string& file() const { return file_; }
    int line() const { return line_; }  // 1-based; 0 = the file as a whole
    const std::string& fault() const { return fault_; }

private:
    std::string file_;
    int line_;
    std::string fault_;
};

// A 3D-Gaussian cumulus (paper section 3.6.1, eqs. 14-17), in the world frame (z up):
// - placement (eq. 14): P = C + N(0, sigma) per axis, each offset clamped to
//   [clampLo, clampHi] * sigma (clamped, not redrawn, as in the paper's code);
// - radius (eq. 16): r = maxRadius * (1 - 0.1 * sqrt(sum_k ((P_k - C_k) / (2 sigma_k))^2))
//   = maxRadius * (1 - 0.05 d) with d the distance in units of sigma, floored at
//   0.05 * maxRadius (reached only for d >= 19, i.e. with clamps far beyond the defaults);
//   the ellipsoid's semi-axes are r * aspect, unrotated;
// - hollow core (the range given in the text before eq. 17): when `hollow`, an ellipsoid is
//   dropped if |dx| < 3 sigma_x / 4, |dy| < 3 sigma_y / 4 and |dz| < sigma_z / 3 (the paper's
//   y is vertical; its sigma_y / 3 is our z);
// - containment (eq. 17): when `pruneContained`, an ellipsoid that lies wholly inside another
//   one that survived the hollow pruning is dropped. The test is EXACT, not conservative:
//   all ellipsoids of a cumulus share the axes and the aspect, so scaling space by 1/aspect
//   makes them spheres of radius r, and j is inside i iff |c_i - c_j| (scaled) + r_j <= r_i,
//   eq. 17 itself. Larger ellipsoids are visited first (ties by placement order), so of two
//   equal ones the first placed is kept. No kept ellipsoid lies inside another kept one.
// The random sequence does not depend on `hollow` or `pruneContained`: the pruned cloud is a
// subset of the unpruned one of the same seed, in placement order.
Cloud generateCumulus(const Generator& g, GenerateStats* stats = nullptr);

// One ellipsoid per triangle of the OBJ at g.resolvedPath (paper section 3.6.4, eqs. 22-28):
// vertices transformed by position + scale * R(rotation_deg) * v; `v` and `f` lines are read
// (polygons fan-triangulated, 1-based and negative indices, `v/vt/vn`, `v//vn` and `v/vt`
// forms), other statements (vn, vt, o, g, s, usemtl, ...) are ignored. Per triangle:
// - centre: the centroid (eq. 22);
// - in-plane semi-axes and directions: those of the triangle's Steiner circumellipse, the
//   unique ellipse centred at the centroid through the three vertices, also the smallest-area
//   ellipse containing the triangle (so it circumscribes the triangle, as the paper's
//   centroid-to-vertex radii do, eq. 24, and its major axis
//   takes the place of the paper's alignment of the largest radius, eqs. 25-28);
// - local x = the major axis, local z = the triangle's normal (winding order, right-handed),
//   semi-axis along z = thicknessRatio * the minor in-plane semi-axis;
// - the rotation as rotation_deg (R = Rz * Ry * Rx, see rotationFromDegrees).
// stats: placed = triangles read, degenerate = triangles skipped because they have no area
// (minor semi-axis <= 1e-9 of the major, or zero size) or that would make an ellipsoid with a
// semi-axis under limits::kSmallestRadius, kept = placed - degenerate. The OBJ must be a
// regular file of at most limits::kObjFileBytes with no NUL byte and at most
// limits::kEllipsoidsPerEntry triangles. Throws ObjError.
Cloud generateMesh(const Generator& g, GenerateStats* stats = nullptr);

// An L-system cloud (paper section 3.6.2): the axiom rewritten `iterations` times by the rules
// (a symbol without a rule is copied), then read by a 3D turtle that starts at `center`
// heading east (+x) with up = +z:
//   F      move `step` forward, placing a sphere of `radius` at the middle of that move;
//          step and radius are each multiplied by (1 + jitter * u), u uniform in [-1, 1),
//          drawn per F from the seed (the paper's proportional random factor)
//   + -    turn left / right by angle_deg about the turtle's up axis (yaw)
//   & ^    pitch down / up by angle_deg about its left axis
//   \ /    roll left / right by angle_deg about its heading
//   |      turn around (yaw 180 degrees)
//   [ ]    push / pop the turtle's position and orientation (an unmatched ] is ignored)
// Every other symbol only takes part in the rewriting. Throws std::length_error when the
// rewritten string would exceed maxSymbols (at most kMaxLSystemSymbols) symbols, place more
// than kMaxLSystemSpheres spheres, or nest '[' deeper than limits::kLSystemDepth.
inline constexpr size_t kMaxLSystemSymbols = size_t(limits::kLSystemSymbols.value);      // rewritten string length
inline constexpr size_t kMaxLSystemSpheres = size_t(limits::kEllipsoidsPerEntry.value);  // as cumulus `count`
Cloud generateLSystem(const Generator& g, GenerateStats* stats = nullptr, size_t maxSymbols = kMaxLSystemSymbols);

// The rotation_deg (rx, ry, rz) of a rotation matrix, so that rotationFromDegrees(result)
// gives R back (R = Rz * Ry * Rx; ry in [-90, 90]; at ry = +-90 rz is 0).
Vec3 degreesFromRotation(const glm::dmat3& R);

// Expands every generator of `scene` that is not yet expanded (index >= scene.generated.size())
// into one Cloud named after it, appended to scene.clouds in generator order; appends its
// statistics to scene.generated and returns those of this call. An OBJ or L-system fault is
// rethrown as SceneError(scene.file, "generate[i].path" (mesh) or "generate[i]", what()).
// The scene's limits (nephele/limits.hpp) hold for what it makes: the scene's clouds and
// ellipsoids in all, OBJ data and L-system symbols per scene, and every generated ellipsoid
// keeps the coordinate, radius and optical-depth limits of an explicit one (a SceneError
// names the generator and the ellipsoid otherwise).
std::vector<GenerateStats> expandGenerators(Scene& scene);

}  // namespace nephele
NEPHELE_API_END
