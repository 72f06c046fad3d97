// Touch records (see vsc_touch.h).
#include "vsc_touch.h"

void vsc_touch_clear(vsc_rod* rod) {
  for (int i = 0; i < rod->def.collision_sphere_count; ++i) {
    double* touch = rod->work.touch + VSC_TOUCH_SIZE * i;
    touch[VSC_TOUCH_RIGID + VSC_TOUCH_PARTNER] = touch[VSC_TOUCH_SELF + VSC_TOUCH_PARTNER] = -1.0;
    touch[VSC_TOUCH_RIGID + VSC_TOUCH_NORMAL_FORCE] = touch[VSC_TOUCH_SELF + VSC_TOUCH_NORMAL_FORCE] = 0.0;
  }
}

int vsc_rod_rigid_touch(const vsc_rod* rod, int sphere, double normal[3]) {
  const double* touch = rod->work.touch + VSC_TOUCH_SIZE * sphere + VSC_TOUCH_RIGID;
  if (!rod->work.touched || touch[VSC_TOUCH_PARTNER] < 0.0 || !(touch[VSC_TOUCH_NORMAL_FORCE] > 0.0)) return -1;
  for (int a = 0; a < 3; ++a) normal[a] = touch[VSC_TOUCH_NORMAL + a];
  return (int)touch[VSC_TOUCH_PARTNER];
}

