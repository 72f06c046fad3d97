// Touch records: per collision sphere, the last force evaluation's strongest
// contacts, one rigid and one self. The narrow phase writes them (vsc_contact.c);
// friction (vsc_friction.c) and the implicit step's Jacobian and reactions read
// them.
#ifndef VISCERA_SRC_VSC_TOUCH_H
#define VISCERA_SRC_VSC_TOUCH_H

#include "vsc_rod.h"

/// Per sphere: the rigid record, then the self record, each of: partner (geom
/// or segment index, -1 none), normal force (N), mu, normal (3), tangential
/// velocity (m/s, 3), closest points on the two segments (self; 0 for rigid).
#define VSC_TOUCH_SIZE 22

/// Offsets of the two records in a sphere's entry, and of the fields in a record.
enum { VSC_TOUCH_RIGID = 0, VSC_TOUCH_SELF = 11 };
enum {
  VSC_TOUCH_PARTNER = 0,
  VSC_TOUCH_NORMAL_FORCE = 1,
  VSC_TOUCH_MU = 2,
  VSC_TOUCH_NORMAL = 3,
  VSC_TOUCH_TANGENT_VELOCITY = 6,
  VSC_TOUCH_S = 9,
  VSC_TOUCH_T = 10
};

/// The touch records, the narrow phase's (vsc_contact.h's pass holds them).
typedef struct vsc_touch_records {
  double* record;  ///< per sphere, VSC_TOUCH_SIZE each
  int current;     ///< 1 if the last evaluation looked for contacts (the records are its)
} vsc_touch_records;

/// Forget every sphere's records (no partner, no force): the start of an evaluation.
void vsc_touch_clear(const vsc_rod* rod, vsc_touch_records* touch);

/// The strongest rigid contact of `sphere` in the last evaluation: returns its
/// geom index (-1: none) and writes its unit normal, from the geom to the sphere.
int vsc_touch_rigid(const vsc_touch_records* touch, int sphere, double normal[3]);

/// Keep a contact in `touch` (one record) if it pushes harder than the one there.
static inline void vsc_record_touch(double* touch, int partner, double normal, double mu, const double n[3], const double vt[3],
                                    double s, double t) {
  if (normal <= touch[VSC_TOUCH_NORMAL_FORCE]) return;  // keep the strongest contact
  touch[VSC_TOUCH_PARTNER] = partner;
  touch[VSC_TOUCH_S] = s;
  touch[VSC_TOUCH_T] = t;
  touch[VSC_TOUCH_NORMAL_FORCE] = normal;
  touch[VSC_TOUCH_MU] = mu;
  for (int a = 0; a < 3; ++a) {
    touch[VSC_TOUCH_NORMAL + a] = n[a];
    touch[VSC_TOUCH_TANGENT_VELOCITY + a] = vt[a];
  }
}

#endif  // VISCERA_SRC_VSC_TOUCH_H
