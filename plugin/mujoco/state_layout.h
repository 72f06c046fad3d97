// The blocks of one viscera.intestine instance's plugin_state: their order,
// offsets and sizes in one place. The plugin reads and writes its state through
// it, and exports.c hands it to Python (viscera_intestine_layout), which reads
// every block by name instead of recomputing offsets.
//
// Per instance (n control points, S collision spheres, B = m->nbody bodies,
// G graspers; mjtNums), in this order:
//   positions     3n   control point positions, x y z per point (m, world frame)
//   velocities    3n   control point velocities (m/s)
//   divergences   1    steps that diverged (non-finite, faster than 100 m/s, or
//                      an energy jump; see vsc_integrate.h) at every retry, whose
//                      positions were restored and velocities zeroed
//   recoveries    1    steps that diverged but held when retried with more
//                      substeps (both counts: reset writes 0)
//   wrenches      6B   per body, the reaction of the intestine over the last
//                      step: force (N), torque about the body's centre of mass
//                      (N m), world frame
//   friction      8S   per sphere, friction state (VSC_STICK_SIZE, vsc_friction.h)
//   grasps        6G   per grasper (grasp_sites), its hold: status (0 open,
//                      1 holding, 2 closed without a hold: missed or slipped),
//                      held abscissa s in [0, 1], held point in the site frame
//                      (m, 3; it moves as the tissue slides in the jaws), slip
//                      count (holds slid out of the jaws or torn out)
//   rest          8n   per control point, its rest record (vsc_sleep.h): the
//                      time it has been at rest (s; it sleeps from `sleep_time`
//                      on), where its rest began (m, 3), asleep next to awake
//                      points the acceleration its forces gave it when it came
//                      to lie there (m/s^2, 3) and 1 once taken; reset wakes
//                      every point at its initial position
//   gravity       3    the gravity (m/s^2) the rest times were counted under: a
//                      change wakes every point
//   damage        2n   per control point, its wall's damage (vsc_damage.h):
//                      bruise in [0, 1] (the force-time product of the pinches
//                      held there over the one that damages the wall), torn (0
//                      or 1: perforated by a pinch or torn by overstretching);
//                      reset writes 0
#ifndef VISCERA_PLUGIN_STATE_LAYOUT_H
#define VISCERA_PLUGIN_STATE_LAYOUT_H

#include "viscera/vsc_damage.h"
#include "viscera/vsc_friction.h"
#include "viscera/vsc_sleep.h"

/// Numbers per grasper in the grasps block.
#define VSC_GRASP_STATE_SIZE 6

/// The blocks, in state order.
typedef enum vsc_state_block {
  VSC_STATE_POSITIONS = 0,
  VSC_STATE_VELOCITIES,
  VSC_STATE_DIVERGENCES,
  VSC_STATE_RECOVERIES,
  VSC_STATE_WRENCHES,
  VSC_STATE_FRICTION,
  VSC_STATE_GRASPS,
  VSC_STATE_REST,
  VSC_STATE_GRAVITY,
  VSC_STATE_DAMAGE,
  VSC_STATE_BLOCK_COUNT
} vsc_state_block;

/// Offset and size (mjtNums) of every block, and the total.
typedef struct vsc_state_layout {
  int offset[VSC_STATE_BLOCK_COUNT];
  int size[VSC_STATE_BLOCK_COUNT];
  int total;
} vsc_state_layout;

/// Numbers per item of each block: per control point, per body, per sphere, per grasper (gravity: one item).
static const int vsc_state_block_width[VSC_STATE_BLOCK_COUNT] = {
    [VSC_STATE_POSITIONS] = 3, [VSC_STATE_VELOCITIES] = 3, [VSC_STATE_DIVERGENCES] = 1,
    [VSC_STATE_RECOVERIES] = 1, [VSC_STATE_WRENCHES] = 6, [VSC_STATE_FRICTION] = VSC_STICK_SIZE,
    [VSC_STATE_GRASPS] = VSC_GRASP_STATE_SIZE, [VSC_STATE_REST] = VSC_REST_SIZE, [VSC_STATE_GRAVITY] = 3,
    [VSC_STATE_DAMAGE] = VSC_DAMAGE_SIZE};

/// A grasper's status in its first number, by name (static storage, NULL-terminated).
enum { VSC_GRASP_OPEN = 0, VSC_GRASP_HOLDING = 1, VSC_GRASP_CLOSED_EMPTY = 2 };
static const char* const vsc_grasp_status_names[] = {
    [VSC_GRASP_OPEN] = "open", [VSC_GRASP_HOLDING] = "holding", [VSC_GRASP_CLOSED_EMPTY] = "closed", NULL};

/// Block names, as Python reads them (static storage).
static const char* const vsc_state_block_names[VSC_STATE_BLOCK_COUNT] = {
    [VSC_STATE_POSITIONS] = "positions",   [VSC_STATE_VELOCITIES] = "velocities",
    [VSC_STATE_DIVERGENCES] = "divergences", [VSC_STATE_RECOVERIES] = "recoveries",
    [VSC_STATE_WRENCHES] = "wrenches",     [VSC_STATE_FRICTION] = "friction",
    [VSC_STATE_GRASPS] = "grasps", [VSC_STATE_REST] = "rest", [VSC_STATE_GRAVITY] = "gravity",
    [VSC_STATE_DAMAGE] = "damage"};

/// The layout for n control points, `spheres` collision spheres, `bodies`
/// bodies and `graspers` graspers: the blocks back to back.
static inline vsc_state_layout vsc_state_layout_of(int n, int spheres, int bodies, int graspers) {
  vsc_state_layout l;
  const int items[VSC_STATE_BLOCK_COUNT] = {n, n, 1, 1, bodies, spheres, graspers, n, 1, n};
  int at = 0;
  for (int b = 0; b < VSC_STATE_BLOCK_COUNT; ++b) {
    l.offset[b] = at;
    l.size[b] = vsc_state_block_width[b] * items[b];
    at += l.size[b];
  }
  l.total = at;
  return l;
}

#endif  // VISCERA_PLUGIN_STATE_LAYOUT_H
