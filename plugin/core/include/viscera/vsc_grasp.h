// Grasps: points of the axis held by a tool's jaws.
//
// A grasp holds the axis point at abscissa s with a stiff spring to an anchor
// that moves with the jaw: F = k (anchor - P(s)) + c (anchor velocity - P'(s)),
// applied at s through the spline basis (virtual work), the opposite force on
// the anchor. The anchor is held at its step-start pose through a step (the
// same rule as moving geoms), which lags the jaw by at most its speed times the
// step (0.2 mm at 0.1 m/s and 2 ms). Deciding when a jaw takes or loses its
// hold (closing, opening, slipping past a force limit) is the host's business.
#ifndef VISCERA_VSC_GRASP_H
#define VISCERA_VSC_GRASP_H

#include "viscera/vsc_rod.h"

/// One held point. Host-owned and read only (its reaction goes to vsc_reactions.grasp_force).
typedef struct vsc_grasp {
  double abscissa;            ///< parametric abscissa s of the held point, in [0, 1]
  double anchor[3];           ///< where the jaw holds it (m, world frame)
  double anchor_velocity[3];  ///< the anchor's velocity (m/s)
  double stiffness;           ///< spring stiffness k (N/m, >= 0)
  double damping;             ///< spring damping c (N s/m, >= 0)
} vsc_grasp;

/// The axis point nearest to `point` (m): writes its abscissa s in [0, 1] and
/// returns its distance (m). Exact on the sample polyline (the springs'
/// resolution, length / ((n - 1) S)); O(samples). Leaves the rod untouched.
double vsc_rod_nearest_abscissa(const vsc_rod* rod, const double* q, const double point[3], double* abscissa);

#endif  // VISCERA_VSC_GRASP_H
