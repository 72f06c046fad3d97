// Sleeping within a step (viscera/vsc_sleep.h has the model): which points
// sleep, holding them, the rod asleep everywhere, and the rest records'
// advance with what wakes.
#ifndef VISCERA_SRC_VSC_SLEEP_H
#define VISCERA_SRC_VSC_SLEEP_H

#include <stddef.h>

#include "viscera/vsc_sleep.h"
#include "vsc_context.h"

/// The host's wakes, as the step begins and whether or not the rod sleeps (the
/// records are the host's state): every point's rest starts over at q (m) with
/// world->wake_all, and those under each capsule world->wake_capsules flags.
void vsc_sleep_host_wakes(const vsc_rod* rod, const vsc_world* world, const double* q, double* rest);

/// Sleep's state within a step, which it owns: which points sleep this step.
/// The elastic pass, the narrow phase, friction and the kick read it.
struct vsc_sleep_flags {
  unsigned char* asleep;         ///< per control point: VSC_AWAKE, VSC_ASLEEP_EDGE or VSC_ASLEEP_DEEP (n)
  unsigned char* sphere_asleep;  ///< per sphere, the least asleep of the 4 points it depends on (spheres)
  int asleep_count;              ///< control points asleep this step (0: the flags above are all 0, unread)
  unsigned char* moved;          ///< 1 where control point k moved in the last step (n; scratch)
  unsigned char* unbalanced;     ///< 1 where a sleeping edge point's forces changed this step (n)
};

/// The per point flags, or NULL when no point sleeps (what the passes take).
static inline const unsigned char* vsc_sleep_points(const vsc_sleep_flags* flags) {
  return flags->asleep_count > 0 ? flags->asleep : NULL;
}

/// The per sphere flags, or NULL when no point sleeps.
static inline const unsigned char* vsc_sleep_spheres(const vsc_sleep_flags* flags) {
  return flags->asleep_count > 0 ? flags->sphere_asleep : NULL;
}

/// Set the flags from the rest records (VSC_REST_SIZE per point; NULL or
/// options disabled: none sleeps) and zero the sleeping points' velocities v
/// (m/s, 3n). A sleeping point the host moved away from its rest (a state
/// written) wakes at q (m). Returns the points asleep.
int vsc_sleep_begin(const vsc_rod* rod, vsc_sleep_flags* flags, const vsc_sleep_options* options, const double* q,
                    double* rest, double* v);

/// Hold the sleeping points: their accelerations a (m/s^2, 3n) zeroed, like
/// pinned ones; an edge point's first acceleration of its rest is kept in its
/// record, and one that changed past VSC_SLEEP_WAKE_ACCELERATION marks it
/// unbalanced (it wakes when the step is accepted).
void vsc_sleep_hold(const vsc_rod* rod, vsc_sleep_flags* flags, double* rest, double* a);

/// A rod asleep everywhere, at q (m), whose contacts with moving bodies'
/// geoms the last pass found (`contacts`): what wakes it. Returns 1 if it
/// sleeps on (the step is done), 0 if a point woke (the caller steps the rod).
int vsc_sleep_rest(const vsc_rod* rod, vsc_sleep_flags* flags, const vsc_contact_pass* contacts, const vsc_world* world,
                   const vsc_sleep_options* options, const double* q, double* rest);

/// After an accepted step of dt (s) from start_q to q (m): the awake points'
/// rests go on, or start over where they are when they left them; then points
/// wake where an awake point within VSC_SLEEP_REACH moved (its mean speed over
/// the step at least rest_speed), where the last contact pass (`contacts`)
/// touched a moving geom (see vsc_sleep.h) or a segment whose points moved,
/// and where a jaw holds them.
void vsc_sleep_advance(const vsc_rod* rod, vsc_sleep_flags* flags, const vsc_contact_pass* contacts,
                       const vsc_world* world, const vsc_sleep_options* options, const double* start_q,
                       const double* q, double dt, double* rest);

/// A retried attempt: the edge points' changed loads the failed one saw are forgotten.
void vsc_sleep_retry(const vsc_rod* rod, vsc_sleep_flags* flags);

/// The step is over: the flags cleared (every point awake to a later evaluation).
void vsc_sleep_end(const vsc_rod* rod, vsc_sleep_flags* flags);

/// Every point awake, its rest starting over at q (m), and the flags cleared.
void vsc_sleep_wake_all(const vsc_rod* rod, vsc_sleep_flags* flags, const double* q, double* rest);

#endif  // VISCERA_SRC_VSC_SLEEP_H
