// The rod's highest frequencies by power iteration, and the substeps a
// timestep needs (see viscera/vsc_stability.h).
#include "viscera/vsc_stability.h"
#include "vsc_rod.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "vsc_jacobian.h"
#include "vsc_schemes.h"

// The estimate's own scratch, one allocation for one call (at load time).
typedef struct estimate {
  double* system;    // the elastic Jacobian's band, 3n x (jacobian_half_width + 1)
  double* gradient;  // g = dl/dq (3n)
  double* x;         // the power iteration's vector, K x and M x (3n each)
  double* y;
  double* mx;
  vsc_jacobian_scratch jacobian;
  vsc_elastic_scratch samples;  // the samples the Jacobian reads (placed here, at q)
} estimate;

// y = K x for the frequency estimate: with `contact` = 0, the band part of the
// elastic Jacobian in `system` and the global length term's rank-one part
// K_g g (g . x); with `contact` > 0 (N/m), only a penalty spring of that
// stiffness at every sphere in every direction.
static void stiffness_times(const vsc_rod* rod, const double* system, const double* gradient, double contact,
                            const double* x, double* y) {
  int size = 3 * rod->n;
  if (contact > 0.0)  // the contact estimate alone: no elastic band
    memset(y, 0, sizeof(double) * (size_t)size);
  else
    vsc_band_wide_multiply(system, size, rod->jacobian_half_width, x, y);
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
static double largest_eigenvalue(const vsc_rod* rod, const estimate* e, double contact) {
  int size = 3 * rod->n;
  double *x = e->x, *y = e->y, *mx = e->mx;
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
    stiffness_times(rod, e->system, e->gradient, contact, x, y);
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

void vsc_rod_frequencies(vsc_rod* rod, const double* q, int length_implicit, double* elastic, double* contact) {
  int size = 3 * rod->n;
  size_t band = (size_t)size * (size_t)(rod->jacobian_half_width + 1);
  size_t N = (size_t)rod->sample_count;
  double* block = (double*)calloc(band + 4 * (size_t)size + VSC_JACOBIAN_SCRATCH_DOUBLES(N) + 10 * N, sizeof(double));
  if (!block) {  // (a few hundred kB at most)
    *elastic = *contact = 0.0;
    return;
  }
  estimate e = {block, block + band, block + band + size, block + band + 2 * size, block + band + 3 * size, {0}, {0}};
  e.jacobian.sample_hessian = block + band + 4 * (size_t)size;
  vsc_elastic_scratch_carve(&e.samples, block + band + 4 * (size_t)size + VSC_JACOBIAN_SCRATCH_DOUBLES(N),
                            rod->sample_count);
  vsc_elastic_place(rod, &e.samples, q);
  vsc_world world = {{0, 0, 0}, NULL, 0};
  double* gradient = e.gradient;
  vsc_jacobian_add(rod, &e.jacobian, &e.samples, NULL, &world, q, 1.0, 0.0, e.system, gradient);
  for (int k = 0; k < rod->n; ++k)  // a kick that takes the global length term implicitly does not see its mode
    if (rod->is_pinned[k] || length_implicit) gradient[3 * k] = gradient[3 * k + 1] = gradient[3 * k + 2] = 0.0;
  *elastic = sqrt(largest_eigenvalue(rod, &e, 0.0));
  memset(gradient, 0, sizeof(double) * (size_t)size);  // contact alone: no global term either
  // a self-contact presses two spheres apart: twice the stiffness on their relative motion
  double squared = largest_eigenvalue(rod, &e, rod->def.contact_stiffness) * (rod->def.self_collision ? 2.0 : 1.0);
  free(block);
  *contact = sqrt(squared);
  // the contact springs' mode is also their damping's: c omega^2 / k (1/s)
  rod->contact_damping_rate = rod->def.contact_damping * squared / rod->def.contact_stiffness;
}

int vsc_stable_substeps(vsc_integrator integrator, double elastic, double contact, double contact_damping_rate,
                        double dt) {
  // an undamped mode of frequency omega: RK4 holds for omega h < 2 sqrt(2) =
  // 2.83 (we trust 2.7: abdomen.xml's 3 m, 250 points run at 1 ms substeps,
  // 0.95 of their limit), symplectic Euler and leapfrog for omega h < 2 (we
  // trust 1.8), less with damping where it is explicit (the scheme table's
  // explicit_damping): a mode of frequency omega and damping rate gamma holds
  // for omega^2 h^2 + 2 gamma h < 4 (the undamped limit omega h < 2 falls to 1
  // at gamma = 1.5 omega).
  // Elastic modes are axial, contact modes mostly across the axis: the larger
  // of the two frequencies sets the limit. The implicit step takes the elastic
  // terms and the rigid contacts' normal springs implicitly, friction and
  // self-contacts explicitly, as symplectic Euler would.
  if ((unsigned)integrator >= VSC_INTEGRATOR_COUNT) return 1;
  const vsc_scheme* scheme = &vsc_schemes[integrator];
  double omega = scheme->elastic_implicit ? contact : (elastic > contact ? elastic : contact);
  double trusted = scheme->trusted_omega_h;
  double h = trusted / omega;  // largest substep we trust (s)
  if (!(h > 0.0) || !(dt > 0.0)) return 1;
  double substeps = ceil(dt / h * (1.0 - 1e-12));
  if (substeps < 1.0) substeps = 1.0;
  double gamma = contact_damping_rate > 0.0 && isfinite(contact_damping_rate) ? contact_damping_rate : 0.0;
  // the stiffest elastic mode and the stiffest damped contact mode are taken as one: a bound, as the
  // cavity's piled loops, pressed by a tool, come near it (at abdomen.xml's 3 substeps they diverge).
  // Their contact pass may limit a pile's gamma h to VSC_KICK_DAMPING_LIMIT: no more than that counts.
  if (scheme->explicit_damping && gamma > 0.0)  // omega^2 h^2 + 2 min(gamma h, the limit) <= trusted^2
    for (; substeps < VSC_MAX_AUTO_SUBSTEPS; substeps += 1.0) {
      double hs = dt / substeps, damped = gamma * hs < VSC_KICK_DAMPING_LIMIT ? gamma * hs : VSC_KICK_DAMPING_LIMIT;
      if (omega * omega * hs * hs + 2.0 * damped <= trusted * trusted) break;
    }
  return substeps > VSC_MAX_AUTO_SUBSTEPS ? VSC_MAX_AUTO_SUBSTEPS : (int)substeps;
}

double vsc_stable_damping_limit(vsc_integrator integrator, double elastic, double contact, double contact_damping_rate,
                                double dt, int substeps) {
  if ((unsigned)integrator >= VSC_INTEGRATOR_COUNT || substeps < 1 || !(dt > 0.0)) return VSC_CONTACT_DAMPING_LIMIT;
  const vsc_scheme* scheme = &vsc_schemes[integrator];
  if (!scheme->explicit_damping) return VSC_CONTACT_DAMPING_LIMIT;
  double omega = elastic > contact ? elastic : contact, h = dt / substeps, trusted = scheme->trusted_omega_h;
  double gamma = contact_damping_rate > 0.0 && isfinite(contact_damping_rate) ? contact_damping_rate : 0.0;
  return omega * omega * h * h + 2.0 * gamma * h > trusted * trusted ? VSC_KICK_DAMPING_LIMIT : VSC_CONTACT_DAMPING_LIMIT;
}
