// Friction's stick springs (see viscera/vsc_contact.h for the model): the
// state's "no contact" value and its advance after each substep from the last
// evaluation's touch records.
#include "vsc_friction.h"

#include <math.h>
#include <string.h>

#include "vsc_touch.h"

void vsc_stick_clear(double* stick, int count) {
  for (int i = 0; i < count; ++i) {
    double* s = stick + VSC_STICK_SIZE * i;
    memset(s, 0, sizeof(double) * VSC_STICK_SIZE);
    s[0] = -1.0;
    s[4] = -1.0;
  }
}

// One friction slot: follow the partner of the last evaluation, advance the
// elongation by (v_t + unseen) h in the tangent plane, clamp it at the slip
// limit. `unseen` (m/s) is the relative velocity change the evaluation did not see.
static void update_slot(double* slot, const double* touch, const double unseen[3], double k, double h) {
  int partner = (int)touch[VSC_TOUCH_PARTNER];
  if (partner < 0) {
    slot[0] = -1.0;
    slot[1] = slot[2] = slot[3] = 0.0;
    return;
  }
  if ((int)slot[0] != partner) {  // a new contact starts unstretched
    slot[0] = partner;
    slot[1] = slot[2] = slot[3] = 0.0;
  }
  double* e = slot + 1;
  const double* n = touch + VSC_TOUCH_NORMAL;
  const double* vt = touch + VSC_TOUCH_TANGENT_VELOCITY;
  for (int a = 0; a < 3; ++a) e[a] += (vt[a] + unseen[a]) * h;
  double along = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
  for (int a = 0; a < 3; ++a) e[a] -= along * n[a];
  double length2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  double friction = touch[VSC_TOUCH_MU] * touch[VSC_TOUCH_NORMAL_FORCE];  // the slip limit is friction / k (m)
  if (length2 * k * k > friction * friction) {  // slipping: the spring stays at the Coulomb limit
    double scale = friction / k / sqrt(length2);  // (division and sqrt only then)
    for (int a = 0; a < 3; ++a) e[a] *= scale;
  }
}

void vsc_rod_update_stick(const vsc_rod* rod, const vsc_touch_records* records, const unsigned char* asleep,
                          double* stick, double h, const double* velocity_change) {
  if (!records->current) {  // no contact was looked for: none holds
    vsc_stick_clear(stick, rod->def.collision_sphere_count);
    return;
  }
  double k = rod->def.contact_stiffness;
  int spheres = rod->def.collision_sphere_count;
  for (int i = 0; i < spheres; ++i) {
    if (asleep && asleep[i]) continue;  // a sleeping sphere's springs keep their stretch until it wakes
    const double* touch = records->record + VSC_TOUCH_SIZE * i;
    const double* rigid = touch + VSC_TOUCH_RIGID;
    double unseen[3] = {0.0, 0.0, 0.0};
    if (velocity_change && rigid[VSC_TOUCH_PARTNER] >= 0.0) vsc_basis_point(&rod->sphere_basis[i], velocity_change, unseen);
    update_slot(stick + VSC_STICK_SIZE * i, rigid, unseen, k, h);
    const double* self = touch + VSC_TOUCH_SELF;
    if (velocity_change && self[VSC_TOUCH_PARTNER] >= 0.0) {  // (1 - s) a + s (a + 1) - (1 - t) b - t (b + 1)
      int b = (int)self[VSC_TOUCH_PARTNER];
      double s = self[VSC_TOUCH_S], t = self[VSC_TOUCH_T], a0[3], a1[3], b0[3], b1[3];
      vsc_basis_point(&rod->sphere_basis[i], velocity_change, a0);
      vsc_basis_point(&rod->sphere_basis[i + 1], velocity_change, a1);
      vsc_basis_point(&rod->sphere_basis[b], velocity_change, b0);
      vsc_basis_point(&rod->sphere_basis[b + 1], velocity_change, b1);
      for (int a = 0; a < 3; ++a)
        unseen[a] = (1.0 - s) * a0[a] + s * a1[a] - (1.0 - t) * b0[a] - t * b1[a];
    }
    update_slot(stick + VSC_STICK_SIZE * i + 4, self, unseen, k, h);
  }
}
