// Time integration of the rod: the integrators (leapfrog, the default; the
// paper's RK4, France et al. 2002, 3.1.4; symplectic Euler; linearly implicit
// Euler) and the step that drives them: substeps, friction, the divergence
// guard and its retries. The substeps a timestep needs are in vsc_stability.h.
#ifndef VISCERA_VSC_INTEGRATE_H
#define VISCERA_VSC_INTEGRATE_H

#include "viscera/vsc_rod.h"
#include "viscera/vsc_sleep.h"

/// Largest omega h (omega: a mode's angular frequency, h: the substep) that
/// vsc_stable_substeps (vsc_stability.h) trusts: RK4's limit is 2 sqrt(2) = 2.83,
/// symplectic Euler's and leapfrog's 2 (95 % and 90 % of them; the estimate
/// matches the measured limits within 4 %, docs/validation's stability map).
#define VSC_RK4_TRUSTED_OMEGA_H 2.7
#define VSC_EULER_TRUSTED_OMEGA_H 1.8

/// The bound on a pile's contact damping rate gamma times the substep h
/// (dimensionless) that a contact pass keeps to (src/vsc_contact_load.h): the
/// explicit limit itself, 2, as the bound is an upper one (no margin needed) ...
#define VSC_CONTACT_DAMPING_LIMIT 2.0

/// ... or, where the stability estimate counted on it to take fewer substeps
/// (vsc_stable_damping_limit), below 1: an explicit kick then never reverses a
/// velocity by its damping, with the 10 % margin of the trusted omega h (1.8 of 2).
#define VSC_KICK_DAMPING_LIMIT 0.9

/// The integrators, one row each: X(ID, name, substep function, trusted omega h,
/// explicit damping, global length term implicit, elastic forces implicit,
/// phase coefficient, phase order).
/// This table is the only list:
/// the enum below, the names the plugin's `integrator` key accepts
/// (vsc_integrator_names) and the scheme table the step, the stability
/// estimate and the tolerance's substeps (vsc_resolution.h) read (src/vsc_schemes.c)
/// all expand it. A new integrator is a row
/// here and its substep function in src/vsc_schemes.c. Each scheme's
/// properties are documented at its function.
///   explicit damping: the scheme applies damping explicitly, which shrinks its
///     stable substep (omega^2 h^2 + 2 gamma h within the trusted bound's square);
///   length implicit: the global length term (a rank-one stiffness, often the
///     rod's stiffest mode) never limits its substep: the kick takes it implicitly;
///   elastic implicit: the elastic forces and the rigid contacts' normal springs
///     never limit its substep (only the explicit self-contacts and friction do);
///   phase coefficient c, order p: an undamped oscillation of frequency omega
///     comes out with a relative error c (omega h)^p: RK4's frequency
///     (omega h)^4 / 120, leapfrog's and symplectic Euler's (omega h)^2 / 24;
///     linearly implicit Euler loses pi omega h of its amplitude a period.
#define VSC_INTEGRATORS(X)                                                                  \
  X(RK4, "rk4", vsc_rk4_substep, VSC_RK4_TRUSTED_OMEGA_H, 0, 0, 0, 1.0 / 120.0, 4)              \
  X(SYMPLECTIC_EULER, "symplectic_euler", vsc_symplectic_euler_substep, VSC_EULER_TRUSTED_OMEGA_H, 1, 1, 0, 1.0 / 24.0, 2) \
  X(IMPLICIT, "implicit", vsc_implicit_substep, VSC_EULER_TRUSTED_OMEGA_H, 0, 1, 1, VSC_PI, 1) \
  X(LEAPFROG, "leapfrog", vsc_leapfrog_substep, VSC_EULER_TRUSTED_OMEGA_H, 1, 1, 0, 1.0 / 24.0, 2)

#define VSC_INTEGRATOR_ENUM_(id, name, substep, trusted, explicit_damping, length_implicit, elastic_implicit, phase_c, phase_p) \
  VSC_INTEGRATOR_##id,
/// Integrators selectable by name, in table order (RK4 = 0, ..., LEAPFROG = 3).
typedef enum vsc_integrator { VSC_INTEGRATORS(VSC_INTEGRATOR_ENUM_) VSC_INTEGRATOR_COUNT } vsc_integrator;
#undef VSC_INTEGRATOR_ENUM_

/// The integrators' names in enum order, NULL-terminated (static storage).
extern const char* const vsc_integrator_names[VSC_INTEGRATOR_COUNT + 1];

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
  int length_implicit;       ///< 1: the kick of the schemes whose row says so (length implicit) takes the
                             ///< global length term implicitly; 0: explicitly, as RK4 does (exactly
                             ///< symplectic, and cheaper where that term is not the stiffest mode)
  double damping_limit;      ///< the bound on a pile's gamma h the contact pass of the schemes that apply
                             ///< damping explicitly keeps to (vsc_stable_damping_limit in vsc_stability.h;
                             ///< in [VSC_KICK_DAMPING_LIMIT, VSC_CONTACT_DAMPING_LIMIT])
  vsc_sleep_options sleep;   ///< which control points sleep (vsc_sleep.h; needs the step's `rest` timers)
} vsc_step_options;

/// 1 if `integrator`'s kick can take the global length term implicitly (its
/// row's length implicit: vsc_step_options.length_implicit then applies), else 0.
int vsc_integrator_length_implicit(vsc_integrator integrator);

/// Leapfrog, 1 substep, 4 retries (up to 16 substeps), jump bound 1 x energy + 1/2 m (3 m/s)^2,
/// the global length term implicit in the kick, damping limit VSC_CONTACT_DAMPING_LIMIT, no sleeping.
vsc_step_options vsc_default_step_options(void);

/// What a step did.
typedef struct vsc_step_report {
  int retries;    ///< attempts after the first (0: the first attempt held)
  int substeps;   ///< substeps of the last attempt
} vsc_step_report;

/// Advance q (m), v (m/s), the friction state `stick` (VSC_STICK_SIZE per
/// sphere, may be NULL) and the rest records `rest` (VSC_REST_SIZE per control
/// point, may be NULL: none sleeps; see vsc_sleep.h) in place by one step dt (s) of options->substeps
/// substeps. The world (geom poses, grasp anchors) is frozen over dt and only
/// read. `reactions` (NULL: not wanted) receives, overwritten, the reaction on
/// each geom and each grasp's anchor averaged over dt: the impulse the geoms
/// receive is the one the rod gave (for the implicit integrator, its
/// linearised forces at the step end).
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
/// state stays finite, and every control point wakes. `report` may be NULL.
///
/// Sleeping (options->sleep enabled, `rest` given): points whose record says
/// they sleep are held still this step; the records then advance and the
/// step's motions and contacts wake points (vsc_sleep.h). A rod asleep
/// everywhere only looks for its contacts with moving bodies' geoms, pushes
/// them, and returns unless one wakes it. VSC_ERROR_INVALID_ARGUMENT if
/// sleeping is asked of the consistent mass matrix or the implicit integrator.
vsc_status vsc_rod_step(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, double* q, double* v,
                        double* stick, double* rest, double dt, const vsc_step_options* options,
                        vsc_step_report* report);

#endif  // VISCERA_VSC_INTEGRATE_H
