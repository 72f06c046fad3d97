// One step of the rod, top to bottom: the step context, the start state kept
// for retries, the divergence guard's budget; then each attempt's substeps
// (place, forces and the scheme in the integrator's substep, then friction);
// then the guard; retries with twice the substeps; and, if none held, the
// start restored (see viscera/vsc_integrate.h).
#include "vsc_step.h"

#include <math.h>
#include <string.h>

#include "viscera/vsc_grasp.h"
#include "viscera/vsc_energy.h"
#include "vsc_contact.h"
#include "vsc_forces.h"
#include "vsc_place.h"
#include "vsc_friction.h"
#include "vsc_schemes.h"
#include "vsc_sleep.h"

vsc_step_options vsc_default_step_options(void) {
  vsc_step_options options = {VSC_INTEGRATOR_LEAPFROG, 1, 4, 1.0, 3.0, 1, VSC_CONTACT_DAMPING_LIMIT,
                                 vsc_default_sleep_options()};
  return options;
}

static int state_is_sane(const double* q, const double* v, int size) {
  for (int i = 0; i < size; ++i)
    if (!isfinite(q[i]) || !(fabs(v[i]) < VSC_DIVERGED_SPEED)) return 0;
  return 1;
}

static void clear_reactions(const vsc_step_context* context) {
  const vsc_reactions* r = context->reactions;
  const vsc_world* world = context->world;
  if (r->geom_wrench) memset(r->geom_wrench, 0, sizeof(double) * 6 * (size_t)world->geom_count);
  if (r->grasp_force) memset(r->grasp_force, 0, sizeof(double) * 3 * (size_t)world->grasp_count);
}

// The divergence guard: a step diverged if the rod's mechanical energy grew
// past its budget (vsc_step_options), counting the contact penalty's
// potential only when the balance without it fails.
typedef struct guard {
  double start_energy;   // kinetic + elastic + gravity at the step start (J)
  double start_active;   // kinetic + elastic at the step start (J)
  double slack;          // 1/2 mass energy_jump_speed^2 (J)
  double allowed;        // the growth allowed without the contact potential (J)
  double start_contact;  // contact potential at the step start (J; -1: not evaluated yet)
  int contacts;          // 1 if the rod can touch anything
} guard;

void vsc_step_backup_carve(vsc_step_backup* b, double* block, int n, int spheres) {
  b->q = block;
  b->v = b->q + 3 * (size_t)n;
  b->stick = b->v + 3 * (size_t)n;
  b->energy_q = b->stick + VSC_STICK_SIZE * (size_t)spheres;
  b->energy_v = b->energy_q + 3 * (size_t)n;
  b->energy_spheres = b->energy_v + 3 * (size_t)n;
  b->energy_known = 0;
}

// Kinetic + elastic energy at (q, v) (J); the last state asked about is
// remembered, so one step's end is not computed again as the next one's start.
static double active_energy(const vsc_rod* rod, vsc_step_backup* b, const double* q, const double* v) {
  size_t bytes = sizeof(double) * 3 * (size_t)rod->n;
  if (b->energy_known && memcmp(b->energy_q, q, bytes) == 0 && memcmp(b->energy_v, v, bytes) == 0)
    return b->energy_active;
  b->energy_active = vsc_rod_active_energy(rod, q, v);
  memcpy(b->energy_q, q, bytes);
  memcpy(b->energy_v, v, bytes);
  b->energy_known = 1;
  return b->energy_active;
}

static double mechanical_energy(const vsc_rod* rod, const vsc_world* world, const double* q, const double* v,
                                double* kinetic_elastic) {
  *kinetic_elastic = active_energy(rod, rod->stages.backup, q, v);
  return *kinetic_elastic + vsc_rod_gravity_energy(rod, world->gravity, q);
}

double vsc_step_contact_energy(const vsc_rod* rod, const vsc_world* world, const double* q,
                               vsc_deepest_contact* deepest) {
  vsc_contact_lists* lists = rod->stages.broad_phase;
  int listed = 1;
  if ((world->geom_count > 0 || rod->def.self_collision) && !vsc_contact_lists_cover(lists, rod, q, world)) {
    double* spheres = rod->stages.backup->energy_spheres;
    vsc_rod_sphere_points(rod, q, NULL, spheres, NULL);
    listed = vsc_contact_lists_refresh(rod, lists, spheres, world);
  }
  return vsc_contact_energy(rod, world, q, lists, listed, deepest);
}

static double contact_energy(const vsc_rod* rod, const vsc_world* world, const double* q) {
  return vsc_step_contact_energy(rod, world, q, NULL);
}

static guard guard_begin(const vsc_rod* rod, const vsc_world* world, const double* q, const double* v,
                         const vsc_step_options* o) {
  guard g;
  g.start_energy = mechanical_energy(rod, world, q, v, &g.start_active);
  g.slack = 0.5 * rod->def.mass * o->energy_jump_speed * o->energy_jump_speed;
  g.allowed = o->energy_jump_ratio * g.start_active + g.slack;
  g.contacts = world->geom_count > 0 || rod->def.self_collision;
  g.start_contact = -1.0;
  return g;
}

// 1 if the step from start_q to (q, v) kept within the budget.
static int guard_holds(guard* g, const vsc_rod* rod, const vsc_world* world, const double* start_q, const double* q,
                       const double* v, const vsc_step_options* o) {
  double active, energy = mechanical_energy(rod, world, q, v, &active);
  if (isfinite(energy) && energy - g->start_energy <= g->allowed) return 1;
  if (!g->contacts || !isfinite(energy)) return 0;
  // A rod pushed out of a geom turns the penalty's potential into kinetic
  // energy legitimately. Evaluated lazily, as it costs a narrow phase; it
  // changes nothing the next evaluation reads.
  if (g->start_contact < 0.0) g->start_contact = contact_energy(rod, world, start_q);
  double end_contact = contact_energy(rod, world, q);
  double jump = energy + end_contact - (g->start_energy + g->start_contact);
  // the allowance grows with the stored contact energy: an embedded rod may release it,
  // but no more than that (a blow-up from deep contact still trips the guard)
  return jump <= o->energy_jump_ratio * (g->start_active + g->start_contact) + g->slack;
}

// One attempt at the whole step with `substeps` substeps: 0 if a substep diverged.
static int attempt(vsc_step_context* context, const vsc_scheme* scheme, double* q, double* v, int substeps) {
  const vsc_rod* rod = context->rod;
  int size = 3 * rod->n;
  double h = context->dt / (double)substeps;
  clear_reactions(context);
  for (int s = 0; s < substeps; ++s) {
    context->unseen = NULL;
    context->substep = h;
    if (scheme->substep(context, q, v, h) != VSC_OK || !state_is_sane(q, v, size)) return 0;
    // friction, from the last evaluation's contacts
    if (context->stick)
      vsc_rod_update_stick(rod, &rod->stages.contact->touch, vsc_sleep_spheres(rod->stages.sleep), context->stick, h,
                           context->unseen);
  }
  return 1;
}

static vsc_status step(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, double* q, double* v,
                       double* stick, double* rest, double dt, const vsc_step_options* options,
                       vsc_step_report* report);

vsc_status vsc_rod_step(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, double* q, double* v,
                        double* stick, double* rest, double dt, const vsc_step_options* options,
                        vsc_step_report* report) {
  vsc_status status = step(rod, world, reactions ? reactions : &vsc_no_reactions, q, v, stick, rest, dt, options, report);
  vsc_sleep_end(rod, rod->stages.sleep);  // the flags are this step's: a lone evaluation after it sees every point awake
  return status;
}

static vsc_status step(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, double* q, double* v,
                       double* stick, double* rest, double dt, const vsc_step_options* options,
                       vsc_step_report* report) {
  vsc_step_context context = {rod, world, reactions, stick, dt, 0.0, NULL, 0.0, VSC_CONTACT_DAMPING_LIMIT, 0, NULL};
  vsc_sleep_flags* sleep = rod->stages.sleep;
  vsc_step_backup* backup = rod->stages.backup;
  clear_reactions(&context);  // overwritten whatever the step does, even refused
  vsc_step_options o = options ? *options : vsc_default_step_options();
  if (o.substeps < 1 || o.retries < 0 || !(dt > 0.0) || !(o.energy_jump_ratio >= 0.0) ||
      !(o.energy_jump_speed >= 0.0) || (unsigned)o.integrator >= VSC_INTEGRATOR_COUNT ||
      !(o.damping_limit >= VSC_KICK_DAMPING_LIMIT && o.damping_limit <= VSC_CONTACT_DAMPING_LIMIT))
    return VSC_ERROR_INVALID_ARGUMENT;
  // the contact pass's bound on a pile's damping: the step's where the scheme applies damping explicitly
  if (vsc_schemes[o.integrator].explicit_damping) context.damping_limit = o.damping_limit;
  context.length_implicit = o.length_implicit && vsc_schemes[o.integrator].length_implicit;
  vsc_sleep_host_wakes(rod, world, q, rest);
  int sleeping = rest && o.sleep.enabled;
  if (sleeping && (!rod->def.lumped_mass || o.integrator == VSC_INTEGRATOR_IMPLICIT ||
                   !(o.sleep.rest_speed >= 0.0) || !(o.sleep.rest_time > 0.0)))
    return VSC_ERROR_INVALID_ARGUMENT;
  if (report) {
    report->retries = 0;
    report->substeps = 0;
  }
  // sleeping points held still; a rod asleep everywhere only feels moving bodies, unless they wake it
  if (sleeping) context.rest = rest;
  int asleep = vsc_sleep_begin(rod, sleep, sleeping ? &o.sleep : NULL, q, rest, v);
  if (asleep == rod->n) {  // (the reactions were cleared above; only moving geoms push it)
    vsc_forces_at_rest(&context, q, rod->stages.scheme->stage);
    if (vsc_sleep_rest(rod, sleep, rod->stages.contact, world, &o.sleep, q, rest)) return VSC_OK;
    vsc_sleep_begin(rod, sleep, &o.sleep, q, rest, v);
  }
  const vsc_scheme* scheme = &vsc_schemes[o.integrator];
  int size = 3 * rod->n, spheres = rod->def.collision_sphere_count;
  for (int i = 0; i < rod->def.pinned_count; ++i) {  // pinned means fixed, whatever the state said
    double* pinned_velocity = v + 3 * rod->pinned[i];
    pinned_velocity[0] = pinned_velocity[1] = pinned_velocity[2] = 0.0;
  }
  // the start, kept for retries
  double* start_q = backup->q;
  double* start_v = backup->v;
  double* start_stick = backup->stick;
  memcpy(start_q, q, sizeof(double) * size);
  memcpy(start_v, v, sizeof(double) * size);
  if (stick) memcpy(start_stick, stick, sizeof(double) * VSC_STICK_SIZE * (size_t)spheres);
  guard g = guard_begin(rod, world, q, v, &o);
  int substeps = o.substeps;
  for (int retry = 0; retry <= o.retries; ++retry) {
    if (retry > 0) {  // from the step start again, with twice the substeps
      memcpy(q, start_q, sizeof(double) * size);
      memcpy(v, start_v, sizeof(double) * size);
      if (stick) memcpy(stick, start_stick, sizeof(double) * VSC_STICK_SIZE * (size_t)spheres);
      if (2 * substeps > VSC_MAX_RETRY_SUBSTEPS) break;
      substeps *= 2;
      if (sleeping) vsc_sleep_retry(rod, sleep);  // the failed attempt's edge loads count for nothing
    }
    if (report) {
      report->retries = retry;
      report->substeps = substeps;
    }
    if (attempt(&context, scheme, q, v, substeps) && guard_holds(&g, rod, world, start_q, q, v, &o)) {
      if (sleeping) vsc_sleep_advance(rod, sleep, rod->stages.contact, world, &o.sleep, start_q, q, dt, rest);
      return VSC_OK;
    }
  }
  if (sleeping) vsc_sleep_wake_all(rod, sleep, start_q, rest);
  // none held: back to the start, at rest
  memcpy(q, start_q, sizeof(double) * size);
  memset(v, 0, sizeof(double) * size);
  if (!state_is_sane(q, v, size)) memset(q, 0, sizeof(double) * size);
  if (stick) vsc_stick_clear(stick, spheres);
  clear_reactions(&context);
  return VSC_ERROR_DIVERGED;
}
