// Friction's advance (viscera/vsc_friction.h has the state's format).
#ifndef VISCERA_SRC_VSC_FRICTION_H
#define VISCERA_SRC_VSC_FRICTION_H

#include "viscera/vsc_friction.h"
#include "vsc_touch.h"

/// Advance the friction state by a substep of h (s), from the contacts of the
/// last evaluation (its touch records; `asleep`, per sphere, NULL: none
/// sleeps: a sleeping sphere's springs keep their stretch). `velocity_change` (m/s per control point coordinate, 3n,
/// may be NULL) is what the substep added to v after that evaluation read it:
/// a stick spring then stretches with the substep's end velocity (symplectic
/// Euler on the spring), not with its start velocity (explicit Euler, which
/// pumps energy into a stuck contact every substep). Under leapfrog, positions
/// move by the mean of the two velocities: the spring's elongation and the
/// contact's displacement then differ by h/2 (v_end - v_start), which does not
/// accumulate (the sum telescopes).
void vsc_rod_update_stick(const vsc_rod* rod, const vsc_touch_records* touch, const unsigned char* asleep,
                          double* stick, double h, const double* velocity_change);

#endif  // VISCERA_SRC_VSC_FRICTION_H
