// The step (viscera/vsc_integrate.h's vsc_rod_step): its own state, the step
// start kept for retries and the divergence guard's energies; the step
// context (vsc_context.h) and the scheme table (vsc_schemes.h) are apart.
#ifndef VISCERA_SRC_VSC_STEP_H
#define VISCERA_SRC_VSC_STEP_H

#include "viscera/vsc_friction.h"
#include "viscera/vsc_integrate.h"
#include "vsc_context.h"
#include "vsc_elastic.h"

/// The step's state, which it owns, and the energy queries' scratch.
struct vsc_step_backup {
  double* q;                           ///< the step start, kept for retries (3n) (m)
  double* v;                           ///< (3n) (m/s)
  double* stick;                       ///< the friction state (VSC_STICK_SIZE per sphere)
  double* energy_q;                    ///< the state at which energy_active was computed: q (3n) (m)
  double* energy_v;                    ///< and v (3n) (m/s)
  double energy_active;                ///< kinetic + elastic energy there (J)
  int energy_known;                    ///< 1 once energy_q and energy_v hold a state
  vsc_elastic_scratch energy_elastic;  ///< the energy queries' samples and edges (10 N)
  double* energy_mass_times_v;         ///< their M v (3n)
  double* energy_spheres;              ///< their sphere centres (3 per sphere) (m)
};

/// Doubles the backup's arrays hold for n points, N samples and `spheres` spheres.
#define VSC_STEP_BACKUP_DOUBLES(n, N, spheres) (15 * (n) + 10 * (N) + (3 + VSC_STICK_SIZE) * (spheres))

/// Point the backup's arrays into `block` (VSC_STEP_BACKUP_DOUBLES, caller-owned).
void vsc_step_backup_carve(vsc_step_backup* backup, double* block, int n, int sample_count, int spheres);

#endif  // VISCERA_SRC_VSC_STEP_H
