// Band force Jacobians (viscera/vsc_jacobian.h): the implicit step's and the
// stability estimate's, each on a scratch of its own.
#ifndef VISCERA_SRC_VSC_JACOBIAN_H
#define VISCERA_SRC_VSC_JACOBIAN_H

#include "viscera/vsc_jacobian.h"
#include "vsc_elastic.h"
#include "vsc_touch.h"

/// A Jacobian's scratch, owned by whoever assembles it (the implicit scheme,
/// the stability estimate): the sample-level blocks.
typedef struct vsc_jacobian_scratch {
  double* sample_hessian;  ///< 3 x 3 x 3 per sample (vsc_jacobian.c)
} vsc_jacobian_scratch;

/// Doubles a Jacobian's scratch holds for N samples.
#define VSC_JACOBIAN_SCRATCH_DOUBLES(N) (27 * (N))

/// vsc_rod_add_jacobian on `scratch`, at the samples `placed` holds (the
/// elastic pass's, placed at q), with rigid contacts from `touch` (NULL: none).
void vsc_jacobian_add(const vsc_rod* rod, vsc_jacobian_scratch* scratch, const vsc_elastic_scratch* placed,
                      const vsc_touch_records* touch, const vsc_world* world, const double* q, double stiffness_weight, double damping_weight,
                      double* band, double* global_gradient);

/// out += D v (N, 3n), D the damping part of the Jacobian, from the same touch records.
void vsc_jacobian_add_damping_force(const vsc_rod* rod, const vsc_touch_records* touch, const vsc_world* world,
                                    const double* v, double* out);

#endif  // VISCERA_SRC_VSC_JACOBIAN_H
