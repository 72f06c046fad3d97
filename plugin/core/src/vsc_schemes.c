// The integrators' substeps on (q, v)' = (v, a(q, v)), and the table that
// names them (viscera/vsc_integrate.h's VSC_INTEGRATORS). Each substep sets
// the context's wrench weight before each force evaluation, so the reactions
// of all a step's evaluations add up to their average over the step, and
// leaves in context->unseen the velocity change it made after its last
// evaluation read v (NULL: none), for friction (vsc_friction.h).
#include "vsc_schemes.h"

#include <math.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "viscera/vsc_grasp.h"
#include "vsc_contact.h"
#include "vsc_elastic.h"
#include "vsc_forces.h"
#include "vsc_place.h"
#include "vsc_sleep.h"

// Classical 4th-order Runge-Kutta: 4 force evaluations a substep, stable to
// h < 2.8 / omega_max, energy error O(h^4) (it loses energy, never gains).
vsc_status vsc_rk4_substep(vsc_step_context* context, double* q, double* v, double h) {
  const vsc_rod* rod = context->rod;
  double weight = h / (6.0 * context->dt);
  int size = 3 * rod->n;
  double* q0 = rod->stages.scheme->stage;
  double* v0 = q0 + size;
  double* qs = v0 + size;     // stage position
  double* vs = qs + size;     // stage velocity
  double* a = vs + size;      // stage acceleration
  double* dq = a + size;      // weighted sum of position slopes
  double* dv = dq + size;     // weighted sum of velocity slopes
  memcpy(q0, q, sizeof(double) * size);
  memcpy(v0, v, sizeof(double) * size);
  // stage 1 at (q0, v0)
  context->wrench_weight = weight;
  vsc_forces_acceleration(context, q0, v0, a);
  for (int i = 0; i < size; ++i) {
    dq[i] = v0[i];
    dv[i] = a[i];
    qs[i] = q0[i] + 0.5 * h * v0[i];
    vs[i] = v0[i] + 0.5 * h * a[i];
  }
  // stages 2 and 3 at half steps
  static const double next_fraction[2] = {0.5, 1.0};
  context->wrench_weight = 2.0 * weight;
  for (int stage = 0; stage < 2; ++stage) {
    vsc_forces_acceleration(context, qs, vs, a);
    double f = next_fraction[stage] * h;
    for (int i = 0; i < size; ++i) {
      double vi = vs[i];
      dq[i] += 2.0 * vi;
      dv[i] += 2.0 * a[i];
      qs[i] = q0[i] + f * vi;
      vs[i] = v0[i] + f * a[i];
    }
  }
  // stage 4 at the full step (its velocity is the end's to O(h^2): friction reads it as is)
  context->unseen = NULL;
  context->wrench_weight = weight;
  vsc_forces_acceleration(context, qs, vs, a);
  double sixth = h / 6.0;
  for (int i = 0; i < size; ++i) {
    q[i] = q0[i] + sixth * (dq[i] + vs[i]);
    v[i] = v0[i] + sixth * (dv[i] + a[i]);
  }
  return VSC_OK;
}

// The mass-proportional damping c (1/s) in the acceleration is -c v; a kick
// v += h a applies it as v (1 - c h). Adding (e^{-c h} - 1 + c h) v makes it
// exact, v e^{-c h} (a uniform motion decays as exp(-c t) whatever h), at no cost.
static double exact_damping_correction(const vsc_rod* rod, double h) {
  double ch = rod->def.damping * h;
  return expm1(-ch) + ch;
}

// x <- (A + s g g')^-1 A x by Sherman-Morrison, given u = A^-1 g (both n long):
// x - s (g.x) / (1 + s g.u) u. The kick's and the implicit step's rank-one term.
static void rank_one_update(double* x, const double* g, const double* u, double s, int size) {
  double gx = 0.0, gu = 0.0;
  for (int i = 0; i < size; ++i) {
    gx += g[i] * x[i];
    gu += g[i] * u[i];
  }
  double scale = s * gx / (1.0 + s * gu);
  for (int i = 0; i < size; ++i) x[i] -= scale * u[i];
}

// The global length term K_g (l - length) is one stiff spring on the whole
// axis (the paper's 200 N/m on a light bowel is the anatomical small bowel's
// highest elastic mode: 2265 rad/s, its springs' 1082). The kick takes it
// implicitly, dv <- (M + s g g')^-1 M dv with s = h^2 K_g (kg) and g = dl/dq:
// a mode along g of frequency omega is kicked as if omega^2 were
// omega^2 / (1 + h^2 omega^2) < 1 / h^2, so leapfrog holds it at any h, and at
// rest dv = 0 stays 0. As g turns with the rod the scheme is no longer exactly
// symplectic: an undamped swinging rod gains about 3e-4 of its swing energy a
// second (tests/c/test_integrate.c), against the e^(-2 c t) of any mass
// damping c (1/s; the default 1). Sherman-Morrison on M:
// dv - s (g.dv) / (1 + s g.M^-1 g) M^-1 g, one gradient and one mass solve,
// O(n). Points held still (pinned, asleep) take no part: their rows of g are 0.
static void implicit_length_kick(const vsc_rod* rod, double h, double* dv) {
  double stiffness = h * h * rod->def.global_stretch_stiffness;  // s (kg)
  if (!(stiffness > 0.0)) return;
  int n = rod->n, size = 3 * n;
  double* g = rod->stages.scheme->stage + size;  // the stage block's second and third slices are free in a kick
  double* u = g + size;
  const unsigned char* asleep = vsc_sleep_points(rod->stages.sleep);
  vsc_elastic_length_gradient(rod, rod->stages.elastic, asleep, g);
  for (int k = 0; k < n; ++k)
    if (rod->is_pinned[k] || (asleep && asleep[k])) g[3 * k] = g[3 * k + 1] = g[3 * k + 2] = 0.0;
  if (rod->def.lumped_mass) {
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) u[3 * k + c] = rod->mass_factor[4 * k + 3] * g[3 * k + c];
  } else {
    memcpy(u, g, sizeof(double) * (size_t)size);
    vsc_band_solve3(rod->mass_factor, n, u);
  }
  rank_one_update(dv, g, u, stiffness, size);
}

// One force evaluation: drift q by `before` of the substep, kick v with the
// forces there (the global length term implicitly where the step asks), drift
// the rest.
// Symplectic Euler kicks first (before = 0); leapfrog drifts half, kicks,
// drifts half (before = 1/2): the midpoint evaluation is what makes it second
// order at the same cost.
static vsc_status drift_kick_drift(vsc_step_context* context, double* q, double* v, double h, double before) {
  const vsc_rod* rod = context->rod;
  int size = 3 * rod->n;
  double* a = rod->stages.scheme->stage;
  double first = before * h, second = (1.0 - before) * h;
  if (before > 0.0)
    for (int i = 0; i < size; ++i) q[i] += first * v[i];
  context->wrench_weight = h / context->dt;
  vsc_forces_acceleration(context, q, v, a);
  double exact = exact_damping_correction(rod, h);
  for (int i = 0; i < size; ++i) a[i] = h * a[i] + exact * v[i];  // now the velocity change
  if (context->length_implicit) implicit_length_kick(rod, h, a);
  for (int i = 0; i < size; ++i) {
    v[i] += a[i];
    q[i] += second * v[i];
  }
  context->unseen = a;
  return VSC_OK;
}

// Symplectic (semi-implicit) Euler, v += h a(q, v), then q += h v: 1
// evaluation a substep, stable to h < 2 / omega_max (less with damping, see
// vsc_stable_substeps), first order, and its energy error stays bounded (it
// conserves a nearby energy). The mass-proportional damping is exact, v e^(-c h).
vsc_status vsc_symplectic_euler_substep(vsc_step_context* context, double* q, double* v, double h) {
  return drift_kick_drift(context, q, v, h, 0.0);
}

// Leapfrog (Stormer-Verlet, drift-kick-drift): q += h/2 v, v += h a(q, v),
// q += h/2 v. 1 evaluation a substep and the same stability limit as
// symplectic Euler (h < 2 / omega_max, less with damping), but second
// order, time-reversible and symplectic on the conservative forces (contact
// damping and friction, which read the substep's start velocity, are first
// order in their rates; the mass-proportional damping is exact, v e^(-c h)).
// The default: the shipped scenes' step is bound by stability, where its one
// evaluation buys 0.7 of RK4's four's substep.
vsc_status vsc_leapfrog_substep(vsc_step_context* context, double* q, double* v, double h) {
  return drift_kick_drift(context, q, v, h, 0.5);
}

// Reactions of the linearised forces: the force evaluation at the substep start
// wrote those at (q0, v0); add the change the linearisation predicts at (q1, v1),
// so the geoms and anchors receive the impulse the rod's solve used.
static void correct_reactions(const vsc_step_context* context, const double* dq, const double* dv) {
  const vsc_rod* rod = context->rod;
  const vsc_world* world = context->world;
  double weight = context->wrench_weight;
  double* reaction = context->reactions->grasp_force;
  for (int g = 0; g < world->grasp_count && reaction; ++g) {
    const vsc_grasp* grasp = &world->grasps[g];
    vsc_basis b = vsc_spline_basis(rod->n, grasp->abscissa);
    double moved[3], accelerated[3];
    vsc_basis_point(&b, dq, moved);
    vsc_basis_point(&b, dv, accelerated);
    for (int c = 0; c < 3; ++c)  // the rod's force changed by -k dP - c dV; the anchor's opposite
      reaction[3 * g + c] += weight * (grasp->stiffness * moved[c] + grasp->damping * accelerated[c]);
  }
  double* geom_wrench = context->reactions->geom_wrench;
  if (!geom_wrench) return;
  double normal[3], k = rod->def.contact_stiffness, c = rod->def.contact_damping;
  const vsc_touch_records* touch = &rod->stages.contact->touch;
  for (int i = 0; i < rod->def.collision_sphere_count && world->geom_count > 0; ++i) {
    int geom = vsc_touch_rigid(touch, i, normal);
    if (geom < 0) continue;
    const vsc_basis* b = &rod->sphere_basis[i];
    double moved[3], accelerated[3];
    vsc_basis_point(b, dq, moved);
    vsc_basis_point(b, dv, accelerated);
    double change = -(k * (moved[0] * normal[0] + moved[1] * normal[1] + moved[2] * normal[2]) +
                      c * (accelerated[0] * normal[0] + accelerated[1] * normal[1] + accelerated[2] * normal[2]));
    double f[3] = {change * normal[0], change * normal[1], change * normal[2]};  // on the sphere
    const double* x = rod->stages.placement->sphere_xyz + 3 * i;  // at the substep start: the lever arm's first order is enough
    const double* p = world->geoms[geom].position;
    double r = rod->sphere_radius[i];
    double arm[3] = {x[0] - r * normal[0] - p[0], x[1] - r * normal[1] - p[1], x[2] - r * normal[2] - p[2]};
    vsc_wrench_add(geom_wrench + 6 * geom, -weight, f, NULL, arm);
  }
}

// Linearly implicit (backward) Euler: one Newton step of backward Euler per
// substep, [(1 + h c) M + h D + h^2 K] v1 = M v0 + h (Q + D v0), q1 = q0 + h v1,
// with K and D the band Jacobians of vsc_jacobian.h (the global stretch
// term's rank-one part by Sherman-Morrison): O(n), 1 evaluation a substep.
// A-stable (L-stable) on the linearised forces, so the elastic and rigid
// contact stiffness never limit h; first order, and it damps motion whose
// period is not resolved by h. Self-contacts and friction stay explicit.
vsc_status vsc_implicit_substep(vsc_step_context* context, double* q, double* v, double h) {
  const vsc_rod* rod = context->rod;
  const vsc_world* world = context->world;
  vsc_scheme_scratch* scratch = rod->stages.scheme;
  const vsc_touch_records* touch = &rod->stages.contact->touch;
  int size = 3 * rod->n, w = rod->jacobian_half_width;
  double* q0 = scratch->stage;
  double* v0 = q0 + size;
  double* rhs = v0 + size;       // generalised forces, then the right-hand side
  double* spread = rhs + size;   // A^-1 g for the rank-one global term
  double* gradient = spread + size;
  memcpy(q0, q, sizeof(double) * size);
  memcpy(v0, v, sizeof(double) * size);
  context->wrench_weight = h / context->dt;
  vsc_forces_evaluate(context, q0, v0, rhs);  // Q(q0, v0), and the touch records the Jacobian reads
  // A v1 = M v0 + h (Q + D v0) with A = (1 + h c) M + h D + h^2 K (vsc_integrate.h)
  vsc_jacobian_add_damping_force(rod, touch, world, v0, rhs);
  for (int i = 0; i < size; ++i) rhs[i] *= h;
  double* momentum = spread;  // M v0, before `spread` is needed
  vsc_band_multiply3(rod->mass_band, rod->n, v0, momentum);
  for (int i = 0; i < size; ++i) rhs[i] += momentum[i];
  memset(scratch->system, 0, sizeof(double) * (size_t)size * (size_t)(w + 1));
  vsc_rod_add_mass(rod, 1.0 + h * rod->def.damping, scratch->system);
  // at the samples the evaluation at q0 just placed
  vsc_jacobian_add(rod, &scratch->jacobian, rod->stages.elastic, touch, world, q0, h * h, h, scratch->system, gradient);
  vsc_rod_pin_band(rod, scratch->system);
  for (int p = 0; p < rod->def.pinned_count; ++p)
    for (int c = 0; c < 3; ++c) rhs[3 * rod->pinned[p] + c] = gradient[3 * rod->pinned[p] + c] = 0.0;
  vsc_status status = vsc_band_wide_factor(scratch->system, size, w, scratch->factor_row);
  if (status != VSC_OK) return VSC_ERROR_DIVERGED;
  vsc_band_wide_solve(scratch->system, size, w, rhs);
  double global = h * h * rod->def.global_stretch_stiffness;
  if (global > 0.0) {  // (A + global g g^T)^-1 r, with A^-1 g in `spread`
    memcpy(spread, gradient, sizeof(double) * size);
    vsc_band_wide_solve(scratch->system, size, w, spread);
    rank_one_update(rhs, gradient, spread, global, size);
  }
  for (int i = 0; i < size; ++i) {
    v[i] = rhs[i];
    q[i] = q0[i] + h * v[i];
  }
  double* dq = rhs;  // q1 - q0 and v1 - v0 for the reactions (v and q hold the result)
  double* dv = spread;
  for (int i = 0; i < size; ++i) {
    dq[i] = q[i] - q0[i];
    dv[i] = v[i] - v0[i];
  }
  correct_reactions(context, dq, dv);
  context->unseen = dv;
  return VSC_OK;
}

#define VSC_SCHEME_ROW_(id, name, substep, trusted, explicit_damping, length_implicit, elastic_implicit, phase_c, phase_p) \
  [VSC_INTEGRATOR_##id] = {name, substep, trusted, explicit_damping, length_implicit, elastic_implicit, phase_c, phase_p},
const vsc_scheme vsc_schemes[VSC_INTEGRATOR_COUNT] = {VSC_INTEGRATORS(VSC_SCHEME_ROW_)};

#define VSC_SCHEME_NAME_(id, name, substep, trusted, explicit_damping, length_implicit, elastic_implicit, phase_c, phase_p) \
  [VSC_INTEGRATOR_##id] = name,
const char* const vsc_integrator_names[VSC_INTEGRATOR_COUNT + 1] = {VSC_INTEGRATORS(VSC_SCHEME_NAME_) NULL};

int vsc_integrator_length_implicit(vsc_integrator integrator) {
  return (unsigned)integrator < VSC_INTEGRATOR_COUNT && vsc_schemes[integrator].length_implicit;
}
