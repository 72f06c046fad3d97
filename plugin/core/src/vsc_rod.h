// The rod's layout: its caches and scratch, private to the core (and its tests).
// The public API (viscera/vsc_rod.h) sees vsc_rod as an opaque handle.
#ifndef VISCERA_SRC_VSC_ROD_H
#define VISCERA_SRC_VSC_ROD_H

#include "viscera/vsc_grid.h"
#include "viscera/vsc_rod.h"

/// A control point's sleep within a step (vsc_sleep.c): awake; asleep within
/// VSC_SLEEP_REACH of an awake point (its forces are still evaluated, so a
/// change in its load wakes it); asleep deeper (its elastic forces are not
/// gathered, nor its contacts with static geoms and with other deep spheres
/// looked for; those with moving geoms and awake segments still are).
enum { VSC_AWAKE = 0, VSC_ASLEEP_EDGE = 1, VSC_ASLEEP_DEEP = 2 };

// Each stage's state, declared by the module that owns it: only that module
// writes it; the stages after it read it through const pointers.
typedef struct vsc_placement vsc_placement;              // vsc_place.h: the placed spheres
typedef struct vsc_elastic_scratch vsc_elastic_scratch;  // vsc_elastic.h: samples, edges, sample forces
typedef struct vsc_contact_lists vsc_contact_lists;      // vsc_contact_lists.h: the broad phase
typedef struct vsc_contact_pass vsc_contact_pass;        // vsc_contact.h: the narrow phase's contacts
typedef struct vsc_sleep_flags vsc_sleep_flags;          // vsc_sleep.h: this step's sleeping points
typedef struct vsc_scheme_scratch vsc_scheme_scratch;    // vsc_schemes.h: integrator stages, the system
typedef struct vsc_step_backup vsc_step_backup;          // vsc_step.h: the step start, the guard's cache

/// Where each stage's state lives: carved from the rod's one allocation at
/// creation (the lists' and the found contacts' arrays grow on their own).
/// Only the rod's creation, the evaluation (vsc_forces.c), the step
/// (vsc_step.c) and the schemes (vsc_schemes.c) reach in here, to hand each
/// stage its own.
typedef struct vsc_rod_stages {
  vsc_placement* placement;
  vsc_elastic_scratch* elastic;
  vsc_contact_lists* broad_phase;
  vsc_contact_pass* contact;
  vsc_sleep_flags* sleep;
  vsc_scheme_scratch* scheme;
  vsc_step_backup* backup;
} vsc_rod_stages;

/// A rod (viscera/vsc_rod.h): the definition and what is derived from it at
/// creation, read only after it; and apart, in `stages`, what evaluations and
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
  vsc_rod_stages stages;     ///< what evaluations and steps write, stage by stage
  void* block;               ///< the one allocation every array lives in (vsc_rod.c's size table)
};

#endif  // VISCERA_SRC_VSC_ROD_H
