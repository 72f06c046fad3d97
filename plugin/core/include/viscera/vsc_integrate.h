// Time integration of the rod: leapfrog (the default), the paper's RK4 (France
// et al. 2002, 3.1.4), symplectic Euler and linearly implicit Euler; the
// substeps a timestep needs; divergence recovery.
#ifndef VISCERA_VSC_INTEGRATE_H
#define VISCERA_VSC_INTEGRATE_H

#include "viscera/vsc_rod.h"

/// Integrators selectable by name.
typedef enum vsc_integrator {
  /// Classical 4th-order Runge-Kutta: 4 force evaluations a substep, stable to
  /// h < 2.8 / omega_max, energy error O(h^4) (it loses energy, never gains).
  VSC_INTEGRATOR_RK4 = 0,
  /// Symplectic (semi-implicit) Euler, v += h a(q, v), then q += h v: 1
  /// evaluation a substep, stable to h < 2 / omega_max (less with damping, see
  /// vsc_stable_substeps), first order, and its energy error stays bounded (it
  /// conserves a nearby energy). The mass-proportional damping is exact, v e^(-c h).
  VSC_INTEGRATOR_SYMPLECTIC_EULER = 1,
  /// Linearly implicit (backward) Euler: one Newton step of backward Euler per
  /// substep, [(1 + h c) M + h D + h^2 K] v1 = M v0 + h (Q + D v0), q1 = q0 + h v1,
  /// with K and D the band Jacobians of vsc_jacobian.h (the global stretch
  /// term's rank-one part by Sherman-Morrison): O(n), 1 evaluation a substep.
  /// A-stable (L-stable) on the linearised forces, so the elastic and rigid
  /// contact stiffness never limit h; first order, and it damps motion whose
  /// period is not resolved by h. Self-contacts and friction stay explicit.
  VSC_INTEGRATOR_IMPLICIT = 2,
  /// Leapfrog (Stormer-Verlet, drift-kick-drift): q += h/2 v, v += h a(q, v),
  /// q += h/2 v. 1 evaluation a substep and the same stability limit as
  /// symplectic Euler (h < 2 / omega_max, less with damping), but second
  /// order, time-reversible and symplectic on the conservative forces (contact
  /// damping and friction, which read the substep's start velocity, are first
  /// order in their rates; the mass-proportional damping is exact, v e^(-c h)).
  /// The default: the shipped scenes' step is bound by stability, where its one
  /// evaluation buys 0.7 of RK4's four's substep.
  VSC_INTEGRATOR_LEAPFROG = 3,
} vsc_integrator;

/// How many integrators there are (the enum's values are 0 to this less 1).
#define VSC_INTEGRATOR_COUNT 4

/// A finite state counts as diverged when a control point moves faster than
/// this (m/s): nothing in a surgical scene does.
#define VSC_DIVERGED_SPEED 100.0

/// Retries stop doubling the substeps past this many per step, so that a step
/// that cannot hold costs a bounded time (about 2 x this many substeps).
#define VSC_MAX_RETRY_SUBSTEPS 1024

/// How vsc_rod_step integrates and when it calls a step diverged.
typedef struct vsc_step_options {
  vsc_integrator integrator;
  int substeps;              ///< substeps per step (>= 1)
  int retries;               ///< on divergence, retry up to this many times, doubling the substeps (>= 0)
  double energy_jump_ratio;  ///< a step diverged if the rod's energy grows by more than this times
                             ///< its kinetic + elastic (+ contact) energy at the step start ...
  double energy_jump_speed;  ///< ... plus 1/2 mass speed^2 (m/s): the energy of the whole rod at this speed
} vsc_step_options;

/// Leapfrog, 1 substep, 4 retries (up to 16 substeps), jump bound 1 x energy + 1/2 m (3 m/s)^2.
vsc_step_options vsc_default_step_options(void);

/// What a step did.
typedef struct vsc_step_report {
  int retries;    ///< attempts after the first (0: the first attempt held)
  int substeps;   ///< substeps of the last attempt
} vsc_step_report;

/// Advance q (m), v (m/s) and the friction state `stick` (VSC_STICK_SIZE per
/// sphere, may be NULL) in place by one step dt (s) of options->substeps
/// substeps. The world (geom poses, grasp anchors) is frozen over dt. If
/// world->geom_wrench is set it receives (overwritten, not added) the reaction
/// on each geom averaged over dt, and each grasp's `reaction` likewise: the
/// impulse the geoms receive is the one the rod gave (for the implicit
/// integrator, its linearised forces at the step end).
///
/// Divergence: a substep diverges when the state becomes non-finite or faster
/// than VSC_DIVERGED_SPEED, or its factorisation fails; a step diverges when
/// one of its substeps does or its energy (kinetic + elastic + gravity +, when
/// that alone jumps, the contact penalty's potential, vsc_rod_contact_energy)
/// jumps past the options' bound: a rod pushed out of a geom turns the
/// penalty's potential into motion, which is no divergence. A diverged step is retried from its start with
/// twice the substeps, up to options->retries times and VSC_MAX_RETRY_SUBSTEPS
/// substeps; VSC_OK is returned if an
/// attempt held (report->retries > 0 then says it was recovered). If none
/// held, q and the friction state are restored to the step start, v is zeroed,
/// reactions are zeroed and VSC_ERROR_DIVERGED is returned. Either way the
/// state stays finite. `report` may be NULL.
vsc_status vsc_rod_step(vsc_rod* rod, const vsc_world* world, double* q, double* v, double* stick, double dt,
                        const vsc_step_options* options, vsc_step_report* report);

/// Most power iterations of the frequency estimate (each O(n)); it stops
/// earlier, usually after 10 to 20, once omega^2 changes by less than 1e-3 in
/// one (it then lies within about 1 % below the limit: the trusted bounds below
/// leave 5 to 10 %).
#define VSC_FREQUENCY_ITERATIONS 100

/// ... and at most this many band entries times iterations (at least 12
/// iterations): a million control points take 12, about a second.
#define VSC_FREQUENCY_WORK 4e7

/// Largest omega h (omega: a mode's angular frequency, h: the substep) that
/// vsc_stable_substeps trusts: RK4's limit is 2 sqrt(2) = 2.83, symplectic
/// Euler's 2 (95 % and 90 % of them; the estimate matches the measured limits
/// within 4 %, docs/validation's stability map).
#define VSC_RK4_TRUSTED_OMEGA_H 2.7
#define VSC_EULER_TRUSTED_OMEGA_H 1.8

/// vsc_stable_substeps never asks for more.
#define VSC_MAX_AUTO_SUBSTEPS 1024

/// Highest angular frequencies (rad/s) of the rod linearised at q (m): of its
/// elastic forces (M^-1 K, pinned points held), and of its contact springs
/// alone, every sphere pressed by a geom in every direction (a rod lying on a
/// plane has exactly that across it), times sqrt(2) with self-collision (a
/// pair presses two spheres). Power iteration, O(n) per iteration. Also sets
/// rod->contact_damping_rate. Overwrites the rod's scratch (samples, stages,
/// the implicit system).
void vsc_rod_frequencies(vsc_rod* rod, const double* q, double* elastic, double* contact);

/// Fewest substeps of `integrator` for a step dt (s) with omega h within the
/// trusted bound above, omega from the frequencies (rad/s) of
/// vsc_rod_frequencies (explicit integrators: the larger; implicit: contact,
/// whose friction and self-contacts it takes explicitly); for leapfrog and
/// symplectic Euler, which apply damping explicitly, omega^2 h^2 + 2 g h
/// within the bound's square, g the contact damping rate (1/s,
/// rod->contact_damping_rate after vsc_rod_frequencies; 0: none); 1 to
/// VSC_MAX_AUTO_SUBSTEPS.
int vsc_stable_substeps(vsc_integrator integrator, double elastic, double contact, double contact_damping_rate,
                        double dt);

#endif  // VISCERA_VSC_INTEGRATE_H
