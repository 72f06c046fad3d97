// Contacts between the intestine instances of one model (private to the
// adapter). Of each pair, the lower instance computes them: it collides
// against the higher one's tube as a chain of capsule geoms, between its
// collision spheres as placed at the step start and moving with their
// velocities, exactly as it collides against a tool. The reaction on those
// capsules, averaged over the step, goes to the higher instance as loads on
// its control points, which it feels over its own step: the two impulses are
// equal and opposite, and each instance still integrates only itself.
#ifndef VISCERA_PLUGIN_PARTNERS_H
#define VISCERA_PLUGIN_PARTNERS_H

#include "viscera/vsc_geom.h"
#include "viscera/vsc_rod.h"
#include "viscera/vsc_sleep.h"
#include "viscera/vsc_world.h"

typedef struct vsc_partner_exchange vsc_partner_exchange;

/// What the exchange reads of one instance of the model, as its host hands it
/// over: all read only.
typedef struct vsc_partner_view {
  const vsc_rod* rod;              ///< NULL: not an intestine of this model, or its caches cannot be had
  const double* positions;         ///< its state's control points (m), velocities (m/s) and rest records
  const double* velocities;
  const double* rest;
  int control_count;
  int spheres;                     ///< its collision spheres
  double self_friction;            ///< its tube's Coulomb coefficient
  const vsc_sleep_options* sleep;  ///< its sleep
  const int* exclude;              ///< the instances its 'exclude' names
  int exclude_count;
  const vsc_partner_exchange* exchange;  ///< its own exchange (what it handed the higher instances)
} vsc_partner_view;

/// The host's view of instance `instance` of the model; `build` 1: the host may
/// build its caches (a higher instance, at this data's first step), 0: only
/// if they exist (a lower instance, which advanced first).
typedef vsc_partner_view (*vsc_partner_viewer)(void* host, int instance, int build);

/// One instance's exchange with the others: the higher instances it collides
/// with (their tubes as capsules after its own geoms), the loads and the
/// pressed capsules it hands them through its own buffers, and the sums of
/// what several lower instances handed it. Owned by its instance's caches.
struct vsc_partner_exchange {
  int instances;          ///< instances of the model
  int known;              ///< 1: the partners were looked up (at this data's first step)
  int count;              ///< higher instances it collides with
  int* partners;          ///< their instance ids
  int geoms;              ///< their capsules, in all
  int most_spheres;       ///< the most spheres any of them has
  double* centres;        ///< a partner's sphere centres (m) and velocities (m/s) at the step start,
  double* velocities;     ///< 3 per sphere each (its rod is read, never written)
  vsc_geom* all_geoms;    ///< the host's candidate geoms, then the partners' capsules
  double* all_wrench;     ///< the reaction on each of them, averaged over a step (6 each)
  int* handed_offset;     ///< per instance: where this step's loads for it start in `handed` (-1: none)
  double* handed;         ///< the loads this step handed each higher partner (3 per control point of each, N)
  unsigned char* handed_any;  ///< per instance: 1 if `handed` holds its loads this step
  int* pressed_offset;    ///< per instance: where its capsules start in `pressed`
  unsigned char* pressed; ///< per capsule of each higher partner: 1 if a moving sphere of this one pressed it
                          ///< this step (what wakes the partner's sleeping points there, as a moving geom would)
  double* waking_speed;   ///< per instance: a sphere faster than this (m/s) wakes what it presses of it
  double* load;           ///< the loads several lower instances handed over this step, summed (3 per point, N)
  unsigned char* pressed_by_several;  ///< per capsule: several lower instances' `pressed` flags, or-ed
};

/// An exchange for an instance of n control points and `spheres` spheres; 0,
/// or -1 if memory ran out.
int vsc_partners_create(vsc_partner_exchange* exchange, int instances, int control_count, int spheres);
void vsc_partners_free(vsc_partner_exchange* exchange);

/// A new step: the loads handed over last step were felt, none yet this step.
void vsc_partners_clear_handed(vsc_partner_exchange* exchange);

/// The higher instances that instance `self` (of view `own`) collides with,
/// not excluded by either's 'exclude', and room for their capsules after
/// `geom_count` geoms and for the loads it hands them: looked up once per
/// data, at its first step, when every instance's config can be read. 0, or
/// -1 if memory ran out (then it has none).
int vsc_partners_find(vsc_partner_exchange* exchange, vsc_partner_viewer view, void* host, int self,
                      const vsc_partner_view* own, int geom_count);

/// Gather: the host's `geom_count` geoms, then the partners' tubes as capsules
/// at the step start (lower instances advance first and only hand over loads),
/// into the world (its geoms and their reactions); and the loads and pressed
/// capsules the lower instances handed this one. `contacts` 0: MuJoCo's
/// contacts are off, no capsules; `timestep` (s); `friction`: this tube's self_friction.
void vsc_partners_gather(vsc_partner_exchange* exchange, vsc_partner_viewer view, void* host, int self, int contacts,
                         const vsc_geom* geoms, int geom_count, double friction, double timestep, vsc_world* world,
                         vsc_reactions* reactions);

/// Scatter: the reactions on the partners' capsules handed to them as loads,
/// and the capsules this instance's moving spheres pressed (`rod` stepped, its
/// rest records `rest` after the step, its sleep `sleep`) flagged for them. `geom_count`:
/// the host's own geoms before the capsules.
void vsc_partners_scatter(vsc_partner_exchange* exchange, vsc_partner_viewer view, void* host, const vsc_rod* rod,
                          const vsc_sleep_options* sleep, const double* rest, int geom_count,
                          const vsc_world* world, const vsc_reactions* reactions);

/// The capsules along another rod's spheres, at `centres` (m) moving at
/// `velocities` (m/s; 3 per sphere each, vsc_rod_sphere_points) with `rod`'s
/// radii: spheres - 1 capsules into `out`, each of the
/// mean radius of its two spheres (m) and Coulomb coefficient `friction`, each moving rigidly with its two
/// spheres (the velocity of its middle, the spin of its axis). Each sphere is
/// placed `ahead` seconds along its velocity: the core holds a geom still over
/// a step, and a partner held where it will be at mid-step (ahead = dt / 2)
/// meets the rod where it moves to, not where it was (a tube falling at 2 m/s
/// moves 4 mm, a third of its radius, in a 2 ms step).
void vsc_partner_capsules(const vsc_rod* rod, const double* centres, const double* velocities, int spheres,
                          double friction, double ahead, vsc_geom* out);

/// Add the reactions on those capsules (`wrench`: 6 per capsule, force N and
/// torque N m about its middle, averaged over a step; vsc_world.geom_wrench)
/// to `load` (3 per control point of `rod`, of `spheres` collision spheres;
/// generalized forces, N): each
/// capsule's force and torque across its axis become forces at its two
/// spheres, spread onto the control points as the rod's contacts spread theirs
/// (vsc_rod_add_sphere_force).
void vsc_partner_add_load(const vsc_rod* rod, int spheres, const vsc_geom* capsules, const double* wrench,
                          double* load);

#endif  // VISCERA_PLUGIN_PARTNERS_H
