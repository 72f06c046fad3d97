// The rod's mechanical energies (see viscera/vsc_energy.h).
#include "vsc_energy.h"

#include "viscera/vsc_band.h"

double vsc_energy_active(const vsc_rod* rod, vsc_elastic_scratch* elastic, double* mass_times_v, const double* q,
                         const double* v) {
  return vsc_energy_kinetic(rod, v, mass_times_v) + vsc_elastic_energy(rod, elastic, q);
}

double vsc_rod_gravity_energy(const vsc_rod* rod, const double gravity[3], const double* q) {
  double e = 0.0;
  for (int k = 0; k < rod->n; ++k)
    e -= rod->mass_row_sum[k] * (gravity[0] * q[3 * k] + gravity[1] * q[3 * k + 1] + gravity[2] * q[3 * k + 2]);
  return e;
}

double vsc_energy_kinetic(const vsc_rod* rod, const double* v, double* Mv) {
  if (rod->def.lumped_mass) {
    double e = 0.0;
    for (int k = 0; k < rod->n; ++k) {
      const double* vk = v + 3 * k;
      e += 0.5 * rod->mass_band[4 * k + 3] * (vk[0] * vk[0] + vk[1] * vk[1] + vk[2] * vk[2]);
    }
    return e;
  }
  vsc_band_multiply3(rod->mass_band, rod->n, v, Mv);
  double e = 0.0;
  for (int i = 0; i < 3 * rod->n; ++i) e += 0.5 * v[i] * Mv[i];
  return e;
}
