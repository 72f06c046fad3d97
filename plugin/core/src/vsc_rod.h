// The rod's layout: its caches and scratch, private to the core (and its tests).
// The public API (viscera/vsc_rod.h) sees vsc_rod as an opaque handle.
#ifndef VISCERA_SRC_VSC_ROD_H
#define VISCERA_SRC_VSC_ROD_H

#include "viscera/vsc_grid.h"
#include "viscera/vsc_rod.h"

typedef struct vsc_contact_lists vsc_contact_lists;  // see vsc_contact_lists.c

/// A control point's sleep within a step (vsc_sleep.c): awake; asleep within
/// VSC_SLEEP_REACH of an awake point (its forces are still evaluated, so a
/// change in its load wakes it); asleep deeper (its elastic forces are not
/// gathered, nor its contacts with static geoms and with other deep spheres
/// looked for; those with moving geoms and awake segments still are).
enum { VSC_AWAKE = 0, VSC_ASLEEP_EDGE = 1, VSC_ASLEEP_DEEP = 2 };

/// What a rod's evaluations and steps write: per-evaluation scratch, the state
/// kept across a step's attempts and between steps (the contact lists, the
/// energy cache), and this step's sleep flags. Everything here is overwritten
/// by the core as it goes; the rest of struct vsc_rod is fixed at creation.
typedef struct vsc_rod_work {
  // per evaluation; structure of arrays so the spring loops vectorise
  double* sample_x;          ///< sample positions (N each) (m)
  double* sample_y;
  double* sample_z;
  double* force_x;           ///< elastic forces on samples (N each) (N)
  double* force_y;
  double* force_z;
  double* edge_x;            ///< spring vectors, then tension vectors (N each)
  double* edge_y;
  double* edge_z;
  double* edge_length;       ///< spring lengths (N) (m)
  double* scratch;           ///< the block holding sample_x .. edge_length (10 N)
  double* sphere_xyz;        ///< collision sphere centres (3 x spheres) (m)
  double* sphere_velocity;   ///< collision sphere velocities (3 x spheres) (m/s)
  double* stage;             ///< integrator stages (8 x 3n)
  double* sample_hessian;    ///< sample-level Jacobian blocks, 3 x 3 x 3 per sample (vsc_jacobian.c)
  double* system;            ///< the implicit step's matrix, wide band 3n x (jacobian_half_width + 1)
  double* factor_row;        ///< factorisation scratch (jacobian_half_width + 1)
  // contacts
  vsc_grid* grid;            ///< sphere grid, cell = 2 (radius + margin / 2)
  vsc_contact_lists* lists;  ///< candidate contacts, rebuilt through the grid when spheres or geoms move
  double* touch;             ///< per sphere, the last evaluation's strongest contacts (VSC_TOUCH_SIZE each)
  int touched;               ///< 1 if the last evaluation looked for contacts (touch is current)
  double* contact_load;      ///< per sphere, the contact pass's stiffness (N/m), then per control point
                             ///< its Gershgorin row (n), both zero between passes, then the inverse
                             ///< lumped masses (n, 1/kg; 0 where pinned; set at creation) (vsc_contact_load.h)
  double* damping_scale;     ///< per sphere, the factor (<= 1) on its contacts' damping in a limited pass
  void* found;               ///< the contacts the pass found, before their forces (vsc_contact.c; own
                             ///< allocation, grown as needed)
  int found_count;           ///< contacts in `found`
  int found_capacity;        ///< contacts `found` holds
  double contact_load_bound; ///< the last pass's largest bound on gamma h (vsc_contact_load.h)
  // the step
  double* backup;            ///< the step-start state kept for retries: q, v (3n each), friction state,
                             ///< then energy_state
  double* energy_state;      ///< q, v (3n each) at which energy_active was computed
  double energy_active;      ///< kinetic + elastic energy at energy_state (J)
  int energy_known;          ///< 1 once energy_state holds a state
  // sleep, this step's
  unsigned char* asleep;     ///< per control point this step: VSC_AWAKE, VSC_ASLEEP_EDGE or VSC_ASLEEP_DEEP (n; vsc_sleep.c)
  unsigned char* sphere_asleep;  ///< per sphere, the least asleep of the 4 points it depends on (spheres)
  int asleep_count;          ///< control points asleep this step (0: the flags above are all 0, unread)
  unsigned char* moved;      ///< 1 where control point k moved in the last step (n; vsc_sleep.c scratch)
  unsigned char* unbalanced; ///< 1 where a sleeping edge point's forces changed this step (n)
  double* rest;              ///< this step's rest records, borrowed from the host for the step's length
                             ///< (VSC_REST_SIZE per point; NULL: none sleeps)
} vsc_rod_work;

/// A rod (viscera/vsc_rod.h): the definition and what is derived from it at
/// creation, read only after it; and apart, in `work`, what evaluations and
/// steps write. Owns all its arrays (one allocation, `block`).
struct vsc_rod {
  vsc_rod_def def;           ///< copy of the definition (def.pinned points to `pinned`)
  int n;                     ///< control points
  int sample_count;          ///< spring sample points N
  double rest_spacing;       ///< l0 (m)
  double stretch_spring;     ///< k_s per spring (N/m)
  double bend_spring;        ///< k_b per spring (N/m)
  // a tapered tube's section factors (NULL untapered: every factor 1)
  double* stretch_scale;     ///< A(r) / A(r0) at each stretch spring's middle (N - 1)
  double* bend_scale;        ///< I(r) / I(r0) at each bend spring's middle sample (N - 2): curvature_scale + 1
  double* curvature_scale;   ///< I(r) / I(r0) at each sample, for the curvature term and the clamps (N)
  vsc_basis* sample_basis;   ///< basis of each sample (N)
  vsc_basis* sphere_basis;   ///< basis of each collision sphere (collision_sphere_count)
  vsc_basis* tether_basis;   ///< basis of each mesentery tether's abscissa (mesentery_points)
  double* mass_band;         ///< M, band layout of vsc_band.h (n x 4) (kg)
  double* mass_factor;       ///< Cholesky factor of M with pinned rows replaced by identity (n x 4)
  double* mass_row_sum;      ///< sum_j M_kj, the gravity weights (n) (kg)
  int* pinned;               ///< pinned indices (pinned_count)
  unsigned char* is_pinned;  ///< 1 where control point k is pinned (n)
  int* gather_first;         ///< first sample that control point k depends on (n)
  int* gather_count;         ///< number of consecutive samples it depends on (n)
  int* gather_offset;        ///< start of its weights in gather_weight (n)
  double* gather_weight;     ///< b_k(s_a) for those samples: the transpose of sample_basis
  double* sphere_radius;     ///< collision sphere radii, the tube's there (spheres) (m)
  double radius_max;         ///< the largest of them (m): what the broad phase inflates by
  int tapered;               ///< 1: they differ (radius_end given and not radius): contacts interpolate them
  int jacobian_half_width;   ///< half-bandwidth of the force Jacobian over the 3n unknowns (vsc_jacobian.h)
  int self_gap;              ///< segments closer than this many indices never collide (see vsc_contact.h)
  double contact_load_unit;  ///< the largest row per unit stiffness at every sphere (1/kg)
  double contact_damping_rate;  ///< the stiffest contact mode's damping rate, c omega_contact^2 / k (1/s),
                                ///< set by vsc_rod_frequencies (0 before)
  vsc_rod_work work;         ///< what evaluations and steps write
  void* block;               ///< the one allocation every array lives in (vsc_rod.c's size table)
};

#endif  // VISCERA_SRC_VSC_ROD_H
