// The contact load and the damping limit (see vsc_contact_load.h).
#include "vsc_contact_load.h"

#include <math.h>
#include <string.h>

static double abs_weight_sum(const vsc_basis* b) {
  double sum = 0.0;
  for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) sum += fabs(b->weight[j]);
  return sum;
}

// Add each loaded sphere's Gershgorin row, sum over spheres of |w_ks| load_s sum_j |w_js|, to `row` (n).
static int add_rows(const vsc_rod* rod, const double* load, double* row) {
  int touched = 0;
  for (int s = 0; s < rod->def.collision_sphere_count; ++s) {
    if (load[s] == 0.0) continue;
    const vsc_basis* b = &rod->sphere_basis[s];
    double spread = abs_weight_sum(b) * load[s];
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) row[b->first + j] += fabs(b->weight[j]) * spread;
    touched = 1;
  }
  return touched;
}

void vsc_contact_load_prepare(vsc_rod* rod, vsc_contact_load* contact_load) {
  int n = rod->n, spheres = rod->def.collision_sphere_count;
  double* load = contact_load->stiffness;
  double* row = load + spheres;
  double* inverse_mass = row + n;
  for (int k = 0; k < n; ++k)  // pinned points do not move: no bound there
    inverse_mass[k] = !rod->is_pinned[k] && rod->mass_row_sum[k] > 0.0 ? 1.0 / rod->mass_row_sum[k] : 0.0;
  for (int s = 0; s < spheres; ++s) load[s] = 1.0;
  add_rows(rod, load, row);
  double unit = 0.0;
  for (int k = 0; k < n; ++k) {
    double bound = row[k] * inverse_mass[k];
    if (bound > unit) unit = bound;
    row[k] = 0.0;
  }
  for (int s = 0; s < spheres; ++s) load[s] = 0.0;
  rod->contact_load_unit = unit;
  contact_load->bound = 0.0;
}

int vsc_contact_load_limit_damping(const vsc_rod* rod, vsc_contact_load* contact_load, double h, double limit) {
  int n = rod->n, spheres = rod->def.collision_sphere_count;
  double* load = contact_load->stiffness;
  double* row = load + spheres;
  const double* inverse_mass = row + n;
  // gamma h per unit of load: the damping is c / k of the stiffness, both per contact
  double per_load = rod->def.contact_damping / rod->def.contact_stiffness * h;
  contact_load->bound = 0.0;
  // first a bound of the bound, from the most loaded sphere: below the limit, the
  // ordinary case, nothing is limited and the rows need not be summed
  double most = 0.0;
  for (int s = 0; s < spheres; ++s) most = load[s] > most ? load[s] : most;
  if (!(per_load * most * rod->contact_load_unit > limit)) {
    if (most > 0.0) memset(load, 0, sizeof(double) * (size_t)spheres);
    return 0;
  }
  add_rows(rod, load, row);
  double peak = 0.0;
  for (int k = 0; k < n; ++k) {
    row[k] *= per_load * inverse_mass[k];  // now the bound on gamma h at control point k
    peak = row[k] > peak ? row[k] : peak;
  }
  contact_load->bound = peak;
  int limited = peak > limit;
  for (int s = 0; s < spheres && limited; ++s) {
    double scale = 1.0;
    const vsc_basis* b = &rod->sphere_basis[s];
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) {
      double bound = row[b->first + j];
      if (bound > limit && limit / bound < scale)
        scale = limit / bound;
    }
    contact_load->damping_scale[s] = scale;
  }
  memset(load, 0, sizeof(double) * (size_t)(spheres + n));
  return limited;
}
