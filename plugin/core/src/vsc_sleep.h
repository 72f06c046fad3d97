// Sleeping within a step (viscera/vsc_sleep.h has the model): which points
// sleep, holding them, the rod asleep everywhere, and the rest records'
// advance with what wakes.
#ifndef VISCERA_SRC_VSC_SLEEP_H
#define VISCERA_SRC_VSC_SLEEP_H

#include "viscera/vsc_sleep.h"
#include "vsc_context.h"

/// The host's wakes, as the step begins and whether or not the rod sleeps (the
/// records are the host's state): every point's rest starts over at q (m) with
/// world->wake_all, and those under each capsule world->wake_capsules flags.
void vsc_sleep_host_wakes(const vsc_rod* rod, const vsc_world* world, const double* q, double* rest);

/// Set the rod's sleeping flags (rod->work.asleep, sphere_asleep, asleep_count)
/// from the rest records (VSC_REST_SIZE per point; NULL or options disabled:
/// none sleeps) and zero the sleeping points' velocities v (m/s, 3n). A
/// sleeping point the host moved away from its rest (a state written) wakes at
/// q (m). Returns the points asleep.
int vsc_sleep_begin(vsc_rod* rod, const vsc_sleep_options* options, const double* q, double* rest, double* v);

/// A rod asleep everywhere, at q (m): its contacts with moving bodies' geoms
/// pushed at full weight (their reactions written to the world, the rod held
/// still), then what wakes it. Returns 1 if it sleeps on (the step is done),
/// 0 if a point woke (the caller steps the rod).
int vsc_sleep_rest(vsc_step_context* context, const vsc_sleep_options* options, const double* q, double* rest);

/// After an accepted step of dt (s) from start_q to q (m): the awake points'
/// rests go on, or start over where they are when they left them; then points
/// wake where an awake point within VSC_SLEEP_REACH moved (its mean speed over
/// the step at least rest_speed), where the last contact pass touched a moving
/// geom (see vsc_sleep.h) or a segment whose points moved, and where a jaw holds them.
void vsc_sleep_advance(vsc_rod* rod, const vsc_world* world, const vsc_sleep_options* options, const double* start_q,
                       const double* q, double dt, double* rest);

/// A retried attempt: the edge points' changed loads the failed one saw are forgotten.
void vsc_sleep_retry(vsc_rod* rod);

/// The step is over: the rod's flags cleared (every point awake to a later evaluation) and the
/// host's records let go.
void vsc_sleep_end(vsc_rod* rod);

/// Every point awake, its rest starting over at q (m), and the rod's flags cleared.
void vsc_sleep_wake_all(vsc_rod* rod, const double* q, double* rest);

#endif  // VISCERA_SRC_VSC_SLEEP_H
