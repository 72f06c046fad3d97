// The step (viscera/vsc_integrate.h's vsc_rod_step): its own state, the step
// start kept for retries and the divergence guard's energies; the step
// context (vsc_context.h) and the scheme table (vsc_schemes.h) are apart.
#ifndef VISCERA_SRC_VSC_STEP_H
#define VISCERA_SRC_VSC_STEP_H

#include "viscera/vsc_friction.h"
#include "viscera/vsc_integrate.h"
#include "viscera/vsc_contact.h"
#include "vsc_context.h"

/// The step's state, which it owns.
struct vsc_step_backup {
  double* q;                           ///< the step start, kept for retries (3n) (m)
  double* v;                           ///< (3n) (m/s)
  double* stick;                       ///< the friction state (VSC_STICK_SIZE per sphere)
  double* energy_q;                    ///< the state at which energy_active was computed: q (3n) (m)
  double* energy_v;                    ///< and v (3n) (m/s)
  double energy_active;                ///< kinetic + elastic energy there (J)
  int energy_known;                    ///< 1 once energy_q and energy_v hold a state
  double* energy_spheres;              ///< where the contact energy places the spheres to rebuild the
                                       ///< broad phase at q, when its lists do not cover q (3 per sphere) (m)
};

/// Doubles the backup's arrays hold for n points and `spheres` spheres.
#define VSC_STEP_BACKUP_DOUBLES(n, spheres) (12 * (n) + (VSC_STICK_SIZE + 3) * (spheres))

/// Point the backup's arrays into `block` (VSC_STEP_BACKUP_DOUBLES, caller-owned).
void vsc_step_backup_carve(vsc_step_backup* backup, double* block, int n, int spheres);

/// The contact penalty's potential at q (J; vsc_rod_contact_energy's, the
/// guard's): a narrow phase through the broad phase's lists where they cover
/// q (vsc_contact_lists_cover); where they do not, the lists are rebuilt at q
/// first, from spheres placed in the backup's scratch. The lists are a cache
/// every evaluation revalidates, so no result depends on when they were
/// built; nothing else is written but `deepest` (may be NULL).
double vsc_step_contact_energy(const vsc_rod* rod, const vsc_world* world, const double* q,
                               vsc_deepest_contact* deepest);

#endif  // VISCERA_SRC_VSC_STEP_H
