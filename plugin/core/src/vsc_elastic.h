// The elastic pass (viscera/vsc_elastic.h has the energy): the rod's elastic
// forces on its sample points, gathered onto the control points.
#ifndef VISCERA_SRC_VSC_ELASTIC_H
#define VISCERA_SRC_VSC_ELASTIC_H

#include "viscera/vsc_elastic.h"
#include "vsc_rod.h"

/// The elastic pass's state, which it owns: the samples it placed, its
/// spring edges and sample forces, structure of arrays so the spring loops
/// vectorise (N each, in one block of 10 N).
struct vsc_elastic_scratch {
  double* sample_x;     ///< sample positions (m)
  double* sample_y;
  double* sample_z;
  double* force_x;      ///< elastic forces on the samples (N)
  double* force_y;
  double* force_z;
  double* edge_x;       ///< spring vectors, then tension vectors
  double* edge_y;
  double* edge_z;
  double* edge_length;  ///< spring lengths (m)
};

/// Point a scratch's arrays into `block` (10 N doubles, caller-owned).
void vsc_elastic_scratch_carve(vsc_elastic_scratch* scratch, double* block, int sample_count);

/// Add the elastic forces -dE/dq at control points q (m) to Q (N, 3n):
/// springs, curvature and clamps on the samples it places, then the
/// mesentery's tethers. `asleep` (vsc_sleep.h's per point flags; NULL: all
/// awake): a point asleep deep gets none.
void vsc_elastic_add_forces(const vsc_rod* rod, vsc_elastic_scratch* scratch, const unsigned char* asleep,
                            const double* q, double* Q);

/// The gradient g = dl/dq (dimensionless, 3n) of the axis length l at the
/// samples the last vsc_elastic_add_forces placed in `scratch`: the direction
/// the global length term K_g (l - length) g pushes along, and its
/// stiffness's rank-one part K_g g g'. Overwrites the scratch's edges and
/// sample forces (0 where a control point sleeps deep, as above).
void vsc_elastic_length_gradient(const vsc_rod* rod, vsc_elastic_scratch* scratch, const unsigned char* asleep,
                                 double* gradient);

/// Place the samples at q (m) in `scratch`, as vsc_elastic_add_forces does
/// (what the Jacobian reads).
void vsc_elastic_place(const vsc_rod* rod, vsc_elastic_scratch* scratch, const double* q);

#endif  // VISCERA_SRC_VSC_ELASTIC_H
