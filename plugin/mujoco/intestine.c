// viscera.intestine callbacks: the rod integrates in `advance` (once per
// mj_step, whatever MuJoCo's integrator) and stores the reaction it exerted on
// each body, averaged over that step, in plugin_state; `compute` adds those
// stored wrenches to qfrc_passive. The bodies thus receive, one step later,
// exactly the impulse the rod gave them (momentum is exchanged exactly), and
// calling compute four times under RK4, or from mj_forward, changes nothing.
#include "intestine.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "caches.h"
#include "geoms.h"
#include "grasps.h"
#include "partners.h"
#include "state_layout.h"
#include "config.h"
#include "viscera/vsc_contact.h"
#include "viscera/vsc_grasp.h"
#include "viscera/vsc_place.h"
#include "viscera/vsc_skin.h"
#include "viscera/vsc_sleep.h"
#include "viscera/vsc_stability.h"

#define ERROR_SIZE 512

typedef struct intestine {
  const mjModel* model;   // the model these caches were built for
  vsc_plugin_config config;
  vsc_rod* rod;
  double* initial_q;      // initial control points (m, 3n)
  vsc_mujoco_geoms world;  // the MuJoCo geoms that may touch the intestine (geoms.h)
  double* geom_wrench;    // reaction on each of them, averaged over a step (6 x world.count)
  int warned_passive_off; // the passive-off warning was given for this data
  int checked_start;      // the first step of this data looked for a start inside a geom
  vsc_state_layout layout;  // plugin_state's blocks for this model and config (state_layout.h)
  double elastic_frequency;  // highest angular frequencies at the initial shape (rad/s), vsc_rod_frequencies,
  double kicked_frequency;   // computed at creation when the substeps come from the timestep: elastic,
  double contact_frequency;  // elastic without the global length term, contact
  double plan_timestep;      // the timestep (s) `plan` was chosen for (0: none yet)
  vsc_plugin_step_plan plan; // what each step takes at that timestep
  vsc_mujoco_holds holds;  // this step's holds (grasps.h)
  // contacts with the other intestine instances (partners.h): this one computes those with the
  // higher instances and hands them loads through its own exchange, which they read; the lower
  // ones hand it theirs
  int plugin_slot;        // viscera.intestine's index in MuJoCo's plugin table (which instances are intestines)
  vsc_partner_exchange partners;
} intestine;

static void intestine_free(intestine* it) {
  if (!it) return;
  vsc_mujoco_geoms_free(&it->world);
  vsc_rod_destroy(it->rod);
  vsc_plugin_config_free(&it->config);
  free(it->initial_q);
  free(it->geom_wrench);
  vsc_partners_free(&it->partners);
  free(it);
}

// plugin_state's blocks for this model and config (state_layout.h)
static vsc_state_layout layout_of(const mjModel* m, const vsc_plugin_config* c) {
  return vsc_state_layout_of(c->rod.control_count, c->rod.collision_sphere_count, (int)m->nbody, c->grasp.count);
}

// Build every model-derived cache. Returns NULL and fills `error` on failure.
static intestine* intestine_create(const mjModel* m, int instance, char* error) {
  intestine* it = (intestine*)calloc(1, sizeof(intestine));
  if (!it) return NULL;
  if (vsc_plugin_config_read(m, instance, &it->config, error, ERROR_SIZE)) {
    free(it);
    return NULL;
  }
  it->model = m;
  it->plugin_slot = -1;
  mjp_getPlugin("viscera.intestine", &it->plugin_slot);
  int n = it->config.rod.control_count;
  it->initial_q = (double*)malloc(sizeof(double) * 3 * (size_t)n);
  it->geom_wrench = (double*)malloc(sizeof(double) * 6 * (size_t)(m->ngeom > 0 ? m->ngeom : 1));
  if (!it->initial_q || !it->geom_wrench ||
      vsc_partners_create(&it->partners, m->nplugin, n, it->config.rod.collision_sphere_count) ||
      vsc_mujoco_geoms_create(m, &it->world)) {
    strcpy(error, "viscera.intestine: out of memory");
    intestine_free(it);
    return NULL;
  }
  if (vsc_plugin_config_check_timestep(&it->config, m->opt.timestep, error, ERROR_SIZE) ||
      vsc_plugin_config_layout(&it->config, it->initial_q, error, ERROR_SIZE) ||
      vsc_plugin_config_clamp(&it->config, it->initial_q, error, ERROR_SIZE)) {
    intestine_free(it);
    return NULL;
  }
  it->layout = layout_of(m, &it->config);
  vsc_status status = vsc_rod_create(&it->config.rod, &it->rod);
  if (status != VSC_OK) {
    snprintf(error, ERROR_SIZE, "viscera.intestine: cannot build the rod: %s", vsc_status_string(status));
    intestine_free(it);
    return NULL;
  }
  if (it->config.auto_substeps) {  // here, not in the first step: about 1-2 ms each, which no step should pay
    vsc_rod_frequencies(it->rod, it->initial_q, 0, &it->elastic_frequency, &it->contact_frequency);
    vsc_rod_frequencies(it->rod, it->initial_q, 1, &it->kicked_frequency, &it->contact_frequency);
  }
  return it;
}

static int config_state_size(const mjModel* m, const vsc_plugin_config* c) { return layout_of(m, c).total; }

// The gravity the rod feels (m/s^2): the model's, unless disabled.
static void model_gravity(const mjModel* m, double gravity[3]) {
  int off = (m->opt.disableflags & mjDSBL_GRAVITY) != 0;
  for (int c = 0; c < 3; ++c) gravity[c] = off ? 0.0 : m->opt.gravity[c];
}

static void write_initial_state(const mjModel* m, const vsc_plugin_config* c, const double* initial_q, mjtNum* state) {
  int n = c->rod.control_count;
  if (initial_q != state) memcpy(state, initial_q, sizeof(double) * 3 * (size_t)n);
  vsc_state_layout l = layout_of(m, c);
  memset(state + l.offset[VSC_STATE_VELOCITIES], 0,
         sizeof(double) * (size_t)(l.offset[VSC_STATE_FRICTION] - l.offset[VSC_STATE_VELOCITIES]));
  vsc_stick_clear(state + l.offset[VSC_STATE_FRICTION], c->rod.collision_sphere_count);
  memset(state + l.offset[VSC_STATE_GRASPS], 0, sizeof(double) * (size_t)l.size[VSC_STATE_GRASPS]);
  vsc_rest_wake_all(n, state, state + l.offset[VSC_STATE_REST]);
  model_gravity(m, state + l.offset[VSC_STATE_GRAVITY]);
  memset(state + l.offset[VSC_STATE_DAMAGE], 0, sizeof(double) * (size_t)l.size[VSC_STATE_DAMAGE]);
}

// Build this instance's caches for `m` and make them d's: the model's state
// must be the size the config needs (an MJB saved with another config would
// overflow it). Any stale entry at this address (a freed mjData) is released.
// Returns the caches, or NULL with `error` filled.
static intestine* install_or_explain(const mjModel* m, mjData* d, int instance, int fresh, char* error) {
  intestine* it = intestine_create(m, instance, error);
  if (!it) return NULL;
  if (m->plugin_statenum[instance] != config_state_size(m, &it->config)) {
    snprintf(error, ERROR_SIZE, "viscera.intestine: the model's state holds %d numbers, its config needs %d",
             m->plugin_statenum[instance], config_state_size(m, &it->config));
    intestine_free(it);
    return NULL;
  }
  void* replaced = vsc_caches_install(d, instance, it, fresh);
  if (replaced == it) {  // out of memory
    intestine_free(it);
    strcpy(error, "viscera.intestine: out of memory");
    return NULL;
  }
  intestine_free((intestine*)replaced);
  return it;
}

// install_or_explain, the error as MuJoCo's warning.
static intestine* install(const mjModel* m, mjData* d, int instance, int fresh) {
  char error[ERROR_SIZE];
  intestine* it = install_or_explain(m, d, instance, fresh, error);
  if (!it) mju_warning("%s", error);
  return it;
}

int vsc_intestine_reconfigure(const mjModel* m, mjData* d, int instance, char* error, int error_size) {
  char message[ERROR_SIZE];
  int slot = -1;
  if (instance < 0 || instance >= m->nplugin || !mjp_getPlugin("viscera.intestine", &slot) ||
      m->plugin[instance] != slot) {
    snprintf(error, (size_t)error_size, "viscera.intestine: plugin instance %d is not a viscera.intestine", instance);
    return -1;
  }
  if (install_or_explain(m, d, instance, 0, message)) return 0;
  snprintf(error, (size_t)error_size, "%s", message);
  return -1;
}

// The caches of this data, through its plugin_data (caches.h), lock-free; a
// pickled copy finds its own at its first step (its plugin_data names its
// original's), and they are rebuilt if the data is stepped with another model
// (multi-model rollouts). NULL only if building fails.
static intestine* caches(const mjModel* m, mjData* d, int instance) {
  intestine* it = (intestine*)vsc_caches_resolve(d, instance);
  if (it && it->model == m) return it;
  if (!it) it = (intestine*)vsc_caches_adopt(d, instance);
  return it && it->model == m ? it : install(m, d, instance, 0);
}

_Static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "all_finite reads the high word second");

static int all_finite(const mjtNum* x, int size) {
  // an OR over the exponents' high words (all ones: inf or NaN), 32-bit compares that vectorise
  // on any x86-64; an early-exit isfinite loop does not, and this runs over the whole state every
  // step (a sleeping bowel's largest single cost). Little-endian: the high word is the second.
  uint32_t not_finite = 0;
  for (int i = 0; i < size; ++i) {
    uint32_t high;
    memcpy(&high, (const char*)(x + i) + 4, sizeof(high));
    not_finite |= (high & 0x7ff00000u) == 0x7ff00000u;
  }
  return !not_finite;
}

// Friction partners are indices stored as doubles: anything out of range
// (a state written by hand, say) becomes "no partner" before it is cast.
static void sanitize_stick(mjtNum* stick, int spheres, int geoms) {
  for (int i = 0; i < spheres; ++i) {
    mjtNum* s = stick + VSC_STICK_SIZE * i;
    if (!(s[0] >= 0.0 && s[0] < geoms)) s[0] = -1.0;
    if (!(s[4] >= 0.0 && s[4] < spheres)) s[4] = -1.0;
  }
}

static int contacts_enabled(const mjModel* m) { return !(m->opt.disableflags & mjDSBL_CONTACT); }

// Each tool force sensor reads 6 numbers (its body is checked in init: the
// sensor's object is not resolved yet when MuJoCo asks for the size).
static int intestine_nsensordata(const mjModel* m, int instance, int sensor_id) { return 6; }

// Every sensor of this instance must name the body it measures.
static int check_sensors(const mjModel* m, int instance) {
  for (int s = 0; s < m->nsensor; ++s) {
    if (m->sensor_plugin[s] != instance) continue;
    if (m->sensor_objtype[s] != mjOBJ_BODY || m->sensor_objid[s] < 0 || m->sensor_objid[s] >= m->nbody) {
      const char* name = mj_id2name(m, mjOBJ_SENSOR, s);
      mju_warning("viscera.intestine: sensor '%s' must name the body it measures: objtype=\"body\" objname=\"...\"",
                  name ? name : "(unnamed)");
      return -1;
    }
  }
  return 0;
}

// The state's size. A config that cannot be read gets none here, and init
// refuses it with its message: no mju_error (it aborts a C host), nothing to leak.
static int intestine_nstate(const mjModel* m, int instance) {
  vsc_plugin_config config;
  char error[ERROR_SIZE];
  if (vsc_plugin_config_read(m, instance, &config, error, ERROR_SIZE)) return 0;
  int size = config_state_size(m, &config);
  vsc_plugin_config_free(&config);
  return size;
}

static int intestine_init(const mjModel* m, mjData* d, int instance) {
  if (check_sensors(m, instance)) return -1;
  intestine* it = install(m, d, instance, 1);
  if (!it) return -1;
  write_initial_state(m, &it->config, it->initial_q, d->plugin_state + m->plugin_stateadr[instance]);
  return 0;
}

static void intestine_destroy(mjData* d, int instance) {
  intestine_free((intestine*)vsc_caches_release(d, instance));
}

// mj_copyData keeps dest's own caches (its plugin_data) and copies the state;
// dest also takes what src's caches record of its history, so that a copy
// neither warns again nor runs the start's check again.
static void intestine_copy(mjData* dest, const mjModel* m, const mjData* src, int instance) {
  const intestine* from = (const intestine*)vsc_caches_resolve(src, instance);
  intestine* to = caches(m, dest, instance);
  if (!from || !to || from->model != m) return;
  to->warned_passive_off = from->warned_passive_off;
  to->checked_start = from->checked_start;
}

typedef struct reset_request {
  const mjModel* m;
  mjtNum* plugin_state;
  int done;
} reset_request;

// Under the caches' mutex (the cache cannot be freed meanwhile): the config
// read when the cache was built, and the initial shape laid out then.
static void reset_from_cache(void* cache, void* context) {
  intestine* it = (intestine*)cache;
  reset_request* request = (reset_request*)context;
  if (it->model != request->m) return;
  write_initial_state(request->m, &it->config, it->initial_q, request->plugin_state);
  request->done = 1;
}

// plugin_data is used only if it names a live cache of this instance for this
// model, whichever data owns it: a pickled copy may carry its original's handle
// (the same model: the same initial state) or one from another process (caches.h).
// Otherwise the config is read again.
static void intestine_reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  reset_request request = {m, plugin_state, 0};
  if (plugin_data) vsc_caches_visit((uintptr_t)plugin_data, instance, reset_from_cache, &request);
  if (request.done) return;
  vsc_plugin_config config;
  char error[ERROR_SIZE];
  if (vsc_plugin_config_read(m, instance, &config, error, ERROR_SIZE)) return;  // checked at load
  if (m->plugin_statenum[instance] == config_state_size(m, &config) &&
      vsc_plugin_config_layout(&config, plugin_state, error, ERROR_SIZE) == 0)
    write_initial_state(m, &config, plugin_state, plugin_state);
  vsc_plugin_config_free(&config);
}

// What the exports read of a data's caches, copied under the caches' mutex.
typedef struct config_request {
  const mjModel* m;
  vsc_skin_def skin;
  int control_count;
  vsc_grasper_config grasp;
  int found;
} config_request;

static void copy_config(void* cache, void* context) {
  intestine* it = (intestine*)cache;
  config_request* request = (config_request*)context;
  if (it->model != request->m) return;
  request->skin = it->config.skin;
  request->control_count = it->config.rod.control_count;
  request->grasp = it->config.grasp;
  request->found = 1;
}

int vsc_intestine_skin_def(const mjModel* m, const mjData* d, int instance, vsc_skin_def* skin, int* control_count) {
  config_request request = {.m = m};
  if (d) vsc_caches_with(d, instance, copy_config, &request);
  if (request.found) *skin = request.skin, *control_count = request.control_count;
  return request.found;
}

int vsc_intestine_grasper_config(const mjModel* m, const mjData* d, int instance, vsc_grasper_config* grasp) {
  config_request request = {.m = m};
  if (d) vsc_caches_with(d, instance, copy_config, &request);
  if (request.found) *grasp = request.grasp;
  return request.found;
}

// Tool force sensors of this instance: the wrench the intestine exerted on the
// sensor's body over the last step, torque about the body frame origin.
static void compute_sensors(const mjModel* m, mjData* d, int instance, const mjtNum* wrench) {
  for (int s = 0; s < m->nsensor; ++s) {
    if (m->sensor_plugin[s] != instance) continue;
    int body = m->sensor_objid[s];
    const mjtNum* w = wrench + 6 * body;
    mjtNum* out = d->sensordata + m->sensor_adr[s];
    if (!all_finite(w, 6)) {  // never hand MuJoCo a NaN
      memset(out, 0, sizeof(mjtNum) * 6);
      continue;
    }
    const mjtNum* com = d->xipos + 3 * body;
    const mjtNum* origin = d->xpos + 3 * body;
    double arm[3] = {com[0] - origin[0], com[1] - origin[1], com[2] - origin[2]};
    memset(out, 0, sizeof(mjtNum) * 6);
    vsc_wrench_add(out, 1.0, w, w + 3, arm);
  }
}

// Reaction of the intestine on the MuJoCo bodies over the last step, into
// qfrc_passive, and the tool force sensors (the rod's state is not read:
// compute has nothing to integrate).
static void intestine_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  intestine* it = caches(m, d, instance);
  if (!it) return;
  const mjtNum* wrench = d->plugin_state + m->plugin_stateadr[instance] + it->layout.offset[VSC_STATE_WRENCHES];
  if (capability_bit == mjPLUGIN_SENSOR) {
    compute_sensors(m, d, instance, wrench);
    return;
  }
  if (capability_bit != mjPLUGIN_PASSIVE) return;
  for (int body = 1; body < m->nbody; ++body) {
    const mjtNum* w = wrench + 6 * body;
    if (w[0] == 0 && w[1] == 0 && w[2] == 0 && w[3] == 0 && w[4] == 0 && w[5] == 0) continue;
    if (!all_finite(w, 6)) continue;  // never hand MuJoCo a NaN
    mj_applyFT(m, d, w, w + 3, d->xipos + 3 * body, body, d->qfrc_passive);
  }
}

// A start inside a geom is pushed out (at up to VSC_PUSH_OUT_SPEED), not
// refused: say so once per data, naming the geom, since it is rarely meant.
// Resting contact sinks m g / k per sphere (hundredths of a mm), but a settled
// pile squeezed against pinned parts sinks more (1.7 mm, 0.16 r, in the
// anatomical abdomen's bank): only the push-out's own depth, VSC_DEEP_CONTACT
// radii, counts.
static void warn_start_inside(const mjModel* m, intestine* it, const vsc_world* world, const mjtNum* state) {
  it->checked_start = 1;
  if (world->geom_count <= 0) return;
  // the advice is about the config's start: a state set since (mj_setState of a snapshot taken
  // while a tool pressed the bowel, a task's settled start) is the user's own, not a misplaced start
  const double* positions = state + it->layout.offset[VSC_STATE_POSITIONS];
  if (memcmp(positions, it->initial_q, sizeof(double) * 3 * (size_t)it->config.rod.control_count) != 0) return;
  vsc_deepest_contact deepest;
  vsc_rod_contact_energy(it->rod, world, positions, &deepest);
  if (deepest.geom < 0 || !(deepest.depth > VSC_DEEP_CONTACT * vsc_rod_sphere_radii(it->rod)[deepest.sphere])) return;
  int g = it->world.ids[deepest.geom];
  const char* name = mj_id2name(m, mjOBJ_GEOM, g);
  char unnamed[32];
  if (!name) {
    snprintf(unnamed, sizeof(unnamed), "#%d (unnamed)", g);
    name = unnamed;
  }
  mju_warning("viscera.intestine: the intestine starts inside geom '%s', %.3g mm deep at abscissa %.3g m; "
              "it is pushed out at up to %g m/s. Move its start ('start', 'points' or 'box') clear of the geom",
              name, 1e3 * deepest.depth,
              it->config.rod.length * deepest.sphere / (double)(it->config.rod.collision_sphere_count - 1),
              VSC_PUSH_OUT_SPEED);
}

// The step's plan (vsc_plugin_config_plan: substeps, the length term in the
// kick, the pile's damping limit), chosen again only when the timestep
// changes. The estimate is taken at the initial shape, from the model alone, so
// every copy of a data chooses alike.
static void plan_step(const mjModel* m, intestine* it, vsc_step_options* step) {
  if (it->plan_timestep != m->opt.timestep) {
    it->plan = vsc_plugin_config_plan(&it->config, it->elastic_frequency, it->kicked_frequency, it->contact_frequency,
                                      vsc_rod_contact_damping_rate(it->rod), m->opt.timestep);
    it->plan_timestep = m->opt.timestep;
  }
  step->substeps = it->plan.substeps;
  step->length_implicit = it->plan.length_implicit;
  step->damping_limit = it->plan.damping_limit;
}

// A state that is not finite anywhere (a bad mj_setState, say) starts over
// from the initial shape, counted as a divergence. Returns 1 if it did.
static int restart_if_not_finite(const mjModel* m, intestine* it, int instance, mjtNum* state) {
  const vsc_state_layout l = it->layout;
  if (all_finite(state, m->plugin_statenum[instance])) return 0;
  mju_warning("viscera.intestine: non-finite state, reset to the initial shape");
  double count = isfinite(state[l.offset[VSC_STATE_DIVERGENCES]]) ? state[l.offset[VSC_STATE_DIVERGENCES]] : 0.0;
  double recovered = isfinite(state[l.offset[VSC_STATE_RECOVERIES]]) ? state[l.offset[VSC_STATE_RECOVERIES]] : 0.0;
  write_initial_state(m, &it->config, it->initial_q, state);
  state[l.offset[VSC_STATE_DIVERGENCES]] = count + 1.0;
  state[l.offset[VSC_STATE_RECOVERIES]] = recovered;
  return 1;
}

// Once per data, at its first step (init also runs inside MuJoCo's compiler, on
// a model whose flags are not the scene's): the model's flags the user rarely
// means, and a start inside a geom.
static void warn_once(const mjModel* m, intestine* it, const vsc_world* world, const mjtNum* state) {
  int passive_off = (m->opt.disableflags & mjDSBL_SPRING) && (m->opt.disableflags & mjDSBL_DAMPER);
  if (passive_off && world->geom_count > 0 && !it->warned_passive_off) {
    // mj_passive returns before plugin compute when both are off
    it->warned_passive_off = 1;
    mju_warning("viscera.intestine: MuJoCo's spring and damper flags are both disabled, so bodies do not "
                "feel the intestine (it still feels them); enable either flag");
  }
  if (it->checked_start) return;
  if (!contacts_enabled(m) && it->world.count > 0)  // honoured (it passes through them), but rarely meant
    mju_warning("viscera.intestine: the model disables contacts (<flag contact=\"disable\"/>): the "
                "intestine passes through every geom (its self-collision is its own config key, "
                "'self_collision')");
  warn_start_inside(m, it, world, state);
}

// The exchange's view of instance `instance` (partners.h): `host` is the model and data.
typedef struct host {
  const mjModel* m;
  mjData* d;
  int slot;  // viscera.intestine's index in MuJoCo's plugin table
} host;

static vsc_partner_view view_of(void* data, int instance, int build) {
  host* h = (host*)data;
  vsc_partner_view view;
  memset(&view, 0, sizeof(view));
  if (h->m->plugin[instance] != h->slot) return view;
  intestine* it = build ? caches(h->m, h->d, instance) : (intestine*)vsc_caches_resolve(h->d, instance);
  if (!it || it->model != h->m) return view;
  const mjtNum* s = h->d->plugin_state + h->m->plugin_stateadr[instance];
  view.rod = it->rod;
  view.positions = s + it->layout.offset[VSC_STATE_POSITIONS];
  view.velocities = s + it->layout.offset[VSC_STATE_VELOCITIES];
  view.rest = s + it->layout.offset[VSC_STATE_REST];
  view.control_count = it->config.rod.control_count;
  view.spheres = it->config.rod.collision_sphere_count;
  view.self_friction = it->config.rod.self_friction;
  view.sleep = &it->config.step.sleep;
  view.exclude = it->config.exclude;
  view.exclude_count = it->config.exclude_count;
  view.exchange = &it->partners;
  return view;
}

// Gather: MuJoCo's side of the step, as the core's world. Gravity, the geoms'
// poses and velocities at the step start, the other intestines' tubes, the
// friction state's partners checked, the jaws' holds taken or let go, and the
// loads the lower intestines handed over.
static vsc_world gather(const mjModel* m, mjData* d, intestine* it, mjtNum* state, int instance,
                        vsc_reactions* reactions) {
  const vsc_state_layout l = it->layout;
  vsc_world world = {{0, 0, 0}, it->world.geoms, contacts_enabled(m) ? it->world.count : 0};
  model_gravity(m, world.gravity);
  mjtNum* slept_under = state + l.offset[VSC_STATE_GRAVITY];  // a new gravity wakes every point
  if (memcmp(slept_under, world.gravity, sizeof(world.gravity)) != 0) {
    world.wake_all = 1;
    memcpy(slept_under, world.gravity, sizeof(world.gravity));
  }
  if (world.geom_count > 0) vsc_mujoco_geoms_update(m, d, it->config.friction, &it->world);
  warn_once(m, it, &world, state);
  reactions->geom_wrench = it->geom_wrench;
  reactions->grasp_force = it->holds.reaction;
  host h = {m, d, it->plugin_slot};
  if (!it->partners.known) {
    vsc_partner_view own = view_of(&h, instance, 0);
    if (vsc_partners_find(&it->partners, view_of, &h, instance, &own, it->world.count))
      mju_warning("viscera.intestine: out of memory: instance %d does not collide with the other intestines", instance);
  }
  vsc_partners_gather(&it->partners, view_of, &h, instance, contacts_enabled(m), it->world.geoms, it->world.count,
                      it->config.rod.self_friction, m->opt.timestep, &world, reactions);
  sanitize_stick(state + l.offset[VSC_STATE_FRICTION], it->config.rod.collision_sphere_count, world.geom_count);
  world.grasps = it->holds.grasps;
  world.grasp_count = vsc_mujoco_holds_update(m, d, &it->config.grasp, it->rod, state,
                                              state + l.offset[VSC_STATE_GRASPS], &it->holds);
  return world;
}

// Scatter: the step's average reaction per body, as force and torque about its
// centre of mass, into the wrenches block; the holds' reactions to the jaws
// (a hold slides past the jaws' friction, tears out past slip_force: grasps.h); the
// wall's damage from the holds' pinches and overstretching; the reactions on the partners' capsules
// handed to them as loads.
static void scatter(const mjModel* m, mjData* d, intestine* it, const vsc_world* world,
                    const vsc_reactions* reactions, mjtNum* state) {
  const vsc_state_layout l = it->layout;
  mjtNum* wrench = state + l.offset[VSC_STATE_WRENCHES];
  memset(wrench, 0, sizeof(mjtNum) * 6 * (size_t)m->nbody);
  int rigid = world->geom_count < it->world.count ? world->geom_count : it->world.count;
  for (int i = 0; i < rigid; ++i) {
    const double* w = reactions->geom_wrench + 6 * i;
    int g = it->world.ids[i], body = m->geom_bodyid[g];
    const mjtNum* com = d->xipos + 3 * body;
    double arm[3] = {it->world.geoms[i].position[0] - com[0], it->world.geoms[i].position[1] - com[1],
                     it->world.geoms[i].position[2] - com[2]};
    vsc_wrench_add(wrench + 6 * body, 1.0, w, w + 3, arm);
  }
  vsc_mujoco_holds_release(m, d, &it->config.grasp, &it->holds, it->config.rod.control_count,
                           state + l.offset[VSC_STATE_POSITIONS], state + l.offset[VSC_STATE_GRASPS], wrench);
  // the wall's damage: each hold's pinch over the step (a hold that slipped pinched until it did),
  // and segments stretched past tearing
  int n = it->config.rod.control_count;
  mjtNum* damage = state + l.offset[VSC_STATE_DAMAGE];
  for (int h = 0; h < it->holds.count; ++h)
    if (it->holds.pinch[h] > 0.0)
      vsc_damage_pinch(&it->config.damage, n, it->holds.grasps[h].abscissa, it->holds.pinch[h], m->opt.timestep, damage);
  vsc_damage_stretch(&it->config.damage, n, it->config.rod.length, state + l.offset[VSC_STATE_POSITIONS], damage);
  host h = {m, d, it->plugin_slot};
  vsc_partners_scatter(&it->partners, view_of, &h, it->rod, &it->config.step.sleep, state + l.offset[VSC_STATE_REST],
                       it->world.count, world, reactions);
}

// Count a diverged or recovered step in the state; warn at counts 1, 2, 4, 8...: no spam.
static void count_trouble(const mjData* d, intestine* it, mjtNum* state, vsc_status status,
                          const vsc_step_report* report, int substeps) {
  const vsc_state_layout l = it->layout;
  if (status == VSC_ERROR_DIVERGED) {
    double count = state[l.offset[VSC_STATE_DIVERGENCES]] += 1.0;
    if (count == ldexp(1.0, ilogb(count)))
      mju_warning("viscera.intestine: state diverged at t = %g s even at %d substeps; positions restored, "
                  "velocities zeroed. Use integrator 'implicit', lower the timestep, raise 'substeps' or soften "
                  "'stretch_stiffness'/'contact_stiffness' (%g times so far)", d->time, report->substeps, count);
  } else if (report->retries > 0) {
    double count = state[l.offset[VSC_STATE_RECOVERIES]] += 1.0;
    if (count == ldexp(1.0, ilogb(count)))
      mju_warning("viscera.intestine: state diverged at t = %g s and held at %d substeps instead of %d; "
                  "raise 'substeps' or use integrator 'implicit' (%g recoveries so far)", d->time,
                  report->substeps, substeps, count);
  }
}

// One MuJoCo step of the rod, top to bottom: gather MuJoCo's side into the
// core's world, step the rod against the geoms' poses at the step start,
// scatter the reactions back, count trouble.
static void intestine_advance(const mjModel* m, mjData* d, int instance) {
  intestine* it = caches(m, d, instance);
  if (!it) return;
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  vsc_partners_clear_handed(&it->partners);
  if (restart_if_not_finite(m, it, instance, state)) return;
  const vsc_state_layout l = it->layout;
  vsc_reactions reactions;
  vsc_world world = gather(m, d, it, state, instance, &reactions);
  vsc_step_options step = it->config.step;
  plan_step(m, it, &step);
  vsc_step_report report = {0, 0};
  vsc_status status = vsc_rod_step(it->rod, &world, &reactions, state + l.offset[VSC_STATE_POSITIONS],
                                   state + l.offset[VSC_STATE_VELOCITIES], state + l.offset[VSC_STATE_FRICTION],
                                   state + l.offset[VSC_STATE_REST], m->opt.timestep, &step, &report);
  scatter(m, d, it, &world, &reactions, state);
  count_trouble(d, it, state, status, &report, step.substeps);
}

// The skin's colour where the wall is bruised (0 to 1) or torn: the healthy colour darkens towards
// a bruise's purple as it deepens; torn, dark red. Python's meshcat viewer draws the same
// (viscera_damage_colours).
static const float vsc_bruise_rgb[3] = {0.42f, 0.12f, 0.32f};
static const float vsc_torn_rgb[3] = {0.30f, 0.02f, 0.02f};

void vsc_damage_colour(const float healthy[4], double bruise, int torn, float out[4]) {
  float b = (float)(bruise < 0.0 ? 0.0 : (bruise > 1.0 ? 1.0 : bruise));
  for (int c = 0; c < 3; ++c) out[c] = torn ? vsc_torn_rgb[c] : (1.0f - b) * healthy[c] + b * vsc_bruise_rgb[c];
  out[3] = healthy[3];
}

void vsc_damage_colours(double out[6]) {
  for (int c = 0; c < 3; ++c) out[c] = vsc_bruise_rgb[c], out[3 + c] = vsc_torn_rgb[c];
}

static void intestine_visualize(const mjModel* m, mjData* d, const mjvOption* opt, mjvScene* scn, int instance) {
  intestine* it = caches(m, d, instance);
  if (!it) return;
  const mjtNum* q = d->plugin_state + m->plugin_stateadr[instance];
  if (!all_finite(q, 3 * it->config.rod.control_count)) return;
  // the skin's radius profile on a capsule chain: a triangle per mjvGeom would
  // take 32k geoms for the default skin, past any scene's capacity
  static const float marked[4] = {0.25f, 0.5f, 0.9f, 1.0f};
  const vsc_plugin_config* c = &it->config;
  const float color[4] = {(float)c->rgba[0], (float)c->rgba[1], (float)c->rgba[2], (float)c->rgba[3]};
  double band_from = c->given[VSC_KEY_marked_band] ? c->marked_band[0] / c->rod.length : 2.0;
  double band_to = c->given[VSC_KEY_marked_band] ? c->marked_band[1] / c->rod.length : -1.0;
  int samples = vsc_rod_sample_count(it->rod), n = it->config.rod.control_count;
  int count = c->given[VSC_KEY_draw_capsules] ? c->draw_capsules : samples - 1;
  const mjtNum* damage = q + it->layout.offset[VSC_STATE_DAMAGE];
  double r_min = it->config.skin.radius_min, r_max = it->config.skin.radius_max;
  mjtNum from[3], to[3];
  for (int a = 0; a < count; ++a) {
    double s = ((double)a + 0.5) / (double)count;  // the capsule's middle (fraction of the rest length)
    double x = s * (double)(n - 1), u = x - floor(x);
    double radius = vsc_skin_radius(r_min, r_max, u) * (1.0 + s * (c->skin.taper_end - 1.0));  // tapered: scaled
    if (scn->ngeom >= scn->maxgeom) return;  // scene full: draw what fits
    if (c->given[VSC_KEY_draw_capsules]) {   // the spline itself at even abscissae
      vsc_basis at_from = vsc_spline_basis(n, (double)a / (double)count);
      vsc_basis at_to = vsc_spline_basis(n, (double)(a + 1) / (double)count);
      vsc_basis_point(&at_from, q, from);
      vsc_basis_point(&at_to, q, to);
    } else {                                  // the spring samples, already evaluated
      vsc_rod_sample_point(it->rod, q, a, from);
      vsc_rod_sample_point(it->rod, q, a + 1, to);
    }
    // the wall's damage here (vsc_damage.h): bruise between the two control points around, torn at the nearer
    int j = (int)floor(x) < n - 2 ? (int)floor(x) : n - 2;
    double w = x - (double)j;
    double bruise = (1.0 - w) * damage[VSC_DAMAGE_SIZE * j] + w * damage[VSC_DAMAGE_SIZE * (j + 1)];
    int torn = damage[VSC_DAMAGE_SIZE * (w < 0.5 ? j : j + 1) + 1] > 0.0;
    float drawn[4];
    vsc_damage_colour(s >= band_from && s <= band_to ? marked : color, bruise, torn, drawn);
    mjvGeom* geom = scn->geoms + scn->ngeom;
    mjv_initGeom(geom, mjGEOM_CAPSULE, NULL, NULL, NULL, drawn);
    mjv_connector(geom, mjGEOM_CAPSULE, radius, from, to);
    geom->category = mjCAT_DYNAMIC;
    // labelled as this plugin instance in segmentation renders (MuJoCo gives decor geoms no label)
    geom->objtype = mjOBJ_PLUGIN;
    geom->objid = instance;
    geom->segid = scn->ngeom;
    // damaged wall (fully bruised or torn) marked for segmentation: MuJoCo reads dataid only for
    // meshes, height fields and the like, never for a capsule
    geom->dataid = torn || bruise >= 1.0 ? VSC_DRAWN_DAMAGED : -1;
    scn->ngeom++;
  }
}

void vsc_plugin_register_intestine(void) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = "viscera.intestine";
  plugin.capabilityflags |= mjPLUGIN_PASSIVE | mjPLUGIN_SENSOR;
  plugin.needstage = mjSTAGE_POS;  // sensors read stored wrenches and body poses
  plugin.nsensordata = intestine_nsensordata;
  plugin.nattribute = vsc_plugin_attribute_count;
  plugin.attributes = vsc_plugin_attributes;
  plugin.nstate = intestine_nstate;
  plugin.init = intestine_init;
  plugin.destroy = intestine_destroy;
  plugin.copy = intestine_copy;
  plugin.reset = intestine_reset;
  plugin.compute = intestine_compute;
  plugin.advance = intestine_advance;
  plugin.visualize = intestine_visualize;
  mjp_registerPlugin(&plugin);
}
