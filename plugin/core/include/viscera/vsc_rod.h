// The intestine's axis: a Lagrangian Catmull-Rom rod (France et al. 2002, 3.1).
//
// Degrees of freedom: n control points q (m) and their velocities v (m/s),
// interleaved xyz, 3 per point. Equations of motion (Euler-Lagrange; the
// paper's eq. 3 prints + signs):
//     M a = Q_gravity + Q_contact + Q_external - grad E - damping * M v
// with M_ij = m * integral_0^1 b_i(s) b_j(s) ds the consistent mass matrix
// (band 7, identical for x, y, z), factorised once at creation.
//
// Elastic energy E, on S sample points per segment (N = (n-1) S + 1 samples
// p_a = P(a / (N-1)), rest spacing l0 = length / (N-1), straight rest shape):
//   stretch springs  p_a -- p_{a+1}: 1/2 k_s (|p_{a+1} - p_a| - l0)^2
//   bend springs     p_a -- p_{a+2}: 1/2 k_b (|p_{a+2} - p_a| - 2 l0)^2  (paper Fig. 1)
//   global stretch   1/2 K_g (l - length)^2, l = sum |p_{a+1} - p_a|   (paper 3.1.3)
//   curvature        (EI / l0) (1 - cos theta_a) at each interior sample, theta_a
//                    the turning angle between its two spring edges: EI theta^2 / (2 l0)
//                    = 1/2 EI kappa^2 l0 for small angles (kappa = theta / l0), the
//                    Kirchhoff rod's bending energy, so EI is the material's. The bend
//                    springs above are not: a chord of a bent arc shortens by
//                    kappa^2 l0^3 / 3, so their energy is quartic in curvature and
//                    gives no linear bending stiffness (the paper's model).
//   clamp            (2 EI / l0) (1 - t . e / |e|) at a clamped end, e its end spring edge
//                    and t the clamp's direction: the mirror image of the rod across the
//                    clamp would turn by 2 theta at the end sample, whose half cell weighs
//                    (EI / l0) (2 theta)^2 / 4 = EI theta^2 / l0, the same for small angles.
//                    The end control point must also be pinned; the next one stays free,
//                    so the axis bends right from the clamp (pinning two control points
//                    would also hold the curve's point one segment out: a first-order error).
// Per-spring constants are scaled from the whole-intestine stiffnesses so the
// response does not depend on the resolution: k_s = stretch_stiffness (N-1),
// k_b = bend_stiffness (N-1). A straight intestine pulled by its ends then has
// the axial stiffness stretch_stiffness + 4 bend_stiffness + global_stretch_stiffness.
// A tapered tube (radius_end) is stiffer where it is wider: the three stiffnesses
// describe the section at s = 0 (`radius`), and each spring scales by its local
// section (vsc_tube_section at the radius there and `wall_thickness`): a stretch
// spring by the area A(r) / A(r0) at its middle, a bend spring and the curvature
// term at a sample by the second moment I(r) / I(r0) there. The global length
// term, a whole-length constraint, does not scale.
// Forces are exact gradients, O(n), transposed to control points by virtual
// work: a force F at abscissa s adds b_k(s) F to control point k.
#ifndef VISCERA_VSC_ROD_H
#define VISCERA_VSC_ROD_H

#include "viscera/vsc_base.h"
#include "viscera/vsc_geom.h"
#include "viscera/vsc_grid.h"
#include "viscera/vsc_spline.h"
#include "viscera/vsc_world.h"

/// Creation parameters. Initialise with vsc_default_rod_def().
typedef struct vsc_rod_def {
  int control_count;                 ///< control points n (>= 4)
  double length;                     ///< rest length of the axis (m, > 0)
  double mass;                       ///< total mass (kg, > 0)
  int samples_per_segment;           ///< spring sample points per segment S (>= 1)
  double stretch_stiffness;          ///< whole-intestine stretch spring stiffness (N/m, >= 0)
  double bend_stiffness;             ///< whole-intestine bend spring stiffness (N/m, >= 0)
  double global_stretch_stiffness;   ///< global length stiffness K_g (N/m, >= 0)
  double bending_rigidity;           ///< EI of the curvature bending energy (N m^2, >= 0; 0: none)
  double damping;                    ///< mass-proportional viscous damping (1/s, >= 0)
  int lumped_mass;                   ///< 1 (default): M lumped, sum_j M_kj on the diagonal (same total
                                     ///< mass, gravity and statics, a stable step about 1.4x longer, a
                                     ///< diagonal solve); 0: the paper's consistent band M
  double radius;                     ///< the tube's radius at s = 0, its collision spheres' there (m, > 0)
  double radius_end;                 ///< the tube's radius at s = 1 (m); 0 (default): `radius` all along.
                                     ///< Linear in s between: spheres, contacts, mass (as radius^2) and the
                                     ///< springs (as the section, see above) follow it
  double wall_thickness;             ///< the tube wall (m; 0, default: a solid section) by which a tapered
                                     ///< tube's springs scale (A and I of vsc_tube_section); unused untapered
  int collision_sphere_count;        ///< spheres uniform in abscissa (>= 2)
  double contact_stiffness;          ///< penalty stiffness against geoms (N/m, > 0)
  double contact_damping;            ///< penalty damping, also tangential (N s/m, >= 0)
  int self_collision;                ///< 1: the intestine collides with itself
  double self_friction;              ///< Coulomb coefficient against itself (>= 0)
  int clamp_start;                   ///< 1: the axis leaves s = 0 along clamp_direction_start (needs EI > 0)
  double clamp_direction_start[3];   ///< clamp tangent at s = 0, towards increasing s (normalised at creation)
  int clamp_end;                     ///< 1: the axis reaches s = 1 along clamp_direction_end (needs EI > 0)
  double clamp_direction_end[3];     ///< clamp tangent at s = 1, towards increasing s (normalised at creation)
  const int* pinned;                 ///< indices of control points fixed in space (copied)
  int pinned_count;                  ///< number of entries of `pinned`
  // mesentery: tension-only tethers from points of the axis to a root line
  int mesentery_points;              ///< tethers at abscissae (i + 1/2) / count (0: none)
  double mesentery_stiffness;        ///< stiffness of each tether (N/m, >= 0; 0: none)
  double mesentery_length;           ///< slack length of every tether (m, >= 0)
  double mesentery_root[6];          ///< root line, from (m, 3) to (m, 3); tether i ends at the same fraction of it
} vsc_rod_def;

/// Basis weights smaller than this (dimensionless) are left out of the force
/// Jacobians: at a sample on a knot the weights are (0, 1, 0, 0) up to rounding.
#define VSC_NEGLIGIBLE_WEIGHT 1e-12

/// Resolution limits: beyond them a definition is rejected (no overflow, no hang).
#define VSC_MAX_CONTROL_POINTS 1000000
#define VSC_MAX_SAMPLES 10000000          ///< (control points - 1) x samples per segment + 1
#define VSC_MAX_COLLISION_SPHERES 10000000
/// Most heap one rod may take (bytes): 2 GiB, 2.7 million control points at the
/// default resolution. Larger definitions are refused before anything is
/// allocated, so an absurd request fails with a message instead of the
/// kernel's OOM killer (Linux overcommits: malloc rarely returns NULL).
#define VSC_MAX_ROD_BYTES 2147483648.0

/// Defaults: a 4 m, 250-point, 12.5 mm-radius intestine of density 1000 kg/m^3,
/// stiffnesses 10, 1 and 200 N/m (the plugin scales the first two as
/// 4 m / length, so that every length is the same material: 40 N and 4 N
/// divided by the length).
vsc_rod_def vsc_default_rod_def(void);

/// The tube's radius at parametric abscissa s in [0, 1] (m): linear from
/// `radius` to `radius_end` (or `radius` all along).
double vsc_rod_def_radius_at(const vsc_rod_def* def, double s);

/// The largest and the smallest of the tube's radii (m).
double vsc_rod_def_radius_max(const vsc_rod_def* def);
double vsc_rod_def_radius_min(const vsc_rod_def* def);

/// Default collision spheres along `length` (m) for radius `radius` (m):
/// ceil(length / radius) + 1, a spacing of at most one radius, so neighbours
/// overlap by half. At the 2 r spacing where neighbours just touch, a crossing
/// tube sinks between spheres until the axes are sqrt(2) r apart and the axis
/// sags 0.3 r between supports; at r spacing the worst crossing keeps the axes
/// sqrt(3.5) r = 1.87 r apart. Returns -1 past VSC_MAX_COLLISION_SPHERES.
int vsc_default_collision_sphere_count(double length, double radius);

/// A tube's section: outer radius (m) and wall thickness (m; 0, or at least the
/// radius: a solid section) to its area A = pi (r^2 - (r - t)^2) (m^2) and second moment of
/// area I = pi (r^4 - (r - t)^4) / 4 (m^4). With a Young's modulus E (Pa), EA
/// (N) and EI (N m^2) are the rod's axial stiffness and bending rigidity.
void vsc_tube_section(double radius, double wall_thickness, double* area, double* second_moment);

/// A tube of Young's modulus E (Pa), outer radius (m), wall thickness (m; 0:
/// solid) and length (m) as the rod's parameters: the whole axis's stretch
/// stiffness EA / length (N/m, vsc_rod_def.stretch_stiffness) and the bending
/// rigidity EI (N m^2, vsc_rod_def.bending_rigidity).
void vsc_material_stiffnesses(double young_modulus, double radius, double wall_thickness, double length,
                              double* stretch_stiffness, double* bending_rigidity);

/// A rod: the definition plus caches derived from it and scratch (its layout
/// is private to the core, src/vsc_rod.h). Evaluation functions write
/// into its scratch, so one rod must not be evaluated from two threads at once
/// (give each thread its own rod).
typedef struct vsc_rod vsc_rod;

/// Validate `def` and build a rod. On success *out owns a new rod (release
/// with vsc_rod_destroy); on failure *out is NULL.
vsc_status vsc_rod_create(const vsc_rod_def* def, vsc_rod** out);

/// Heap bytes vsc_rod_create would allocate for `def` (its arrays, the sphere
/// grid and the contact lists), from the same sizes it allocates. Returned as
/// a double so that no product overflows. vsc_rod_create refuses a definition
/// above VSC_MAX_ROD_BYTES with VSC_ERROR_OUT_OF_MEMORY.
double vsc_rod_memory_bytes(const vsc_rod_def* def);

/// Release a rod created by vsc_rod_create (NULL is allowed).
void vsc_rod_destroy(vsc_rod* rod);

/// Half-bandwidth of the rod's force Jacobian over its 3n unknowns: the band
/// size the vsc_jacobian.h functions write.
int vsc_rod_jacobian_half_width(const vsc_rod* rod);

/// The rod's control points n.
int vsc_rod_control_count(const vsc_rod* rod);

/// The rod's spring sample points N (vsc_rod_sample_point, vsc_place.h, places one).
int vsc_rod_sample_count(const vsc_rod* rod);

/// The collision sphere centres (m, 3 per sphere) as the last evaluation placed them (owned by the rod).
const double* vsc_rod_sphere_centres(const vsc_rod* rod);

/// The collision spheres' velocities (m/s, 3 per sphere) as the last
/// evaluation with contacts placed them (owned by the rod).
const double* vsc_rod_sphere_velocities(const vsc_rod* rod);

/// Collision sphere radii (m; the tube's radius there: all `radius` unless it
/// tapers). Rod-owned, fixed at creation.
const double* vsc_rod_sphere_radii(const vsc_rod* rod);

/// The stiffest contact mode's damping rate c omega_contact^2 / k (1/s), as
/// vsc_rod_frequencies last set it (0 before).
double vsc_rod_contact_damping_rate(const vsc_rod* rod);

#endif  // VISCERA_VSC_ROD_H
