// Config reading and validation for viscera.intestine (see config.h).
#include "config.h"

#include <errno.h>
#include <stddef.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geoms.h"
#include "keys.h"
#include "viscera/vsc_layout.h"
#include "viscera/vsc_stability.h"

// keys.h's columns as vsc_plugin_key fields
#define FIELD(member) (long)offsetof(vsc_plugin_config, member)
#define NO_FIELD -1L
#define CORE NULL, NULL
#define VALUE(text) text, NULL
#define DERIVED(words) NULL, words
#define KEY_NAME(name, kind, field, minimum, maximum, unit, default_value, meaning) #name,
#define VSC_KEY_ROW(name, kind, field, minimum, maximum, unit, default_value, meaning) \
  {#name, kind, field, minimum, maximum, unit, default_value, meaning},
const char* const vsc_plugin_attributes[] = {VSC_PLUGIN_KEYS(KEY_NAME)};
const vsc_plugin_key vsc_plugin_keys[] = {VSC_PLUGIN_KEYS(VSC_KEY_ROW)};
const int vsc_plugin_attribute_count = VSC_KEY_COUNT;

// VSC_KEY_KIND_CHOICE values are written as int
_Static_assert(sizeof(vsc_integrator) == sizeof(int) && sizeof(vsc_shape_kind) == sizeof(int), "enum size");

#define MAX_NUMBERS 300000  // a polyline of 100000 vertices is plenty

// Each enumerated key's names, indexed by its enum (designated initializers: a
// name cannot drift from its value), NULL-terminated.
double vsc_plugin_default_stretch_stiffness(const vsc_rod_def* core, double length) {
  return core->stretch_stiffness * core->length / length;
}

double vsc_plugin_default_bend_stiffness(const vsc_rod_def* core, double length) {
  return core->bend_stiffness * core->length / length;
}

static const char* const shape_names[] = {[VSC_SHAPE_LINE] = "line", [VSC_SHAPE_POLYLINE] = "polyline",
                                          [VSC_SHAPE_SERPENTINE] = "serpentine",
                                          [VSC_SHAPE_CONTROL_POINTS] = "control_points", NULL};
static const char* const clamp_names[] = {"none", "start", "end", "both", NULL};  // bit 0: start, bit 1: end
static const char* const mass_matrix_names[] = {"consistent", "lumped", NULL};    // vsc_rod_def.lumped_mass

const char* const* vsc_plugin_allowed_values(const char* key) {
  if (strcmp(key, "integrator") == 0) return vsc_integrator_names;  // the core's table (vsc_integrate.h)
  if (strcmp(key, "shape") == 0) return shape_names;
  if (strcmp(key, "clamped") == 0) return clamp_names;
  if (strcmp(key, "mass_matrix") == 0) return mass_matrix_names;
  return NULL;
}

typedef struct reader {
  const mjModel* m;
  int instance;
  char* error;
  int error_size;
} reader;

static int fail(reader* r, const char* format, ...) {
  va_list args;
  va_start(args, format);
  int used = snprintf(r->error, (size_t)r->error_size, "viscera.intestine: ");
  vsnprintf(r->error + used, (size_t)(r->error_size - used), format, args);
  va_end(args);
  return -1;
}

// The raw attribute string, or NULL when the attribute is absent or empty.
static const char* raw(reader* r, const char* key) {
  const char* value = mj_getPluginConfig(r->m, r->instance, key);
  if (!value) return NULL;
  while (*value == ' ' || *value == '\t' || *value == '\n') ++value;
  return *value ? value : NULL;
}

// Parse whitespace-separated finite numbers into out (capacity `capacity`;
// out may be NULL to count only). Returns the count, -1 if a token is not a
// finite number, -2 if there are more than `capacity`.
static int parse_numbers(const char* text, double* out, int capacity) {
  int count = 0;
  const char* p = text;
  for (;;) {
    while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
    if (!*p) return count;
    char* end = NULL;
    errno = 0;
    double x = strtod(p, &end);
    if (end == p || errno == ERANGE || !isfinite(x)) return -1;
    if (*end && *end != ' ' && *end != '\t' && *end != '\n' && *end != '\r') return -1;
    if (count >= capacity) return -2;
    if (out) out[count] = x;
    ++count;
    p = end;
  }
}

// "a, b or c": the allowed names of an enumerated key, for messages and docs.
static void list_names(const char* const* names, const char* quote, char* out, size_t size) {
  out[0] = 0;
  for (int i = 0; names[i]; ++i) {
    size_t used = strlen(out);
    snprintf(out + used, size - used, "%s%s%s%s", i == 0 ? "" : (names[i + 1] ? ", " : " or "), quote, names[i], quote);
  }
}

// An integer, whitespace around it allowed.
static int parse_integer(const char* text, long* out) {
  char* end = NULL;
  errno = 0;
  *out = strtol(text, &end, 10);
  while (end && (*end == ' ' || *end == '\t' || *end == '\n')) ++end;
  return end != text && !*end && errno != ERANGE;
}

// Key `index` of the table (keys.h): the model's text, else the table's default
// text, read by the row's kind and bounds into the row's field. A core or
// derived default leaves the field as it is (the caller fills derived ones).
static int read_key(reader* r, vsc_plugin_config* c, int index) {
  const vsc_plugin_key* key = &vsc_plugin_keys[index];
  const char* given = raw(r, key->name);
  c->given[index] = given != NULL;
  const char* text = given ? given : key->value;
  if (!text || key->kind == VSC_KEY_KIND_CUSTOM) return 0;
  void* field = (char*)c + key->offset;
  double x;
  long k;
  switch (key->kind) {
    case VSC_KEY_KIND_REAL:
    case VSC_KEY_KIND_POSITIVE:
    case VSC_KEY_KIND_NONNEGATIVE:
      if (parse_numbers(text, &x, 1) != 1) return fail(r, "attribute '%s' = '%s' is not a finite number", key->name, text);
      if (key->kind == VSC_KEY_KIND_POSITIVE && !(x > 0.0))
        return fail(r, "attribute '%s' = '%s' must be positive (%s)", key->name, text, key->unit);
      if (key->kind == VSC_KEY_KIND_NONNEGATIVE && !(x >= 0.0))
        return fail(r, "attribute '%s' = '%s' must be >= 0 (%s)", key->name, text, key->unit);
      if (key->kind == VSC_KEY_KIND_REAL && !(x >= key->minimum && x <= key->maximum))
        return fail(r, "attribute '%s' = '%s' must be in [%g, %g] (%s)", key->name, text, key->minimum, key->maximum,
                    key->unit);
      *(double*)field = x;
      return 0;
    case VSC_KEY_KIND_COUNT:
      if (!parse_integer(text, &k)) return fail(r, "attribute '%s' = '%s' is not an integer", key->name, text);
      if (k < key->minimum) return fail(r, "attribute '%s' = '%s' must be at least %ld", key->name, text, (long)key->minimum);
      if (k > key->maximum) return fail(r, "attribute '%s' = '%s' must be at most %ld", key->name, text, (long)key->maximum);
      *(int*)field = (int)k;
      return 0;
    case VSC_KEY_KIND_TAPER: {  // one positive number, or two: at the start and at the end (0: not tapered)
      double pair[2] = {0.0, 0.0};
      int count = parse_numbers(text, pair, 2);
      if (count != 1 && count != 2)
        return fail(r, "attribute '%s' = '%s' must be one positive number, or two (at the start and at the end) (%s)",
                    key->name, text, key->unit);
      if (!(pair[0] > 0.0) || (count == 2 && !(pair[1] > 0.0)))
        return fail(r, "attribute '%s' = '%s' must be positive (%s)", key->name, text, key->unit);
      memcpy(field, pair, sizeof(pair));
      return 0;
    }
    case VSC_KEY_KIND_VECTOR: {
      double buffer[8];
      int count = (int)key->maximum;
      if (parse_numbers(text, buffer, 8) != count)
        return fail(r, "attribute '%s' = '%s' must be %d finite numbers (%s)", key->name, text, count, key->unit);
      memcpy(field, buffer, sizeof(double) * (size_t)count);
      return 0;
    }
    case VSC_KEY_KIND_CHOICE: {
      const char* const* names = vsc_plugin_allowed_values(key->name);
      for (int i = 0; names[i]; ++i)
        if (strcmp(text, names[i]) == 0) {
          *(int*)field = i;
          return 0;
        }
      char allowed[256];
      list_names(names, "", allowed, sizeof(allowed));
      return fail(r, "attribute '%s' = '%s' must be %s", key->name, text, allowed);
    }
    case VSC_KEY_KIND_CUSTOM:
      break;
  }
  return 0;
}

static int read_pinned(reader* r, vsc_plugin_config* c) {
  const char* text = raw(r, "pinned");
  c->pinned = NULL;
  c->rod.pinned = NULL;
  c->rod.pinned_count = 0;
  if (!text && !c->rod.clamp_start && !c->rod.clamp_end) return 0;
  int n = c->rod.control_count;
  c->pinned = (int*)malloc(sizeof(int) * (size_t)n);
  unsigned char* seen = (unsigned char*)calloc((size_t)n, 1);
  if (!c->pinned || !seen) {
    free(seen);
    return fail(r, "out of memory reading 'pinned'");
  }
  int status = 0;
  const char* p = text ? text : "";
  for (;;) {
    while (*p == ' ' || *p == '\t' || *p == '\n') ++p;
    if (!*p) break;
    char* end = NULL;
    errno = 0;
    long k = strtol(p, &end, 10);
    if (end == p || (*end && *end != ' ' && *end != '\t' && *end != '\n') || errno == ERANGE) {
      status = fail(r, "attribute 'pinned' = '%s' must be control point indices (integers)", text);
      break;
    }
    if (k < -n || k >= n) {
      status = fail(r, "attribute 'pinned' = '%s': index %ld is out of range [%d, %d]", text, k, -n, n - 1);
      break;
    }
    if (k < 0) k += n;  // from the end, as Python counts: -1 is the last (n chosen by 'tolerance', say)
    if (!seen[k]) c->pinned[c->rod.pinned_count++] = (int)k;  // duplicates are harmless
    seen[k] = 1;
    p = end;
  }
  // a clamped end pins its control point; with a bending rigidity the clamp term
  // holds the tangent, without one (the paper's springs) the neighbour is pinned too
  int clamped_ends[2] = {c->rod.clamp_start, c->rod.clamp_end};
  for (int end = 0; end < 2 && status == 0; ++end) {
    if (!clamped_ends[end]) continue;
    int held[2] = {end ? n - 1 : 0, end ? n - 2 : 1};
    for (int i = 0; i < (c->rod.bending_rigidity > 0.0 ? 1 : 2); ++i) {
      if (!seen[held[i]]) c->pinned[c->rod.pinned_count++] = held[i];
      seen[held[i]] = 1;
    }
  }
  if (c->rod.bending_rigidity == 0.0) c->rod.clamp_start = c->rod.clamp_end = 0;
  free(seen);
  c->rod.pinned = c->pinned;
  return status;
}

static int read_shape(reader* r, vsc_plugin_config* c) {
  double norm = sqrt(c->direction[0] * c->direction[0] + c->direction[1] * c->direction[1] +
                     c->direction[2] * c->direction[2]);
  if (!(norm > 0.0) || !isfinite(norm)) return fail(r, "attribute 'direction' = '%s' must be a non-zero vector", raw(r, "direction"));
  for (int i = 0; i < 3; ++i) c->direction[i] /= norm;
  if (c->shape == VSC_SHAPE_SERPENTINE) {
    if (!c->given[VSC_KEY_box]) return fail(r, "attribute 'box' is required by 'shape' = 'serpentine' (6 numbers, m)");
    for (int i = 0; i < 3; ++i)
      if (!(c->box[3 + i] > c->box[i])) return fail(r, "attribute 'box' = '%s' must give min then max corners", raw(r, "box"));
    double capacity = vsc_layout_serpentine_capacity(vsc_rod_def_radius_max(&c->rod), c->box);
    if (capacity < c->rod.length * (1.0 - 1e-9))
      return fail(r, "attribute 'box' = '%s' cannot hold a serpentine of length %g m and radius %g m "
                  "(it holds %g m)", raw(r, "box"), c->rod.length, c->rod.radius, capacity);
  }
  c->points = NULL;
  c->point_count = 0;
  const char* points = raw(r, "points");
  if (c->shape == VSC_SHAPE_POLYLINE || c->shape == VSC_SHAPE_CONTROL_POINTS) {
    if (!points) return fail(r, "attribute 'points' is required by 'shape' = '%s' (3k numbers, m)", raw(r, "shape"));
    int got = parse_numbers(points, NULL, MAX_NUMBERS);
    if (got < 0) return fail(r, "attribute 'points' must be finite numbers (at most %d)", MAX_NUMBERS);
    c->points = (double*)malloc(sizeof(double) * (size_t)(got > 0 ? got : 1));
    if (!c->points) return fail(r, "out of memory reading 'points'");
    parse_numbers(points, c->points, got);
    if (got % 3 != 0 || got < 6)
      return fail(r, "attribute 'points' holds %d numbers: a polyline needs at least 2 points of 3 numbers", got);
    c->point_count = got / 3;
    if (c->shape == VSC_SHAPE_CONTROL_POINTS && c->point_count != c->rod.control_count)
      return fail(r, "attribute 'points' holds %d points: shape 'control_points' needs one per control point (%d)",
                  c->point_count, c->rod.control_count);
  }
  return 0;
}

// Whitespace-separated names of model objects of type `type` into ids; returns
// the count, or -1 (with the message) on an unknown name or too many names.
static int read_names(reader* r, const char* key, mjtObj type, const char* what, int* ids, int capacity) {
  const char* text = raw(r, key);
  if (!text) return 0;
  int count = 0;
  const char* p = text;
  char name[256];
  for (;;) {
    while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
    if (!*p) return count;
    int length = 0;
    while (p[length] && p[length] != ' ' && p[length] != '\t' && p[length] != '\n' && p[length] != '\r') ++length;
    if (length >= (int)sizeof(name)) return fail(r, "attribute '%s' = '%s': a name is too long", key, text);
    if (count >= capacity) return fail(r, "attribute '%s' = '%s' names more than %d %ss", key, text, capacity, what);
    memcpy(name, p, (size_t)length);
    name[length] = 0;
    int id = mj_name2id(r->m, type, name);
    if (id < 0) return fail(r, "attribute '%s' = '%s': the model has no %s named '%s'", key, text, what, name);
    ids[count++] = id;
    p += length;
  }
}

static int read_graspers(reader* r, vsc_plugin_config* c) {
  vsc_grasper_config* g = &c->grasp;
  int joints = 0;
  g->count = read_names(r, "grasp_sites", mjOBJ_SITE, "site", g->site, VSC_MAX_GRASPERS);
  if (g->count < 0) return -1;
  joints = read_names(r, "grasp_joints", mjOBJ_JOINT, "joint", g->joint, VSC_MAX_GRASPERS);
  if (joints < 0) return -1;
  if (joints != g->count)
    return fail(r, "attributes 'grasp_sites' = '%s' and 'grasp_joints' = '%s' must name as many sites as joints",
                c->given[VSC_KEY_grasp_sites] ? raw(r, "grasp_sites") : "", c->given[VSC_KEY_grasp_joints] ? raw(r, "grasp_joints") : "");
  for (int i = 0; i < joints; ++i) {
    int type = r->m->jnt_type[g->joint[i]];
    if (type != mjJNT_HINGE && type != mjJNT_SLIDE)
      return fail(r, "attribute 'grasp_joints' = '%s': joint '%s' must be a hinge or a slide (the jaw opening)",
                  raw(r, "grasp_joints"), mj_id2name(r->m, mjOBJ_JOINT, g->joint[i]));
  }
  if (!c->given[VSC_KEY_grasp_reach]) g->reach = 2.0 * vsc_rod_def_radius_max(&c->rod);
  if (!c->given[VSC_KEY_grasp_lever]) g->lever = 0.0;  // derived each step (grasps.c)
  int hinges = 0;
  for (int i = 0; i < joints; ++i) hinges += r->m->jnt_type[g->joint[i]] == mjJNT_HINGE;
  if (c->given[VSC_KEY_grasp_lever] && hinges == 0)
    return fail(r, "attribute 'grasp_lever' = '%s': no jaw in 'grasp_joints' is a hinge (a slide jaw's pinch is "
                "its actuators' force)", raw(r, "grasp_lever"));
  // the actuators that squeeze each jaw: on its joint, with a force affine in control and
  // position (motor, position, general affine), so that the plugin can evaluate it where the
  // jaws meet the tissue
  for (int i = 0; i < joints; ++i) {
    g->actuator_count[i] = 0;
    for (int a = 0; a < r->m->nu; ++a) {
      if (r->m->actuator_trntype[a] != mjTRN_JOINT || r->m->actuator_trnid[2 * a] != g->joint[i]) continue;
      const char* name = mj_id2name(r->m, mjOBJ_ACTUATOR, a);
      if (r->m->actuator_gaintype[a] != mjGAIN_FIXED ||
          (r->m->actuator_biastype[a] != mjBIAS_NONE && r->m->actuator_biastype[a] != mjBIAS_AFFINE))
        return fail(r, "attribute 'grasp_joints' = '%s': actuator '%s' on jaw joint '%s' must have a fixed gain and "
                    "no or an affine bias (motor, position, general) for the jaws' pinch",
                    raw(r, "grasp_joints"), name ? name : "(unnamed)", mj_id2name(r->m, mjOBJ_JOINT, g->joint[i]));
      if (g->actuator_count[i] == VSC_MAX_JAW_ACTUATORS)
        return fail(r, "attribute 'grasp_joints' = '%s': jaw joint '%s' has more than %d actuators",
                    raw(r, "grasp_joints"), mj_id2name(r->m, mjOBJ_JOINT, g->joint[i]), VSC_MAX_JAW_ACTUATORS);
      g->actuator[i][g->actuator_count[i]++] = a;
    }
  }
  return 0;
}

// 1 if the model has a viscera.intestine instance other than this one.
static int other_intestines(const mjModel* m, int instance) {
  int slot = -1;
  mjp_getPlugin("viscera.intestine", &slot);
  for (int j = 0; j < m->nplugin; ++j)
    if (j != instance && m->plugin[j] == slot) return 1;
  return 0;
}

// 'tolerance': the resolution it chooses (vsc_resolution.h) for the keys not
// given, or the limit it cannot be met within. The choice sets the state's
// size, so it reads nothing a user may change after load (the model's gravity,
// a geom's contype, the timestep): standard gravity for the bending length, and
// contact wherever a geom of a colliding type or another intestine exists.
static int apply_tolerance(reader* r, vsc_plugin_config* c) {
  vsc_rod_def* d = &c->rod;
  const unsigned char* given = c->given;
  if (!given[VSC_KEY_tolerance]) return 0;
  const char* text = raw(r, "tolerance");
  if (!(c->tolerance < 1.0)) return fail(r, "attribute 'tolerance' = '%s' must be below 1 (a relative error)", text);
  vsc_resolution_request request = {
      .tolerance = c->tolerance, .length = d->length, .radius = vsc_rod_def_radius_min(d), .mass_per_length = d->mass / d->length,
      .bending_rigidity = d->bending_rigidity,
      // the whole-length axial stiffness EA (N): springs, the bend springs' share and the global term
      .axial_stiffness = (d->stretch_stiffness + 4.0 * d->bend_stiffness + d->global_stretch_stiffness) * d->length,
      .gravity = VSC_STANDARD_GRAVITY,
      .contacts = d->self_collision || vsc_mujoco_geoms_possible(r->m) || other_intestines(r->m, r->instance),
      .integrator = c->step.integrator};
  vsc_resolution* out = &c->resolution;
  vsc_resolution_limit limit = vsc_resolution_choose(&request, out);
  if (limit == VSC_RESOLUTION_BELOW_FLOOR)
    return fail(r, "attribute 'tolerance' = '%s' is below %.2g, the smallest relative error every validation "
                "case of a rod %s reaches (docs/config.md#tolerance)", text, out->floor,
                request.bending_rigidity > 0.0 ? "with a bending rigidity" : "of springs alone");
  if (limit == VSC_RESOLUTION_INVALID)
    return fail(r, "attribute 'tolerance' = '%s' cannot be applied to this intestine's length, radius, mass and "
                "stiffnesses", text);
  // past a count's limit the tolerance is refused, unless that count was given: it then wins
  if (!given[VSC_KEY_control_points] && out->needed_control_points > VSC_MAX_CONTROL_POINTS)
    return fail(r, "attribute 'tolerance' = '%s' needs %.0f control points for 'length' = %g m, more than the "
                "limit %d", text, out->needed_control_points, d->length, VSC_MAX_CONTROL_POINTS);
  if (!given[VSC_KEY_collision_spheres] && out->needed_spheres > VSC_MAX_COLLISION_SPHERES)
    return fail(r, "attribute 'tolerance' = '%s' needs %.0f collision spheres for 'length' = %g m and 'radius' = "
                "%g m, more than the limit %d", text, out->needed_spheres, d->length, d->radius,
                VSC_MAX_COLLISION_SPHERES);
  if (!given[VSC_KEY_control_points]) d->control_count = out->control_points;
  if (!given[VSC_KEY_samples_per_segment]) d->samples_per_segment = out->samples_per_segment;
  if (!given[VSC_KEY_collision_spheres]) d->collision_sphere_count = out->collision_spheres;
  return 0;
}

int vsc_plugin_config_check_timestep(const vsc_plugin_config* c, double dt, char* error, int error_size) {
  if (!c->given[VSC_KEY_tolerance] || !c->auto_substeps) return 0;
  double accurate = vsc_resolution_substeps(&c->resolution, dt);
  if (!(accurate > VSC_MAX_AUTO_SUBSTEPS)) return 0;
  snprintf(error, (size_t)error_size, "viscera.intestine: attribute 'tolerance' = '%g' needs %.0f substeps per %g s "
           "step with 'integrator' = '%s', more than the limit %d: lower the timestep or choose another integrator",
           c->tolerance, accurate, dt, vsc_integrator_names[c->step.integrator], VSC_MAX_AUTO_SUBSTEPS);
  return -1;
}

int vsc_plugin_config_substeps(const vsc_plugin_config* c, double elastic, double contact, double contact_damping_rate,
                               double dt) {
  if (!c->auto_substeps) return c->step.substeps;
  int stable = vsc_stable_substeps(c->step.integrator, elastic, contact, contact_damping_rate, dt);
  if (!c->given[VSC_KEY_tolerance]) return stable;
  double accurate = vsc_resolution_substeps(&c->resolution, dt);
  if (accurate > VSC_MAX_AUTO_SUBSTEPS) accurate = VSC_MAX_AUTO_SUBSTEPS;  // a timestep raised after load
  return accurate > stable ? (int)accurate : stable;
}

vsc_plugin_step_plan vsc_plugin_config_plan(const vsc_plugin_config* c, double elastic, double kicked,
                                            double contact, double contact_damping_rate, double dt) {
  int can_kick = vsc_integrator_length_implicit(c->step.integrator);
  vsc_plugin_step_plan plan = {c->step.substeps, can_kick, c->step.damping_limit, can_kick ? kicked : elastic};
  if (!c->auto_substeps) return plan;
  int whole = vsc_plugin_config_substeps(c, elastic, contact, contact_damping_rate, dt);
  int fewer = can_kick ? vsc_plugin_config_substeps(c, kicked, contact, contact_damping_rate, dt) : whole;
  plan.length_implicit = fewer < whole;
  plan.substeps = plan.length_implicit ? fewer : whole;
  plan.elastic = plan.length_implicit ? kicked : elastic;
  plan.damping_limit = vsc_stable_damping_limit(c->step.integrator, plan.elastic, contact, contact_damping_rate, dt,
                                                plan.substeps);
  return plan;
}

// 'exclude': other intestine instances of the model, by name.
static int read_excluded(reader* r, vsc_plugin_config* c) {
  c->exclude_count = read_names(r, "exclude", mjOBJ_PLUGIN, "plugin instance", c->exclude, VSC_MAX_EXCLUDED);
  if (c->exclude_count < 0) return -1;
  int slot = -1;
  mjp_getPlugin("viscera.intestine", &slot);
  for (int i = 0; i < c->exclude_count; ++i) {
    int id = c->exclude[i];
    if (r->m->plugin[id] != slot)
      return fail(r, "attribute 'exclude' = '%s': plugin instance '%s' is not a viscera.intestine", raw(r, "exclude"),
                  mj_id2name(r->m, mjOBJ_PLUGIN, id));
    if (id == r->instance)
      return fail(r, "attribute 'exclude' = '%s' names this instance itself (its self-collision is 'self_collision')",
                  raw(r, "exclude"));
  }
  return 0;
}

// Defaults computed from other keys (DERIVED in keys.h), then the checks that
// involve several keys.
static int derive(reader* r, vsc_plugin_config* c, const vsc_rod_def* core) {
  vsc_rod_def* d = &c->rod;
  const unsigned char* given = c->given;
  // mass: given, or from the density of a full tube of the contact radius
  if (given[VSC_KEY_mass] && given[VSC_KEY_density]) return fail(r, "attributes 'mass' and 'density' are both given: give one");
  if (!given[VSC_KEY_mass]) {
    double r0 = d->radius, r1 = vsc_rod_def_radius_at(d, 1.0);
    if (r1 == r0)
      d->mass = c->density * VSC_PI * d->radius * d->radius * d->length;
    else  // tapered: the mean of radius^2 over the length, the radius linear in it
      d->mass = c->density * VSC_PI * ((r0 * r0 + r0 * r1 + r1 * r1) / 3.0) * d->length;
    if (!isfinite(d->mass))
      return fail(r, "attribute 'density' = '%g' with 'radius' = '%g' and 'length' = '%g' gives a non-finite mass",
                  c->density, d->radius, d->length);
  }
  if (!given[VSC_KEY_radius_max]) c->skin.radius_max = d->radius;
  c->skin.taper_end = vsc_rod_def_radius_at(d, 1.0) / d->radius;  // the skin's radii scale with the tube's
  if (!given[VSC_KEY_radius_min]) c->skin.radius_min = c->skin.radius_max;
  if (c->skin.radius_min > c->skin.radius_max)
    return fail(r, "attribute 'radius_min' = '%g' exceeds 'radius_max' = '%g'", c->skin.radius_min, c->skin.radius_max);
  // material: a Young's modulus gives the stretch springs EA and the curvature
  // term EI, and turns the paper's bend springs and global length term off
  int tapered = vsc_rod_def_radius_at(d, 1.0) != d->radius;
  if (given[VSC_KEY_wall_thickness] && !given[VSC_KEY_young_modulus] && !tapered)
    return fail(r, "attribute 'wall_thickness' needs 'young_modulus' or a tapered 'radius'");
  if (given[VSC_KEY_wall_thickness] && !(c->wall_thickness <= vsc_rod_def_radius_max(d)))
    return fail(r, "attribute 'wall_thickness' = '%s' must be positive and at most 'radius' = %g (m)",
                raw(r, "wall_thickness"), vsc_rod_def_radius_max(d));
  d->wall_thickness = c->wall_thickness;  // a tapered tube's springs follow this section (0: solid)
  double stretch = 0.0, rigidity = 0.0;
  if (given[VSC_KEY_young_modulus])
    vsc_material_stiffnesses(c->young_modulus, d->radius, c->wall_thickness, d->length, &stretch, &rigidity);
  // the springs' defaults describe one material at any length (stiffness x
  // length constant); the global term regulates the end points' distance, so
  // scaling it up for short intestines would only make them unstable
  int young = given[VSC_KEY_young_modulus];
  if (!given[VSC_KEY_stretch_stiffness])
    d->stretch_stiffness = young ? stretch : vsc_plugin_default_stretch_stiffness(core, d->length);
  if (!given[VSC_KEY_bend_stiffness]) d->bend_stiffness = young ? 0.0 : vsc_plugin_default_bend_stiffness(core, d->length);
  if (!given[VSC_KEY_global_stretch_stiffness] && young) d->global_stretch_stiffness = 0.0;
  if (!given[VSC_KEY_bending_rigidity]) d->bending_rigidity = rigidity;
  if (d->stretch_stiffness == 0.0 && d->bend_stiffness == 0.0 && d->global_stretch_stiffness == 0.0)
    return fail(r, "attributes 'stretch_stiffness', 'bend_stiffness' and 'global_stretch_stiffness' are all 0: "
                "nothing holds the intestine together");
  if (!isfinite(d->stretch_stiffness) || !isfinite(d->bending_rigidity))
    return fail(r, "attribute 'young_modulus' = '%s' gives non-finite stiffnesses", raw(r, "young_modulus"));
  c->auto_substeps = !given[VSC_KEY_substeps];
  if (apply_tolerance(r, c)) return -1;
  if ((double)(d->control_count - 1) * d->samples_per_segment + 1.0 > VSC_MAX_SAMPLES)
    return fail(r, "attributes 'control_points' = %d and 'samples_per_segment' = %d give more than %d samples",
                d->control_count, d->samples_per_segment, VSC_MAX_SAMPLES);
  // sleeping holds points still, which the consistent matrix and the implicit solve cannot do in part
  int can_sleep = d->lumped_mass && c->step.integrator != VSC_INTEGRATOR_IMPLICIT;
  if (c->step.sleep.enabled && !can_sleep)
    return fail(r, "attribute 'sleep' = '1' needs 'mass_matrix' = 'lumped' and an explicit integrator, not "
                "'mass_matrix' = '%s' with 'integrator' = '%s'", d->lumped_mass ? "lumped" : "consistent",
                vsc_integrator_names[c->step.integrator]);
  if (!given[VSC_KEY_collision_spheres] && !given[VSC_KEY_tolerance]) {
    // spaced at most the smallest radius apart (a tapered tube's thin end)
    d->collision_sphere_count = vsc_default_collision_sphere_count(d->length, vsc_rod_def_radius_min(d));
    if (d->collision_sphere_count < 2)  // the default overflowed
      return fail(r, "attributes 'length' = '%g' and 'radius' = '%g' need more than %d collision spheres: "
                  "give 'collision_spheres'", d->length, vsc_rod_def_radius_min(d), VSC_MAX_COLLISION_SPHERES);
  }
  if (d->mesentery_stiffness > 0.0 && !given[VSC_KEY_mesentery_root])
    return fail(r, "attribute 'mesentery_root' is required by 'mesentery_stiffness' > 0 (6 numbers, m)");
  if (d->mesentery_stiffness == 0.0) d->mesentery_points = 0;
  if (!given[VSC_KEY_friction]) c->friction = -1.0;  // each geom's own
  for (int k = 0; k < 4; ++k)
    if (!(c->rgba[k] >= 0.0 && c->rgba[k] <= 1.0))
      return fail(r, "attribute 'rgba' = '%s' must be 4 numbers in [0, 1] (red, green, blue, opacity)", raw(r, "rgba"));
  if (given[VSC_KEY_marked_band] &&
      !(c->marked_band[0] >= 0.0 && c->marked_band[0] < c->marked_band[1] && c->marked_band[1] <= d->length))
    return fail(r, "attribute 'marked_band' = '%s' must be from, to with 0 <= from < to <= 'length' = %g (m)",
                raw(r, "marked_band"), d->length);
  d->clamp_start = c->clamped & 1;
  d->clamp_end = (c->clamped >> 1) & 1;
  // refuse absurd resolutions here, with the keys that set them, rather than
  // let the allocation crash or the OOM killer end the process
  double bytes = vsc_rod_memory_bytes(d);
  if (bytes > VSC_MAX_ROD_BYTES)
    return fail(r, "%s'control_points' = %d, 'samples_per_segment' = %d and 'collision_spheres' = %d "
                "would need %.1f GB, more than the %.1f GB one intestine may take",
                given[VSC_KEY_tolerance] ? "attribute 'tolerance' chooses " : "attributes ", d->control_count,
                d->samples_per_segment, d->collision_sphere_count, bytes / 1e9, VSC_MAX_ROD_BYTES / 1e9);
  return 0;
}

// The config the core's defaults give, before any key is read.
static void core_defaults(vsc_plugin_config* c) {
  memset(c, 0, sizeof(*c));
  c->rod = vsc_default_rod_def();
  c->step = vsc_default_step_options();
  c->step.sleep = vsc_default_sleep_options();
  c->skin = vsc_default_skin_def();
  c->damage = vsc_default_damage_limits();
}

int vsc_plugin_config_read(const mjModel* m, int instance, vsc_plugin_config* c, char* error, int error_size) {
  reader r = {m, instance, error, error_size};
  core_defaults(c);
  const vsc_rod_def core = c->rod;
  for (int i = 0; i < VSC_KEY_COUNT; ++i)
    if (read_key(&r, c, i)) return -1;
  if (derive(&r, c, &core)) return -1;
  if (read_pinned(&r, c) || read_shape(&r, c) || read_graspers(&r, c) || read_excluded(&r, c)) {
    vsc_plugin_config_free(c);
    return -1;
  }
  return 0;
}

int vsc_plugin_key_field(int i, const char* field, char* out, int size) {
  if (i < 0 || i >= VSC_KEY_COUNT || !field || !out || size < 1) return -1;
  const vsc_plugin_key* key = &vsc_plugin_keys[i];
  static const char* const kinds[] = {"real", "positive", "nonnegative", "count", "vector", "choice", "custom", "taper"};
  const char* const* names = vsc_plugin_allowed_values(key->name);
  char text[320] = "";
  if (strcmp(field, "unit") == 0) return snprintf(out, (size_t)size, "%s", key->unit);
  if (strcmp(field, "meaning") == 0) return snprintf(out, (size_t)size, "%s", key->meaning);
  if (strcmp(field, "kind") == 0) return snprintf(out, (size_t)size, "%s", kinds[key->kind]);
  if (strcmp(field, "values") == 0) {
    switch (key->kind) {
      case VSC_KEY_KIND_REAL:
        if (isfinite(key->minimum) || isfinite(key->maximum))
          snprintf(text, sizeof(text), "%g to %g", key->minimum, key->maximum);
        else
          snprintf(text, sizeof(text), "any");
        break;
      case VSC_KEY_KIND_POSITIVE: snprintf(text, sizeof(text), "> 0"); break;
      case VSC_KEY_KIND_NONNEGATIVE: snprintf(text, sizeof(text), ">= 0"); break;
      case VSC_KEY_KIND_COUNT: snprintf(text, sizeof(text), "%ld to %ld", (long)key->minimum, (long)key->maximum); break;
      case VSC_KEY_KIND_VECTOR: snprintf(text, sizeof(text), "%d numbers", (int)key->maximum); break;
      case VSC_KEY_KIND_CHOICE: list_names(names, "`", text, sizeof(text)); break;
      case VSC_KEY_KIND_CUSTOM: snprintf(text, sizeof(text), "a list"); break;
      case VSC_KEY_KIND_TAPER: snprintf(text, sizeof(text), "> 0, or two > 0"); break;
    }
    return snprintf(out, (size_t)size, "%s", text);
  }
  if (strcmp(field, "default") != 0) return -1;
  if (key->derived) return snprintf(out, (size_t)size, "%s", key->derived);
  if (key->value) return snprintf(out, (size_t)size, key->kind == VSC_KEY_KIND_CHOICE ? "`%s`" : "%s", key->value);
  if (key->offset < 0) return snprintf(out, (size_t)size, "-");
  vsc_plugin_config c;  // a core default: print the core's value
  core_defaults(&c);
  const void* value = (const char*)&c + key->offset;
  switch (key->kind) {
    case VSC_KEY_KIND_COUNT: return snprintf(out, (size_t)size, "%d", *(const int*)value);
    case VSC_KEY_KIND_CHOICE: return snprintf(out, (size_t)size, "`%s`", names[*(const int*)value]);
    default: return snprintf(out, (size_t)size, "%g", *(const double*)value);
  }
}

int vsc_plugin_config_clamp(vsc_plugin_config* c, const double* q, char* error, int error_size) {
  int n = c->rod.control_count, clamped[2] = {c->rod.clamp_start, c->rod.clamp_end};
  double* direction[2] = {c->rod.clamp_direction_start, c->rod.clamp_direction_end};
  for (int end = 0; end < 2; ++end) {
    if (!clamped[end]) continue;
    vsc_basis tangent = vsc_spline_basis_derivative(n, end ? 1.0 : 0.0);  // the spline's end tangent
    vsc_basis_point(&tangent, q, direction[end]);
    double norm = 0.0;
    for (int i = 0; i < 3; ++i) norm += direction[end][i] * direction[end][i];
    if (!(norm > 1e-24)) {
      snprintf(error, (size_t)error_size, "viscera.intestine: attribute 'clamped' = '%s': the initial shape has no "
               "tangent at that end (the spline's end tangent, from its first three control points, is zero)", end ? "end" : "start");
      return -1;
    }
  }
  return 0;
}

void vsc_plugin_config_free(vsc_plugin_config* c) {
  free(c->pinned);
  free(c->points);
  c->pinned = NULL;
  c->points = NULL;
  c->rod.pinned = NULL;
}

int vsc_plugin_config_layout(const vsc_plugin_config* c, double* q, char* error, int error_size) {
  int n = c->rod.control_count;
  vsc_status status = VSC_OK;
  const char* what = "";
  switch (c->shape) {
    case VSC_SHAPE_LINE:
      status = vsc_layout_line(n, c->rod.length, c->start, c->direction, q);
      what = "line";
      break;
    case VSC_SHAPE_POLYLINE:
      status = vsc_layout_polyline(n, c->rod.length, c->points, c->point_count, q);
      what = "polyline 'points' (shorter than 'length'?)";
      break;
    case VSC_SHAPE_SERPENTINE:
      status = vsc_layout_serpentine(n, c->rod.length, vsc_rod_def_radius_max(&c->rod), c->box, q);
      what = "serpentine 'box'";
      break;
    case VSC_SHAPE_CONTROL_POINTS:
      memcpy(q, c->points, sizeof(double) * 3 * (size_t)n);
      break;
  }
  if (status == VSC_OK) return 0;
  snprintf(error, (size_t)error_size, "viscera.intestine: cannot lay out the %s: %s", what, vsc_status_string(status));
  return -1;
}
