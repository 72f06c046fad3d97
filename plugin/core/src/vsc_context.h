// The step context: what one step of one rod carries through its stages and
// mutates on its own account, apart from the host's world (viscera/vsc_world.h)
// and the stages' own state (vsc_rod.h's vsc_rod_stages). vsc_rod_step makes one per step on the
// stack; vsc_rod_forces makes one for a lone evaluation.
#ifndef VISCERA_SRC_VSC_CONTEXT_H
#define VISCERA_SRC_VSC_CONTEXT_H

#include "viscera/vsc_world.h"
#include "vsc_rod.h"

typedef struct vsc_step_context {
  const vsc_rod* rod;      ///< the rod (its definition and caches read only)
  const vsc_world* world;  ///< the host's inputs (read only)
  const vsc_reactions* reactions;  ///< where the reactions go (never NULL; its members may be)
  double* stick;           ///< friction state, VSC_STICK_SIZE per sphere (NULL: none; vsc_friction.h)
  double dt;               ///< the whole step (s)
  double wrench_weight;    ///< weight of the current evaluation's reactions: its share of dt, so the
                           ///< reactions of all a step's evaluations add up to their average over dt
  const double* unseen;    ///< the velocity change (m/s, 3n) the last substep made after its force
                           ///< evaluation read v, or NULL (vsc_friction.h's vsc_rod_update_stick)
  double substep;          ///< the current substep's length h (s), which the contacts' explicit damping
                           ///< must keep stable (vsc_contact_load.h); 0 in a lone evaluation: no limit
  double damping_limit;    ///< the bound on a pile's gamma h the contact pass keeps to: the
                           ///< scheme's (vsc_contact_load.h)
  int length_implicit;     ///< 1: the kick takes the global length term implicitly (vsc_schemes.c)
  double* rest;            ///< the host's rest records, VSC_REST_SIZE per point, where points sleep this
                           ///< step (NULL: none does): the evaluation keeps the edge points' loads there
} vsc_step_context;

/// The reactions of a caller that wants none: every member NULL, nothing written.
extern const vsc_reactions vsc_no_reactions;

#endif  // VISCERA_SRC_VSC_CONTEXT_H
