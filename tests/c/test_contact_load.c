// The contact load's damping limit (src/vsc_contact_load.h): ordinary loads are
// left alone; where many contacts pile on a few spheres, the scaled damping
// keeps every control point's Gershgorin bound on gamma h at the limit, and
// the one-contact-per-sphere unit matches the lumped mass it is built on.
#include <math.h>
#include <string.h>

#include "viscera/vsc_rod.h"
#include "vsc_contact.h"
#include "vsc_rod.h"
#include "vsc_test.h"

// The contact pass's load, the stage state these tests drive directly.
#define LOAD(rod) (&(rod)->stages.contact->load)

static vsc_rod* rod_of(int control_points, int spheres) {
  vsc_rod_def def = vsc_default_rod_def();
  def.control_count = control_points;
  def.length = 1.0;
  def.collision_sphere_count = spheres;
  vsc_rod* rod = NULL;
  ENSURE(vsc_rod_create(&def, &rod) == VSC_OK);
  return rod;
}

// gamma h at control point k for the per-sphere loads `load` (N/m) scaled by `scale` (NULL: 1).
static double bound_at(const vsc_rod* rod, const double* load, const double* scale, int k, double h) {
  double row = 0.0;
  for (int s = 0; s < rod->def.collision_sphere_count; ++s) {
    const vsc_basis* b = &rod->sphere_basis[s];
    double spread = 0.0, w = 0.0;
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) {
      spread += fabs(b->weight[j]);
      if (b->first + j == k) w = fabs(b->weight[j]);
    }
    row += w * spread * load[s] * (scale ? scale[s] : 1.0);
  }
  return rod->def.contact_damping / rod->def.contact_stiffness * h * row / rod->mass_row_sum[k];
}

// One unit of stiffness at every sphere: the unit is the largest row over the lumped mass,
// about (spheres per control point) x (sum of |weights|)^2 / (mass per point).
static void unit_is_the_uniform_bound(void) {
  vsc_rod* rod = rod_of(40, 81);
  double load[81];
  for (int s = 0; s < 81; ++s) load[s] = rod->def.contact_stiffness;
  double peak = 0.0;
  for (int k = 0; k < 40; ++k) {
    double bound = bound_at(rod, load, NULL, k, 1.0);
    peak = bound > peak ? bound : peak;
  }
  double per_unit = rod->def.contact_damping / rod->def.contact_stiffness * rod->def.contact_stiffness;
  ENSURE_NEAR(rod->contact_load_unit * per_unit, peak, 1e-9 * peak);
  vsc_rod_destroy(rod);
}

// The shipped scenes' ordinary contacts: one per sphere along the rod, at the 3-substep h of a
// 2 ms step: far below the limit, nothing limited, and the load cleared for the next pass.
static void ordinary_contacts_are_untouched(void) {
  vsc_rod* rod = rod_of(40, 81);
  for (int s = 0; s < 81; ++s) vsc_contact_load_add(LOAD(rod), s, rod->def.contact_stiffness);
  ENSURE(vsc_contact_load_limit_damping(rod, LOAD(rod), 0.002 / 3.0, VSC_CONTACT_DAMPING_LIMIT) == 0);
  for (int s = 0; s < 81; ++s) ENSURE(LOAD(rod)->stiffness[s] == 0.0);
  vsc_rod_destroy(rod);
}

// A pile squeezed under a tool: 14 self contacts on each of a few spheres (measured in the
// cavity). Limited, the scaled loads keep every control point at or below the limit, the
// scales stay in (0, 1], and spheres far from the pile keep their damping.
static void a_squeezed_pile_is_limited_to_the_bound(void) {
  vsc_rod* rod = rod_of(40, 81);
  double load[81] = {0.0}, h = 0.002 / 3.0;
  for (int s = 30; s <= 36; ++s) load[s] = 14.0 * 2.0 * rod->def.contact_stiffness;
  load[70] = rod->def.contact_stiffness;  // an ordinary contact elsewhere
  for (int s = 0; s < 81; ++s) vsc_contact_load_add(LOAD(rod), s, load[s]);
  ENSURE(vsc_contact_load_limit_damping(rod, LOAD(rod), h, VSC_CONTACT_DAMPING_LIMIT) == 1);
  ENSURE(LOAD(rod)->bound > VSC_CONTACT_DAMPING_LIMIT);
  double worst = 0.0, unscaled = 0.0;
  for (int k = 0; k < 40; ++k) {
    double b = bound_at(rod, load, LOAD(rod)->damping_scale, k, h);
    worst = b > worst ? b : worst;
    double u = bound_at(rod, load, NULL, k, h);
    unscaled = u > unscaled ? u : unscaled;
  }
  ENSURE_NEAR(unscaled, LOAD(rod)->bound, 1e-9 * unscaled);
  ENSURE(worst <= VSC_CONTACT_DAMPING_LIMIT * (1.0 + 1e-12));
  ENSURE(worst >= 0.5 * VSC_CONTACT_DAMPING_LIMIT);  // limited to the bound, not far below it
  for (int s = 30; s <= 36; ++s) ENSURE(LOAD(rod)->damping_scale[s] > 0.0 && LOAD(rod)->damping_scale[s] < 1.0);
  ENSURE(LOAD(rod)->damping_scale[70] == 1.0);
  vsc_rod_destroy(rod);
}

// The kick schemes' limit, below 1, holds a pile that the explicit limit 2 leaves alone to
// gamma h <= 0.9 at every control point, and leaves an ordinary contact alone.
static void the_kick_limit_is_lower(void) {
  vsc_rod* rod = rod_of(40, 81);
  double load[81] = {0.0}, h = 0.001;
  for (int s = 30; s <= 36; ++s) load[s] = rod->def.contact_stiffness;
  double peak = 0.0;
  for (int k = 0; k < 40; ++k) peak = fmax(peak, bound_at(rod, load, NULL, k, h));
  double pile = 1.4 / peak;  // a pile between the two limits: gamma h 1.4 at its worst point
  for (int s = 30; s <= 36; ++s) load[s] *= pile;
  load[70] = rod->def.contact_stiffness;  // an ordinary contact elsewhere (gamma h under 0.9)
  ENSURE(bound_at(rod, load, NULL, 70 * 39 / 80, h) < VSC_KICK_DAMPING_LIMIT);
  for (int s = 0; s < 81; ++s) vsc_contact_load_add(LOAD(rod), s, load[s]);
  ENSURE(vsc_contact_load_limit_damping(rod, LOAD(rod), h, VSC_CONTACT_DAMPING_LIMIT) == 0);
  for (int s = 0; s < 81; ++s) vsc_contact_load_add(LOAD(rod), s, load[s]);
  ENSURE(vsc_contact_load_limit_damping(rod, LOAD(rod), h, VSC_KICK_DAMPING_LIMIT) == 1);
  double worst = 0.0;
  for (int k = 0; k < 40; ++k) worst = fmax(worst, bound_at(rod, load, LOAD(rod)->damping_scale, k, h));
  ENSURE(worst <= VSC_KICK_DAMPING_LIMIT * (1.0 + 1e-12) && worst >= 0.5 * VSC_KICK_DAMPING_LIMIT);
  ENSURE(LOAD(rod)->damping_scale[70] == 1.0);
  vsc_rod_destroy(rod);
}

int main(void) {
  RUN(unit_is_the_uniform_bound);
  RUN(ordinary_contacts_are_untouched);
  RUN(a_squeezed_pile_is_limited_to_the_bound);
  RUN(the_kick_limit_is_lower);
  TEST_MAIN_END();
}
