// Sleeping: control points at rest and untouched stop being integrated, the
// way a rigid-body engine puts resting bodies to sleep, but per control point
// of one spline, so that a tool moving one loop leaves the rest of the bowel
// asleep. The host keeps a rest record per control point (VSC_REST_SIZE
// numbers, below: seconds at rest, where its rest began, and the load it lay
// under at the edge of the awake part); vsc_rod_step (vsc_integrate.h) reads
// and advances it.
//
// - A control point is at rest while it stays within rest_speed x rest_time
//   of where its rest began (its mean speed below `rest_speed`: a contact's
//   chatter, micrometres at the penalty's frequency, is rest); at rest for
//   `rest_time` it sleeps: its velocity is zero and it is held where it is,
//   like a pinned point, so its awake neighbours still feel it.
// - What sleeps deep (further than 3 points from an awake one) costs nothing:
//   its contacts with static geoms and between such spheres are not looked
//   for, its elastic forces are not gathered,
//   and a rod asleep everywhere skips the step but for its contacts with
//   moving bodies' geoms (those still push and feel it).
// - It wakes (its rest starts over where it is) when an awake control point
//   within the spline's reach (3 points each way) moves (its mean speed over a
//   step at least `rest_speed`); when one of its spheres touches a geom that
//   moves at all (faster than VSC_SLEEP_GEOM_SPEED_SHARE x `rest_speed`: a
//   support sliding away slowly must not leave it hanging) or presses it
//   deeper than VSC_SLEEP_WAKE_DEPTH radii (a mocap body moves without a
//   velocity), or a segment of the rod whose points moved; when a jaw holds it; when, next to awake
//   points, the forces on it change; when the host's world says so as the
//   step begins (vsc_world.h: a new gravity wakes every point, another rod's
//   moving spheres the points under the capsules they pressed); and on a reset.
// Sleeping needs the lumped mass matrix and an explicit integrator: the
// consistent matrix couples every point to its neighbours' accelerations and
// the implicit step solves for all of them, so neither can hold part of the
// rod still without a new factorisation.
#ifndef VISCERA_VSC_SLEEP_H
#define VISCERA_VSC_SLEEP_H

/// When control points sleep.
typedef struct vsc_sleep_options {
  int enabled;        ///< 1: points at rest sleep; 0: every point is integrated every step
  double rest_speed;  ///< a point whose mean speed over rest_time is below this is at rest; a
                      ///< neighbour moving this fast over a step wakes it (m/s); 0: nothing sleeps
  double rest_time;   ///< at rest this long, a point sleeps (s, > 0)
} vsc_sleep_options;

/// Disabled; 5 mm/s and 0.25 s when enabled.
vsc_sleep_options vsc_default_sleep_options(void);

/// A geom touching a sleeping sphere wakes it when the geom's surface moves
/// faster than this share of rest_speed (50 um/s at the defaults), unless the
/// host marks the geom `resting` (vsc_geom.h): another rod's capsule whose
/// points have stayed within their rest reach for VSC_SLEEP_RESTING_SHARE of
/// rest_time. Two rods pressing each other chatter at the penalty's frequency
/// (a colon under the small bowel's loops flipped its velocity every step, at
/// 3 to 14 mm/s, micrometres of travel); each side's chatter woke the other's
/// points every step, so neither ever slept.
#define VSC_SLEEP_GEOM_SPEED_SHARE 0.01

/// A point at rest this share of rest_time counts as resting for waking what it
/// touches: a point moving at rest_speed or faster leaves its rest reach
/// (rest_speed x rest_time) within rest_time, so one moving at twice rest_speed
/// or faster never counts; a slower one wakes what it presses each time it
/// leaves that reach.
#define VSC_SLEEP_RESTING_SHARE 0.5

/// A sleeping control point next to awake ones (within VSC_SLEEP_REACH) wakes
/// when the forces on it change: held free, it would accelerate this much
/// faster (m/s^2) than when it came to lie next to them. Its awake neighbours
/// may settle into a new shape slowly, below rest_speed, and load it (a loop
/// whose support sank away, hanging from sleeping sides). Measured from that
/// moment, not from zero: a pile's penalty contacts never balance exactly, and
/// what they leave over is no reason to wake.
#define VSC_SLEEP_WAKE_ACCELERATION 10.0

/// A geom pressing a sleeping sphere deeper than this share of the radius
/// wakes it, moving or not (1.25 mm for the 12.5 mm tube; a contact's
/// ordinary depth at rest is a few tenths of a millimetre).
#define VSC_SLEEP_WAKE_DEPTH 0.1

/// An awake point's step counts as motion (it wakes sleeping neighbours and
/// what its spheres touch) only once the point is this share of the rest reach
/// (rest_speed x rest_time) from where its rest began: 0.125 mm at the
/// defaults. A contact's chatter swings a few micrometres about a point, at up
/// to 10 mm/s; with one substep a step its swing is not cancelled within the
/// step, and after the anatomical sweep it kept woken half the small bowel that
/// two substeps let sleep.
#define VSC_SLEEP_MOVE_SHARE 0.1

/// Control points either side of a point whose motion wakes it: the spline's
/// reach (a sample depends on 4 consecutive points, a spring on 2 samples).
#define VSC_SLEEP_REACH 3

/// A rest record, VSC_REST_SIZE numbers per control point: the time it has
/// been at rest (s); where its rest began (m, 3); and, asleep next to awake
/// points, the acceleration its forces gave it when it came to lie there
/// (m/s^2, 3) and 1 once that is taken (else 0).
enum {
  VSC_REST_TIME = 0,
  VSC_REST_ANCHOR = 1,
  VSC_REST_LOAD = 4,
  VSC_REST_WATCHED = 7,
  VSC_REST_SIZE = 8
};

/// Every control point awake, its rest beginning at q (m, 3n): the record of a
/// reset (rest: VSC_REST_SIZE per point).
void vsc_rest_wake_all(int control_count, const double* q, double* rest);

/// Control point k awake, its rest beginning at q (m, 3n): a host's load on it
/// (another intestine pressing) wakes it as a touching geom would.
void vsc_rest_wake(int k, const double* q, double* rest);

typedef struct vsc_rod vsc_rod;

/// 1 if a contact wakes a sleeping sphere of `radius` (m) it presses `depth`
/// (m) deep: the other side moves faster than `waking_speed` (m/s; a geom:
/// VSC_SLEEP_GEOM_SPEED_SHARE x rest_speed), unless the sphere's points rest
/// (`chatter`: a resting rod's capsule, whose speed is no motion), or it
/// presses deeper than VSC_SLEEP_WAKE_DEPTH radii. The rule for a geom, and for
/// another intestine pressing as one.
static inline int vsc_sleep_contact_wakes(int chatter, double speed, double waking_speed, double depth,
                                          double radius) {
  return (!chatter && speed > waking_speed) || depth > VSC_SLEEP_WAKE_DEPTH * radius;
}

/// 1 if every control point that collision sphere `sphere` of `rod` depends on has stayed within
/// its rest reach for VSC_SLEEP_RESTING_SHARE of options->rest_time (its rest records `rest`,
/// VSC_REST_SIZE per point): a resting rod there, whose chatter wakes nothing it touches.
/// 0 when sleeping is off.
int vsc_sleep_sphere_resting(const vsc_rod* rod, const vsc_sleep_options* options, const double* rest, int sphere);

/// Every control point collision sphere `sphere` of `rod` depends on awake, its rest beginning at
/// q (m, 3n): another rod pressing that sphere wakes it as a touching geom would.
void vsc_sleep_wake_sphere(const vsc_rod* rod, int sphere, const double* q, double* rest);

/// 1 if a control point at rest for `time_at_rest` (s) sleeps under `options`.
static inline int vsc_sleeps(const vsc_sleep_options* options, double time_at_rest) {
  return options->enabled && time_at_rest >= options->rest_time;
}

#endif  // VISCERA_VSC_SLEEP_H
