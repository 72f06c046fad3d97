// The integrators' substeps and their table (viscera/vsc_integrate.h's
// VSC_INTEGRATORS, expanded in vsc_schemes.c).
#ifndef VISCERA_SRC_VSC_SCHEMES_H
#define VISCERA_SRC_VSC_SCHEMES_H

#include "viscera/vsc_integrate.h"
#include "vsc_context.h"
#include "vsc_jacobian.h"

/// The schemes' scratch, which they own: integrator stages, and the implicit
/// step's system and Jacobian.
struct vsc_scheme_scratch {
  double* stage;                  ///< integrator stages (8 x 3n)
  double* system;                 ///< the implicit step's matrix, wide band 3n x (jacobian_half_width + 1)
  double* factor_row;             ///< factorisation scratch (jacobian_half_width + 1)
  vsc_jacobian_scratch jacobian;  ///< the implicit step's Jacobian
};

/// One substep of h (s) on q (m) and v (m/s) in place. VSC_OK, or
/// VSC_ERROR_DIVERGED when a factorisation fails.
typedef vsc_status (*vsc_substep_function)(vsc_step_context* context, double* q, double* v, double h);

/// One integrator: its row of VSC_INTEGRATORS.
typedef struct vsc_scheme {
  const char* name;             ///< the `integrator` key's value
  vsc_substep_function substep;
  double trusted_omega_h;       ///< largest omega h vsc_stable_substeps trusts
  int explicit_damping;         ///< 1: damping applied explicitly shrinks its stable substep
  int length_implicit;          ///< 1: the global length term never limits its substep
  int elastic_implicit;         ///< 1: only the contact frequency limits its substep
  double phase_coefficient;     ///< c in its relative error c (omega h)^p on an oscillation
  int phase_order;              ///< p
} vsc_scheme;

/// The integrators, indexed by vsc_integrator.
extern const vsc_scheme vsc_schemes[VSC_INTEGRATOR_COUNT];

#define VSC_SUBSTEP_DECLARE_(id, name, substep, trusted, explicit_damping, length_implicit, elastic_implicit, phase_c, phase_p) \
  vsc_status substep(vsc_step_context* context, double* q, double* v, double h);
VSC_INTEGRATORS(VSC_SUBSTEP_DECLARE_)
#undef VSC_SUBSTEP_DECLARE_

#endif  // VISCERA_SRC_VSC_SCHEMES_H
