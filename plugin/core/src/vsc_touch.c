// Touch records (see vsc_touch.h).
#include "vsc_touch.h"

void vsc_touch_clear(const vsc_rod* rod, vsc_touch_records* t) {
  for (int i = 0; i < rod->def.collision_sphere_count; ++i) {
    double* touch = t->record + VSC_TOUCH_SIZE * i;
    touch[VSC_TOUCH_RIGID + VSC_TOUCH_PARTNER] = touch[VSC_TOUCH_SELF + VSC_TOUCH_PARTNER] = -1.0;
    touch[VSC_TOUCH_RIGID + VSC_TOUCH_NORMAL_FORCE] = touch[VSC_TOUCH_SELF + VSC_TOUCH_NORMAL_FORCE] = 0.0;
  }
}

int vsc_touch_rigid(const vsc_touch_records* t, int sphere, double normal[3]) {
  const double* touch = t->record + VSC_TOUCH_SIZE * sphere + VSC_TOUCH_RIGID;
  if (!t->current || touch[VSC_TOUCH_PARTNER] < 0.0 || !(touch[VSC_TOUCH_NORMAL_FORCE] > 0.0)) return -1;
  for (int a = 0; a < 3; ++a) normal[a] = touch[VSC_TOUCH_NORMAL + a];
  return (int)touch[VSC_TOUCH_PARTNER];
}
