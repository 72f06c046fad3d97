// Tissue damage: a pinch's force-time product bruises, a pinch at the
// perforation limit tears, an overstretched segment tears its ends.
#include <string.h>

#include "viscera/vsc_damage.h"
#include "vsc_test.h"

// 300 N s bruises fully (Barrie): 6 N for 25 s at a control point is half of it,
// all at that point; between two points it splits by nearness.
static void a_held_pinch_bruises_by_its_force_time_product(void) {
  vsc_damage_limits limits = vsc_default_damage_limits();
  double damage[2 * 11];
  memset(damage, 0, sizeof(damage));
  for (int step = 0; step < 12500; ++step) ENSURE(vsc_damage_pinch(&limits, 11, 0.3, 6.0, 0.002, damage) == 0);
  ENSURE_NEAR(damage[2 * 3], 0.5, 1e-9);   // s = 0.3 is control point 3 of 11
  ENSURE_NEAR(damage[2 * 2], 0.0, 1e-12);
  ENSURE_NEAR(damage[2 * 4], 0.0, 1e-9);
  ENSURE(damage[2 * 3 + 1] == 0.0);        // bruised, not torn
  memset(damage, 0, sizeof(damage));
  vsc_damage_pinch(&limits, 11, 0.325, 30.0, 1.0, damage);  // a quarter of the way from 3 to 4: point 3 torn
  ENSURE_NEAR(damage[2 * 4], 0.25 * 30.0 / 300.0, 1e-9);
  for (int k = 0; k < 200; ++k) vsc_damage_pinch(&limits, 11, 0.3, 6.0, 10.0, damage);
  ENSURE_NEAR(damage[2 * 3], 1.0, 0.0);    // capped at 1
}

// Below the perforation pinch nothing tears however long; at it, the nearest point does, once.
static void a_pinch_at_the_limit_perforates_the_nearest_point(void) {
  vsc_damage_limits limits = vsc_default_damage_limits();
  double damage[2 * 5];
  memset(damage, 0, sizeof(damage));
  ENSURE(vsc_damage_pinch(&limits, 5, 0.6, limits.perforation_pinch - 1e-9, 100.0, damage) == 0);
  for (int k = 0; k < 5; ++k) ENSURE(damage[2 * k + 1] == 0.0);
  ENSURE(vsc_damage_pinch(&limits, 5, 0.6, limits.perforation_pinch, 0.002, damage) == 1);  // 0.6 x 4 = 2.4: point 2
  ENSURE(damage[2 * 2 + 1] == 1.0 && damage[2 * 2] == 1.0);
  ENSURE(damage[2 * 3 + 1] == 0.0);
  ENSURE(vsc_damage_pinch(&limits, 5, 0.6, 20.0, 0.002, damage) == 0);  // already torn: no new perforation
}

// A segment at 140 % strain tears its two ends; one just short of it does not.
static void an_overstretched_segment_tears_its_ends(void) {
  vsc_damage_limits limits = vsc_default_damage_limits();
  double q[3 * 4] = {0, 0, 0, 0.1, 0, 0, 0.1 + 0.1 * 2.4 - 1e-9, 0, 0, 0.2 + 0.1 * 2.4, 0, 0};
  double damage[2 * 4];
  memset(damage, 0, sizeof(damage));
  ENSURE(vsc_damage_stretch(&limits, 4, 0.3, q, damage) == 0);
  q[6] += 2e-9;
  ENSURE(vsc_damage_stretch(&limits, 4, 0.3, q, damage) == 2);
  ENSURE(damage[2 * 1 + 1] == 1.0 && damage[2 * 2 + 1] == 1.0 && damage[2 * 0 + 1] == 0.0 && damage[2 * 3 + 1] == 0.0);
}

int main(void) {
  RUN(a_held_pinch_bruises_by_its_force_time_product);
  RUN(a_pinch_at_the_limit_perforates_the_nearest_point);
  RUN(an_overstretched_segment_tears_its_ends);
  TEST_MAIN_END();
}
