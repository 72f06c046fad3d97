// The rod's mechanical energies (see viscera/vsc_energy.h).
#include "viscera/vsc_energy.h"
#include "vsc_rod.h"

#include <string.h>

#include "viscera/vsc_band.h"
#include "vsc_elastic.h"

double vsc_rod_active_energy(vsc_rod* rod, const double* q, const double* v) {
  size_t bytes = sizeof(double) * 3 * (size_t)rod->n;
  double* known_q = rod->work.energy_state;
  double* known_v = known_q + 3 * rod->n;
  if (rod->work.energy_known && memcmp(known_q, q, bytes) == 0 && memcmp(known_v, v, bytes) == 0)
    return rod->work.energy_active;  // the step's end, now the next step's start
  rod->work.energy_active = vsc_rod_kinetic_energy(rod, v) + vsc_rod_elastic_energy(rod, q);
  memcpy(known_q, q, bytes);
  memcpy(known_v, v, bytes);
  rod->work.energy_known = 1;
  return rod->work.energy_active;
}

double vsc_rod_gravity_energy(const vsc_rod* rod, const double gravity[3], const double* q) {
  double e = 0.0;
  for (int k = 0; k < rod->n; ++k)
    e -= rod->mass_row_sum[k] * (gravity[0] * q[3 * k] + gravity[1] * q[3 * k + 1] + gravity[2] * q[3 * k + 2]);
  return e;
}

double vsc_rod_kinetic_energy(vsc_rod* rod, const double* v) {
  if (rod->def.lumped_mass) {
    double e = 0.0;
    for (int k = 0; k < rod->n; ++k) {
      const double* vk = v + 3 * k;
      e += 0.5 * rod->mass_band[4 * k + 3] * (vk[0] * vk[0] + vk[1] * vk[1] + vk[2] * vk[2]);
    }
    return e;
  }
  double* Mv = rod->work.stage;  // scratch
  vsc_band_multiply3(rod->mass_band, rod->n, v, Mv);
  double e = 0.0;
  for (int i = 0; i < 3 * rod->n; ++i) e += 0.5 * v[i] * Mv[i];
  return e;
}
