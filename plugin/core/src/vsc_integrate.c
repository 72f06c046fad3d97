// RK4, symplectic Euler and linearly implicit Euler on (q, v)' = (v, a(q, v)),
// and the step driver that detects divergence and retries (see vsc_integrate.h).
#include "viscera/vsc_integrate.h"

#include <math.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "vsc_contact_internal.h"
#include "viscera/vsc_grasp.h"
#include "viscera/vsc_jacobian.h"

vsc_step_options vsc_default_step_options(void) {
  vsc_step_options options = {VSC_INTEGRATOR_LEAPFROG, 1, 4, 1.0, 3.0};
  return options;
}

// Leapfrog and symplectic Euler evaluate once a substep and apply damping
// explicitly, which shrinks their stable substep: a mode of frequency omega and
// damping rate gamma holds for omega^2 h^2 + 2 gamma h < 4 (4 - 2 gamma h:
// the undamped limit omega h < 2 falls to 1 at gamma = 1.5 omega).
static int damping_limits(vsc_integrator integrator) {
  return integrator == VSC_INTEGRATOR_LEAPFROG || integrator == VSC_INTEGRATOR_SYMPLECTIC_EULER;
}

static int state_is_sane(const double* q, const double* v, int size) {
  for (int i = 0; i < size; ++i)
    if (!isfinite(q[i]) || !(fabs(v[i]) < VSC_DIVERGED_SPEED)) return 0;
  return 1;
}

// `world` is this step's copy; its wrench weight is set per evaluation so the
// reactions of all evaluations add up to their average over the whole step dt.
// Each substep writes to *unseen the velocity change (3n, m/s) it made after its
// last force evaluation read v, or NULL (see vsc_rod_update_stick).

static vsc_status rk4_substep(vsc_rod* rod, vsc_world* world, double* q, double* v, double h, double dt,
                              const double** unseen) {
  double weight = h / (6.0 * dt);
  int size = 3 * rod->n;
  double* q0 = rod->stage;
  double* v0 = q0 + size;
  double* qs = v0 + size;     // stage position
  double* vs = qs + size;     // stage velocity
  double* a = vs + size;      // stage acceleration
  double* dq = a + size;      // weighted sum of position slopes
  double* dv = dq + size;     // weighted sum of velocity slopes
  memcpy(q0, q, sizeof(double) * size);
  memcpy(v0, v, sizeof(double) * size);
  // stage 1 at (q0, v0)
  world->wrench_weight = weight;
  vsc_rod_acceleration(rod, world, q0, v0, a);
  for (int i = 0; i < size; ++i) {
    dq[i] = v0[i];
    dv[i] = a[i];
    qs[i] = q0[i] + 0.5 * h * v0[i];
    vs[i] = v0[i] + 0.5 * h * a[i];
  }
  // stages 2 and 3 at half steps
  static const double next_fraction[2] = {0.5, 1.0};
  world->wrench_weight = 2.0 * weight;
  for (int stage = 0; stage < 2; ++stage) {
    vsc_rod_acceleration(rod, world, qs, vs, a);
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
  *unseen = NULL;
  world->wrench_weight = weight;
  vsc_rod_acceleration(rod, world, qs, vs, a);
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

// One force evaluation: drift q by `before` of the substep, kick v with the
// forces there, drift the rest. Symplectic Euler kicks first (before = 0);
// leapfrog drifts half, kicks, drifts half (before = 1/2): the midpoint
// evaluation is what makes it second order at the same cost.
static vsc_status drift_kick_drift(vsc_rod* rod, vsc_world* world, double* q, double* v, double h, double dt,
                                   double before, const double** unseen) {
  int size = 3 * rod->n;
  double* a = rod->stage;
  double first = before * h, second = (1.0 - before) * h;
  if (before > 0.0)
    for (int i = 0; i < size; ++i) q[i] += first * v[i];
  world->wrench_weight = h / dt;
  vsc_rod_acceleration(rod, world, q, v, a);
  double exact = exact_damping_correction(rod, h);
  for (int i = 0; i < size; ++i) {
    a[i] = h * a[i] + exact * v[i];  // now the velocity change
    v[i] += a[i];
    q[i] += second * v[i];
  }
  *unseen = a;
  return VSC_OK;
}

// Reactions of the linearised forces: the force evaluation at the substep start
// wrote those at (q0, v0); add the change the linearisation predicts at (q1, v1),
// so the geoms and anchors receive the impulse the rod's solve used.
static void correct_reactions(vsc_rod* rod, const vsc_world* world, const double* dq, const double* dv) {
  double weight = world->wrench_weight;
  for (int g = 0; g < world->grasp_count; ++g) {
    vsc_grasp* grasp = &world->grasps[g];
    vsc_basis b = vsc_spline_basis(rod->n, grasp->abscissa);
    double moved[3], accelerated[3];
    vsc_basis_point(&b, dq, moved);
    vsc_basis_point(&b, dv, accelerated);
    for (int c = 0; c < 3; ++c)  // the rod's force changed by -k dP - c dV; the anchor's opposite
      grasp->reaction[c] += weight * (grasp->stiffness * moved[c] + grasp->damping * accelerated[c]);
  }
  if (!world->geom_wrench) return;
  double normal[3], k = rod->def.contact_stiffness, c = rod->def.contact_damping, r = rod->def.radius;
  for (int i = 0; i < rod->def.collision_sphere_count && world->geom_count > 0; ++i) {
    int geom = vsc_rod_rigid_touch(rod, i, normal);
    if (geom < 0) continue;
    const vsc_basis* b = &rod->sphere_basis[i];
    double moved[3], accelerated[3];
    vsc_basis_point(b, dq, moved);
    vsc_basis_point(b, dv, accelerated);
    double change = -(k * (moved[0] * normal[0] + moved[1] * normal[1] + moved[2] * normal[2]) +
                      c * (accelerated[0] * normal[0] + accelerated[1] * normal[1] + accelerated[2] * normal[2]));
    double f[3] = {change * normal[0], change * normal[1], change * normal[2]};  // on the sphere
    const double* x = rod->sphere_xyz + 3 * i;  // at the substep start: the lever arm's first order is enough
    const double* p = world->geoms[geom].position;
    double arm[3] = {x[0] - r * normal[0] - p[0], x[1] - r * normal[1] - p[1], x[2] - r * normal[2] - p[2]};
    vsc_wrench_add(world->geom_wrench + 6 * geom, -weight, f, NULL, arm);
  }
}

static vsc_status implicit_substep(vsc_rod* rod, vsc_world* world, double* q, double* v, double h, double dt,
                                   const double** unseen) {
  int size = 3 * rod->n, w = rod->jacobian_half_width;
  double* q0 = rod->stage;
  double* v0 = q0 + size;
  double* rhs = v0 + size;       // generalised forces, then the right-hand side
  double* spread = rhs + size;   // A^-1 g for the rank-one global term
  double* gradient = spread + size;
  memcpy(q0, q, sizeof(double) * size);
  memcpy(v0, v, sizeof(double) * size);
  world->wrench_weight = h / dt;
  vsc_rod_forces(rod, world, q0, v0, rhs);  // Q(q0, v0), and the touch records the Jacobian reads
  // A v1 = M v0 + h (Q + D v0) with A = (1 + h c) M + h D + h^2 K (vsc_integrate.h)
  vsc_rod_add_damping_force(rod, world, v0, rhs);
  for (int i = 0; i < size; ++i) rhs[i] *= h;
  double* momentum = spread;  // M v0, before `spread` is needed
  vsc_band_multiply3(rod->mass_band, rod->n, v0, momentum);
  for (int i = 0; i < size; ++i) rhs[i] += momentum[i];
  memset(rod->system, 0, sizeof(double) * (size_t)size * (size_t)(w + 1));
  vsc_rod_add_mass(rod, 1.0 + h * rod->def.damping, rod->system);
  vsc_rod_add_jacobian(rod, world, q0, h * h, h, rod->system, gradient);
  vsc_rod_pin_band(rod, rod->system);
  for (int p = 0; p < rod->def.pinned_count; ++p)
    for (int c = 0; c < 3; ++c) rhs[3 * rod->pinned[p] + c] = gradient[3 * rod->pinned[p] + c] = 0.0;
  vsc_status status = vsc_band_wide_factor(rod->system, size, w, rod->factor_row);
  if (status != VSC_OK) return VSC_ERROR_DIVERGED;
  vsc_band_wide_solve(rod->system, size, w, rhs);
  double global = h * h * rod->def.global_stretch_stiffness;
  if (global > 0.0) {  // (A + global g g^T)^-1 r = x - (global g.x / (1 + global g.A^-1 g)) A^-1 g
    memcpy(spread, gradient, sizeof(double) * size);
    vsc_band_wide_solve(rod->system, size, w, spread);
    double gx = 0.0, gy = 0.0;
    for (int i = 0; i < size; ++i) {
      gx += gradient[i] * rhs[i];
      gy += gradient[i] * spread[i];
    }
    double scale = global * gx / (1.0 + global * gy);
    for (int i = 0; i < size; ++i) rhs[i] -= scale * spread[i];
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
  correct_reactions(rod, world, dq, dv);
  *unseen = dv;
  return VSC_OK;
}

static vsc_status substep(vsc_integrator integrator, vsc_rod* rod, vsc_world* world, double* q, double* v,
                          double h, double dt, const double** unseen) {
  *unseen = NULL;
  switch (integrator) {
    case VSC_INTEGRATOR_SYMPLECTIC_EULER: return drift_kick_drift(rod, world, q, v, h, dt, 0.0, unseen);
    case VSC_INTEGRATOR_IMPLICIT: return implicit_substep(rod, world, q, v, h, dt, unseen);
    case VSC_INTEGRATOR_LEAPFROG: return drift_kick_drift(rod, world, q, v, h, dt, 0.5, unseen);
    case VSC_INTEGRATOR_RK4: return rk4_substep(rod, world, q, v, h, dt, unseen);
    default: return VSC_ERROR_INVALID_ARGUMENT;
  }
}

static double mechanical_energy(vsc_rod* rod, const vsc_world* world, const double* q, const double* v,
                                double* kinetic_elastic) {
  *kinetic_elastic = vsc_rod_active_energy(rod, q, v);
  return *kinetic_elastic + vsc_rod_gravity_energy(rod, world->gravity, q);
}

static void clear_reactions(const vsc_world* world) {
  if (world->geom_wrench) memset(world->geom_wrench, 0, sizeof(double) * 6 * (size_t)world->geom_count);
  for (int g = 0; g < world->grasp_count; ++g)
    world->grasps[g].reaction[0] = world->grasps[g].reaction[1] = world->grasps[g].reaction[2] = 0.0;
}

// One attempt at the whole step with `substeps` substeps: 0 if it diverged.
static int attempt(vsc_rod* rod, vsc_world* world, double* q, double* v, double* stick, double dt, int substeps,
                   vsc_integrator integrator) {
  int size = 3 * rod->n;
  double h = dt / (double)substeps;
  clear_reactions(world);
  for (int s = 0; s < substeps; ++s) {
    const double* unseen;
    if (substep(integrator, rod, world, q, v, h, dt, &unseen) != VSC_OK || !state_is_sane(q, v, size)) return 0;
    if (stick) vsc_rod_update_stick(rod, stick, h, unseen);  // from the last evaluation's contacts
  }
  return 1;
}

vsc_status vsc_rod_step(vsc_rod* rod, const vsc_world* world, double* q, double* v, double* stick, double dt,
                        const vsc_step_options* options, vsc_step_report* report) {
  vsc_step_options o = options ? *options : vsc_default_step_options();
  if (o.substeps < 1 || o.retries < 0 || !(dt > 0.0) || !(o.energy_jump_ratio >= 0.0) ||
      !(o.energy_jump_speed >= 0.0) || (unsigned)o.integrator >= VSC_INTEGRATOR_COUNT)
    return VSC_ERROR_INVALID_ARGUMENT;
  vsc_world step_world = *world;
  step_world.stick = stick;
  int size = 3 * rod->n, spheres = rod->def.collision_sphere_count;
  for (int i = 0; i < rod->def.pinned_count; ++i) {  // pinned means fixed, whatever the state said
    double* pinned_velocity = v + 3 * rod->pinned[i];
    pinned_velocity[0] = pinned_velocity[1] = pinned_velocity[2] = 0.0;
  }
  double* start_q = rod->backup;
  double* start_v = start_q + size;
  double* start_stick = start_v + size;
  memcpy(start_q, q, sizeof(double) * size);
  memcpy(start_v, v, sizeof(double) * size);
  if (stick) memcpy(start_stick, stick, sizeof(double) * VSC_STICK_SIZE * (size_t)spheres);
  double start_active;
  double start_energy = mechanical_energy(rod, world, q, v, &start_active);
  double slack = 0.5 * rod->def.mass * o.energy_jump_speed * o.energy_jump_speed;
  double allowed = o.energy_jump_ratio * start_active + slack;
  // The contact penalty's potential (J) enters the balance only when the
  // balance without it fails: a rod pushed out of a geom turns it into kinetic
  // energy legitimately. Evaluated lazily, as it costs a narrow phase.
  int contacts = world->geom_count > 0 || rod->def.self_collision;
  double start_contact = -1.0;  // not evaluated yet
  int substeps = o.substeps;
  for (int retry = 0; retry <= o.retries; ++retry) {
    if (retry > 0) {  // from the step start again, with twice the substeps
      memcpy(q, start_q, sizeof(double) * size);
      memcpy(v, start_v, sizeof(double) * size);
      if (stick) memcpy(stick, start_stick, sizeof(double) * VSC_STICK_SIZE * (size_t)spheres);
      if (2 * substeps > VSC_MAX_RETRY_SUBSTEPS) break;
      substeps *= 2;
    }
    if (report) {
      report->retries = retry;
      report->substeps = substeps;
    }
    if (!attempt(rod, &step_world, q, v, stick, dt, substeps, o.integrator)) continue;
    double active, energy = mechanical_energy(rod, world, q, v, &active);
    if (isfinite(energy) && energy - start_energy <= allowed) return VSC_OK;
    if (!contacts || !isfinite(energy)) continue;
    // start first, end last: the rod's spheres and contact lists are left at the accepted q
    if (start_contact < 0.0) start_contact = vsc_rod_contact_energy(rod, world, start_q, NULL);
    double end_contact = vsc_rod_contact_energy(rod, world, q, NULL);
    double jump = energy + end_contact - (start_energy + start_contact);
    // the allowance grows with the stored contact energy: an embedded rod may release it,
    // but no more than that (a blow-up from deep contact still trips the guard)
    if (jump <= o.energy_jump_ratio * (start_active + start_contact) + slack) return VSC_OK;
  }
  memcpy(q, start_q, sizeof(double) * size);
  memset(v, 0, sizeof(double) * size);
  if (!state_is_sane(q, v, size)) memset(q, 0, sizeof(double) * size);
  if (stick) vsc_stick_clear(stick, spheres);
  clear_reactions(world);
  return VSC_ERROR_DIVERGED;
}

// y = K x for the frequency estimate: with `contact` = 0, the band part of the
// elastic Jacobian in rod->system and the global length term's rank-one part
// K_g g (g . x); with `contact` > 0 (N/m), only a penalty spring of that
// stiffness at every sphere in every direction.
static void stiffness_times(vsc_rod* rod, const double* gradient, double contact, const double* x, double* y) {
  int size = 3 * rod->n;
  if (contact > 0.0)  // the contact estimate alone: no elastic band
    memset(y, 0, sizeof(double) * (size_t)size);
  else
    vsc_band_wide_multiply(rod->system, size, rod->jacobian_half_width, x, y);
  double gx = 0.0;
  for (int i = 0; i < size; ++i) gx += gradient[i] * x[i];
  for (int i = 0; i < size; ++i) y[i] += rod->def.global_stretch_stiffness * gx * gradient[i];
  for (int s = 0; s < rod->def.collision_sphere_count && contact > 0.0; ++s) {
    const vsc_basis* b = &rod->sphere_basis[s];
    double p[3];
    vsc_basis_point(b, x, p);
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j)
      for (int c = 0; c < 3; ++c) y[3 * (b->first + j) + c] += contact * b->weight[j] * p[c];
  }
  for (int k = 0; k < rod->n; ++k)
    if (rod->is_pinned[k]) y[3 * k] = y[3 * k + 1] = y[3 * k + 2] = 0.0;
}

// Power iteration on M^-1 K: the largest omega^2 (rad^2/s^2), from below.
static double largest_eigenvalue(vsc_rod* rod, const double* gradient, double contact) {
  int size = 3 * rod->n;
  double* x = rod->stage + 3 * size;  // the first three are the caller's gradient and scratch
  double* y = x + size;
  double* mx = y + size;
  // start near the highest mode: neighbours in opposition, along every axis
  for (int k = 0; k < rod->n; ++k)
    for (int c = 0; c < 3; ++c)
      x[3 * k + c] = (rod->is_pinned[k] ? 0.0 : 1.0) * ((k & 1) ? -1.0 : 1.0) * (1.0 + 0.37 * c + 0.01 * (k % 7));
  double lambda = 0.0;
  // a bounded cost for huge rods: the estimate is then a little lower (the retries catch the rest)
  double work = (double)size * (double)(rod->jacobian_half_width + 1);
  int iterations = VSC_FREQUENCY_WORK / work < VSC_FREQUENCY_ITERATIONS ? (int)(VSC_FREQUENCY_WORK / work) : VSC_FREQUENCY_ITERATIONS;
  if (iterations < 12) iterations = 12;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    stiffness_times(rod, gradient, contact, x, y);
    vsc_band_multiply3(rod->mass_band, rod->n, x, mx);
    double xkx = 0.0, xmx = 0.0;
    for (int i = 0; i < size; ++i) {
      xkx += x[i] * y[i];
      xmx += x[i] * mx[i];
    }
    if (!(xmx > 0.0)) return lambda;  // every point pinned
    double previous = lambda;
    lambda = xkx / xmx;  // Rayleigh quotient
    vsc_band_solve3(rod->mass_factor, rod->n, y);
    double norm = 0.0;
    for (int k = 0; k < rod->n; ++k) {
      if (rod->is_pinned[k]) y[3 * k] = y[3 * k + 1] = y[3 * k + 2] = 0.0;
      for (int c = 0; c < 3; ++c) norm += y[3 * k + c] * y[3 * k + c];
    }
    if (!(norm > 0.0) || !isfinite(norm)) return lambda;  // no stiffness at all
    norm = 1.0 / sqrt(norm);
    for (int i = 0; i < size; ++i) x[i] = y[i] * norm;
    if (iteration > 8 && fabs(lambda - previous) <= 1e-3 * lambda) break;
  }
  return lambda;
}

void vsc_rod_frequencies(vsc_rod* rod, const double* q, double* elastic, double* contact) {
  int size = 3 * rod->n;
  vsc_world world = {{0, 0, 0}, NULL, 0};
  double* gradient = rod->stage;
  memset(rod->system, 0, sizeof(double) * (size_t)size * (size_t)(rod->jacobian_half_width + 1));
  vsc_rod_add_jacobian(rod, &world, q, 1.0, 0.0, rod->system, gradient);
  for (int k = 0; k < rod->n; ++k)
    if (rod->is_pinned[k]) gradient[3 * k] = gradient[3 * k + 1] = gradient[3 * k + 2] = 0.0;
  *elastic = sqrt(largest_eigenvalue(rod, gradient, 0.0));
  memset(gradient, 0, sizeof(double) * (size_t)size);  // contact alone: no global term either
  // a self-contact presses two spheres apart: twice the stiffness on their relative motion
  double squared = largest_eigenvalue(rod, gradient, rod->def.contact_stiffness) * (rod->def.self_collision ? 2.0 : 1.0);
  *contact = sqrt(squared);
  // the contact springs' mode is also their damping's: c omega^2 / k (1/s)
  rod->contact_damping_rate = rod->def.contact_damping * squared / rod->def.contact_stiffness;
}

int vsc_stable_substeps(vsc_integrator integrator, double elastic, double contact, double contact_damping_rate,
                        double dt) {
  // an undamped mode of frequency omega: RK4 holds for omega h < 2 sqrt(2) =
  // 2.83 (we trust 2.7: abdomen.xml's 3 m, 250 points run at 1 ms substeps,
  // 0.95 of their limit), symplectic Euler and leapfrog for omega h < 2 (we
  // trust 1.8), less with damping (see damping_limits).
  // Elastic modes are axial, contact modes mostly across the axis: the larger
  // of the two frequencies sets the limit. The implicit step takes the elastic
  // terms and the rigid contacts' normal springs implicitly, friction and
  // self-contacts explicitly, as symplectic Euler would.
  double omega = integrator == VSC_INTEGRATOR_IMPLICIT ? contact : (elastic > contact ? elastic : contact);
  double trusted = integrator == VSC_INTEGRATOR_RK4 ? VSC_RK4_TRUSTED_OMEGA_H : VSC_EULER_TRUSTED_OMEGA_H;
  double h = trusted / omega;  // largest substep we trust (s)
  if (!(h > 0.0) || !(dt > 0.0)) return 1;
  double substeps = ceil(dt / h * (1.0 - 1e-12));
  if (substeps < 1.0) substeps = 1.0;
  double gamma = contact_damping_rate > 0.0 && isfinite(contact_damping_rate) ? contact_damping_rate : 0.0;
  // the stiffest elastic mode and the stiffest damped contact mode are taken as one: a bound, as the
  // cavity's piled loops, pressed by a tool, come near it (at abdomen.xml's 3 substeps they diverge)
  if (damping_limits(integrator) && gamma > 0.0)  // omega^2 h^2 + 2 gamma h <= trusted^2
    for (; substeps < VSC_MAX_AUTO_SUBSTEPS; substeps += 1.0) {
      double hs = dt / substeps;
      if (omega * omega * hs * hs + 2.0 * gamma * hs <= trusted * trusted) break;
    }
  return substeps > VSC_MAX_AUTO_SUBSTEPS ? VSC_MAX_AUTO_SUBSTEPS : (int)substeps;
}
