// The rod's mechanical energies (see viscera/vsc_energy.h): computed where
// needed, writing nothing, so the divergence guard's queries have no side effects.
#include "viscera/vsc_energy.h"

#include "viscera/vsc_elastic.h"
#include "vsc_rod.h"

double vsc_rod_active_energy(const vsc_rod* rod, const double* q, const double* v) {
  return vsc_rod_kinetic_energy(rod, v) + vsc_rod_elastic_energy(rod, q);
}

double vsc_rod_gravity_energy(const vsc_rod* rod, const double gravity[3], const double* q) {
  double e = 0.0;
  for (int k = 0; k < rod->n; ++k)
    e -= rod->mass_row_sum[k] * (gravity[0] * q[3 * k] + gravity[1] * q[3 * k + 1] + gravity[2] * q[3 * k + 2]);
  return e;
}

// Band entry M(i, j), j <= i <= j + 3, of vsc_band.h's layout (kg).
static double mass_entry(const vsc_rod* rod, int i, int j) { return rod->mass_band[4 * i + 3 - (i - j)]; }

double vsc_rod_kinetic_energy(const vsc_rod* rod, const double* v) {
  int n = rod->n;
  double e = 0.0;
  if (rod->def.lumped_mass) {
    for (int k = 0; k < n; ++k) {
      const double* vk = v + 3 * k;
      e += 0.5 * rod->mass_band[4 * k + 3] * (vk[0] * vk[0] + vk[1] * vk[1] + vk[2] * vk[2]);
    }
    return e;
  }
  // 1/2 v' M v, row by row: each (M v)_i summed in vsc_band_multiply3's order (its own row's
  // entries left to right, then the rows below's mirrored entries), so the bits are that product's
  for (int i = 0; i < n; ++i) {
    double mv[3] = {0.0, 0.0, 0.0};
    for (int j = i - 3 < 0 ? 0 : i - 3; j <= i; ++j)
      for (int c = 0; c < 3; ++c) mv[c] += mass_entry(rod, i, j) * v[3 * j + c];
    for (int r = i + 1; r <= i + 3 && r < n; ++r)
      for (int c = 0; c < 3; ++c) mv[c] += mass_entry(rod, r, i) * v[3 * r + c];
    for (int c = 0; c < 3; ++c) e += 0.5 * v[3 * i + c] * mv[c];
  }
  return e;
}
