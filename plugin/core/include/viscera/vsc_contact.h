// Contacts of the rod's collision spheres with rigid geoms and with each other
// (France et al. 2002, 3.3), found through the sphere grid (vsc_grid.h).
//
// Broad phase (Verlet lists): grid passes find the candidate pairs within a
// margin (segments closer than 2r + m, sphere-geom pairs within r + m, both by
// exact distance, m = one radius); every force evaluation then runs
// only the narrow phase over them. The self pairs are rebuilt once a sphere has
// moved by m / 2 since they were built, the geom pairs once a sphere or a geom
// has (then no contact can have been missed), apart: a moving tool does not
// rebuild the self pairs. The lists are sorted, so forces do not depend on when
// they were built.
//
// Spheres of radius def.radius sit uniformly in abscissa. A contact of depth
// d > 0 and normal separation speed v_n pushes with
// f_n = max(0, s(d, v_n) k min(d, VSC_SPRING_DEPTH r) - c v_n) along its normal
// (k = contact_stiffness, c = contact_damping; s = 1 except for deep contacts
// separating fast, see VSC_PUSH_OUT_SPEED), applied at
// the sphere's abscissa through the spline basis (virtual work); the partner
// (geom or sphere) receives the opposite force.
//
// Self-collision takes the tube's cylindrical shape into account (the paper's
// own suggested improvement, section 5): segment k joins sphere centres k and
// k + 1, and two segments collide as capsules of radius r (exact closest
// points of two segments). Between sphere centres two crossing tubes thus
// cannot sink into each other, as bare spheres would let them (down to
// sqrt(3.5) r apart at one-radius spacing). The force at the closest points is
// split linearly onto the segments' end spheres, then through the spline basis.
// Neighbours: segments a < b never collide when their nearest points are
// closer along the rest axis than pi r, (b - a - 1) spacing < pi r. The
// tightest fold of a tube of radius r has a centre line of radius r, so its
// U-turn spans pi r of arc: pairs beyond that (the fold's legs) still collide,
// while on a straight tube they are at least pi r > 2r apart, so it starts
// with no self-contact.
//
// Friction (regularised Coulomb): each contact has a tangential stick spring
// of stiffness k and damping c, F_t = -k delta - c v_t, limited to mu f_n. The
// elongation delta lives in the host's state (VSC_STICK_SIZE numbers per
// sphere: one rigid and one self partner) and advances after each substep by
// v_t h, clamped at the slip limit k |delta| = mu f_n: below the friction
// angle a contact holds (no creep), above it slides with force mu f_n.
// Contacts without a stick slot get F_t = -c v_t limited to mu f_n.
#ifndef VISCERA_VSC_CONTACT_H
#define VISCERA_VSC_CONTACT_H

#include "viscera/vsc_friction.h"
#include "viscera/vsc_rod.h"

/// Deep contacts push out at a bounded speed. A sphere that starts deep in a
/// geom (placed there) would be thrown out at d sqrt(k / m) by the spring's
/// 1/2 k d^2 (4 to 7 m/s from one radius deep at the defaults). So past
/// VSC_DEEP_CONTACT radii the spring's push fades with the sphere's separation
/// speed: in full below half this speed (m/s), none from this speed on, the
/// fade itself reaching full weight at twice that depth; and past
/// VSC_SPRING_DEPTH radii the push stops growing. The sphere then leaves at
/// about sqrt(VSC_PUSH_OUT_SPEED^2 + k (VSC_DEEP_CONTACT r)^2 / m) (2 m/s at the
/// defaults) whatever its depth. Ordinary contacts, the depths impacts reach
/// (a quarter radius at 1.8 m/s at the defaults), are untouched, and the fade
/// only ever takes energy out.
#define VSC_PUSH_OUT_SPEED 1.0

/// Depth (radii) past which a contact counts as deep (see VSC_PUSH_OUT_SPEED).
#define VSC_DEEP_CONTACT 0.25

/// The penalty spring's push grows with depth up to this many radii, then stays
/// (k r / 2 = 12.5 N per sphere at the defaults, 200 times its weight; a tube
/// pressed deeper would be half crushed): a deeper start is pushed out no
/// harder, so an explicit substep overshoots the push-out speed less.
#define VSC_SPRING_DEPTH 0.5

/// The deepest sphere-geom contact found by vsc_rod_contact_energy.
typedef struct vsc_deepest_contact {
  double depth;  ///< penetration of the sphere into the geom (m, 0: none)
  int geom;      ///< geom index in the world (-1: none)
  int sphere;    ///< sphere index (-1: none)
} vsc_deepest_contact;

/// Potential energy of the contact penalty springs at positions q (J):
/// 1/2 k d^2 over every sphere-geom and self-contact of depth d > 0 (friction's
/// stick springs are not counted). If `deepest` is not NULL it receives the
/// deepest sphere-geom contact. Changes nothing an evaluation or a step reads:
/// the spheres at q are placed in a scratch of the energy query's own, and the
/// candidate lists are read where they cover q, never rebuilt.
double vsc_rod_contact_energy(vsc_rod* rod, const vsc_world* world, const double* q, vsc_deepest_contact* deepest);

/// Each contact the last contact pass found: visit(data, rigid, a, b, speed,
/// depth) with rigid 1 for sphere a against geom b, 0 for segments a < b, the
/// speed of a relative to b at the contact (m/s) and its depth (m). Sleeping
/// reads it (vsc_sleep.c), and a host handing another rod the loads of these
/// contacts (which of them its moving spheres press).
void vsc_rod_visit_contacts(const vsc_rod* rod,
                            void (*visit)(void* data, int rigid, int a, int b, double speed, double depth), void* data);

#endif  // VISCERA_VSC_CONTACT_H
