// Config reading and validation for viscera.intestine (see config.h).
#include "config.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "keys.h"
#include "viscera/vsc_layout.h"

#define KEY_NAME(name, unit, default_value, meaning) #name,
#define KEY_DOC(name, unit, default_value, meaning) {#name, unit, default_value, meaning},
const char* const vsc_plugin_attributes[] = {VSC_PLUGIN_KEYS(KEY_NAME)};
const vsc_plugin_key_doc vsc_plugin_key_docs[] = {VSC_PLUGIN_KEYS(KEY_DOC)};
const int vsc_plugin_attribute_count = (int)(sizeof(vsc_plugin_attributes) / sizeof(vsc_plugin_attributes[0]));

#define MAX_NUMBERS 300000  // a polyline of 100000 vertices is plenty

// Each enumerated key's names, indexed by its enum (designated initializers: a
// name cannot drift from its value), NULL-terminated.
static const char* const integrator_names[VSC_INTEGRATOR_COUNT + 1] = {
    [VSC_INTEGRATOR_RK4] = "rk4", [VSC_INTEGRATOR_SYMPLECTIC_EULER] = "symplectic_euler",
    [VSC_INTEGRATOR_IMPLICIT] = "implicit", [VSC_INTEGRATOR_LEAPFROG] = "leapfrog", NULL};
static const char* const shape_names[] = {[VSC_SHAPE_LINE] = "line", [VSC_SHAPE_POLYLINE] = "polyline",
                                          [VSC_SHAPE_SERPENTINE] = "serpentine",
                                          [VSC_SHAPE_CONTROL_POINTS] = "control_points", NULL};
static const char* const clamp_names[] = {"none", "start", "end", "both", NULL};  // bit 0: start, bit 1: end
static const char* const mass_matrix_names[] = {"consistent", "lumped", NULL};    // vsc_rod_def.lumped_mass

const char* const* vsc_plugin_allowed_values(const char* key) {
  if (strcmp(key, "integrator") == 0) return integrator_names;
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

// An enumerated key's value as its index in vsc_plugin_allowed_values (the
// fallback when absent); on an unknown name the message lists the allowed ones.
static int read_choice(reader* r, const char* key, int fallback, int* out) {
  const char* text = raw(r, key);
  const char* const* names = vsc_plugin_allowed_values(key);
  *out = fallback;
  if (!text) return 0;
  for (int i = 0; names[i]; ++i)
    if (strcmp(text, names[i]) == 0) {
      *out = i;
      return 0;
    }
  char allowed[256] = "";
  for (int i = 0; names[i]; ++i) {
    size_t used = strlen(allowed);
    snprintf(allowed + used, sizeof(allowed) - used, "%s%s", i == 0 ? "" : (names[i + 1] ? ", " : " or "), names[i]);
  }
  return fail(r, "attribute '%s' = '%s' must be %s", key, text, allowed);
}

// A single finite number; `*present` says whether the key was given.
static int read_number(reader* r, const char* key, double fallback, double* out, int* present) {
  const char* text = raw(r, key);
  if (present) *present = text != NULL;
  if (!text) {
    *out = fallback;
    return 0;
  }
  double x;
  if (parse_numbers(text, &x, 1) != 1) return fail(r, "attribute '%s' = '%s' is not a finite number", key, text);
  *out = x;
  return 0;
}

// The key's unit, from the table of keys (keys.h): refusals name it.
static const char* unit_of(const char* key) {
  for (int i = 0; i < vsc_plugin_attribute_count; ++i)
    if (strcmp(vsc_plugin_key_docs[i].name, key) == 0) return vsc_plugin_key_docs[i].unit;
  return "?";
}

static int read_positive(reader* r, const char* key, double fallback, double* out) {
  const char* unit = unit_of(key);
  if (read_number(r, key, fallback, out, NULL)) return -1;
  if (!(*out > 0.0)) return fail(r, "attribute '%s' = '%s' must be positive (%s)", key, raw(r, key), unit);
  return 0;
}

static int read_nonnegative(reader* r, const char* key, double fallback, double* out) {
  const char* unit = unit_of(key);
  if (read_number(r, key, fallback, out, NULL)) return -1;
  if (!(*out >= 0.0)) return fail(r, "attribute '%s' = '%s' must be >= 0 (%s)", key, raw(r, key), unit);
  return 0;
}

static int read_count(reader* r, const char* key, int fallback, int minimum, int maximum, int* out) {
  const char* text = raw(r, key);
  if (!text) {
    *out = fallback;
    return 0;
  }
  char* end = NULL;
  errno = 0;
  long x = strtol(text, &end, 10);
  while (end && (*end == ' ' || *end == '\t' || *end == '\n')) ++end;
  if (end == text || *end || errno == ERANGE) return fail(r, "attribute '%s' = '%s' is not an integer", key, text);
  if (x < minimum) return fail(r, "attribute '%s' = '%s' must be at least %d", key, text, minimum);
  if (x > maximum) return fail(r, "attribute '%s' = '%s' must be at most %d", key, text, maximum);
  *out = (int)x;
  return 0;
}

// Exactly `count` numbers (for start, direction, box).
static int read_vector(reader* r, const char* key, int count, const double* fallback, double* out) {
  const char* text = raw(r, key);
  if (!text) {
    memcpy(out, fallback, sizeof(double) * (size_t)count);
    return 0;
  }
  double buffer[8];
  int got = parse_numbers(text, buffer, 8);
  if (got != count) return fail(r, "attribute '%s' = '%s' must be %d finite numbers", key, text, count);
  memcpy(out, buffer, sizeof(double) * (size_t)count);
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
    if (k < 0 || k >= n) {
      status = fail(r, "attribute 'pinned' = '%s': index %ld is out of range [0, %d]", text, k, n - 1);
      break;
    }
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
  static const double default_start[3] = {0.0, 0.0, 0.0}, default_direction[3] = {1.0, 0.0, 0.0};
  static const double no_box[6] = {0, 0, 0, 0, 0, 0};
  int shape;
  if (read_choice(r, "shape", VSC_SHAPE_LINE, &shape)) return -1;
  c->shape = (vsc_shape_kind)shape;
  if (read_vector(r, "start", 3, default_start, c->start)) return -1;
  if (read_vector(r, "direction", 3, default_direction, c->direction)) return -1;
  double norm = sqrt(c->direction[0] * c->direction[0] + c->direction[1] * c->direction[1] +
                     c->direction[2] * c->direction[2]);
  if (!(norm > 0.0) || !isfinite(norm)) return fail(r, "attribute 'direction' = '%s' must be a non-zero vector", raw(r, "direction"));
  for (int i = 0; i < 3; ++i) c->direction[i] /= norm;
  if (read_vector(r, "box", 6, no_box, c->box)) return -1;
  if (c->shape == VSC_SHAPE_SERPENTINE) {
    if (!raw(r, "box")) return fail(r, "attribute 'box' is required by 'shape' = 'serpentine' (6 numbers, m)");
    for (int i = 0; i < 3; ++i)
      if (!(c->box[3 + i] > c->box[i])) return fail(r, "attribute 'box' = '%s' must give min then max corners", raw(r, "box"));
    double capacity = vsc_layout_serpentine_capacity(c->rod.radius, c->box);
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
                raw(r, "grasp_sites") ? raw(r, "grasp_sites") : "", raw(r, "grasp_joints") ? raw(r, "grasp_joints") : "");
  for (int i = 0; i < joints; ++i) {
    int type = r->m->jnt_type[g->joint[i]];
    if (type != mjJNT_HINGE && type != mjJNT_SLIDE)
      return fail(r, "attribute 'grasp_joints' = '%s': joint '%s' must be a hinge or a slide (the jaw opening)",
                  raw(r, "grasp_joints"), mj_id2name(r->m, mjOBJ_JOINT, g->joint[i]));
  }
  return read_number(r, "grasp_closed_below", 0.1, &g->closed_below, NULL) ||
         read_positive(r, "grasp_reach", 2.0 * c->rod.radius, &g->reach) ||
         read_nonnegative(r, "grasp_stiffness", 1000.0, &g->stiffness) ||
         read_nonnegative(r, "grasp_damping", 2.0, &g->damping) ||
         read_positive(r, "grasp_slip_force", 5.0, &g->slip_force);
}

int vsc_plugin_config_read(const mjModel* m, int instance, vsc_plugin_config* c, char* error, int error_size) {
  reader r = {m, instance, error, error_size};
  memset(c, 0, sizeof(*c));
  c->rod = vsc_default_rod_def();
  c->step = vsc_default_step_options();
  vsc_rod_def* d = &c->rod;
  int failed =
      read_positive(&r, "length", d->length, &d->length) ||
      read_count(&r, "control_points", d->control_count, 4, VSC_MAX_CONTROL_POINTS, &d->control_count) ||
      read_positive(&r, "radius", d->radius, &d->radius) ||
      read_count(&r, "samples_per_segment", d->samples_per_segment, 1, 64, &d->samples_per_segment);
  if (failed) return -1;
  if ((double)(d->control_count - 1) * d->samples_per_segment + 1.0 > VSC_MAX_SAMPLES)
    return fail(&r, "attributes 'control_points' = %d and 'samples_per_segment' = %d give more than %d samples",
                d->control_count, d->samples_per_segment, VSC_MAX_SAMPLES);
  // mass: given, or from the density of a full tube of the contact radius
  double density = 1000.0;
  int mass_given = 0, density_given = 0;
  if (read_number(&r, "mass", 0.0, &d->mass, &mass_given) || read_number(&r, "density", 1000.0, &density, &density_given))
    return -1;
  if (mass_given && density_given) return fail(&r, "attributes 'mass' and 'density' are both given: give one");
  if (mass_given && !(d->mass > 0.0)) return fail(&r, "attribute 'mass' = '%s' must be positive (kg)", raw(&r, "mass"));
  if (!mass_given) {
    if (!(density > 0.0)) return fail(&r, "attribute 'density' = '%s' must be positive (kg/m^3)", raw(&r, "density"));
    d->mass = density * VSC_PI * d->radius * d->radius * d->length;
    if (!isfinite(d->mass))
      return fail(&r, "attribute 'density' = '%g' with 'radius' = '%g' and 'length' = '%g' gives a non-finite mass",
                  density, d->radius, d->length);
  }
  // material: a Young's modulus gives the axial EA and bending EI of a tube of
  // the contact radius (a wall of the given thickness, else a solid section);
  // then the stretch springs carry EA, the curvature term EI, and the paper's
  // bend springs and global length term default to off
  double young = 0.0, wall = 0.0;
  int young_given = 0, wall_given = 0;
  if (read_number(&r, "young_modulus", 0.0, &young, &young_given) ||
      read_number(&r, "wall_thickness", 0.0, &wall, &wall_given))
    return -1;
  if (young_given && !(young > 0.0)) return fail(&r, "attribute 'young_modulus' = '%s' must be positive (Pa)", raw(&r, "young_modulus"));
  if (wall_given && !(wall > 0.0 && wall <= d->radius))
    return fail(&r, "attribute 'wall_thickness' = '%s' must be positive and at most 'radius' = %g (m)", raw(&r, "wall_thickness"), d->radius);
  if (wall_given && !young_given) return fail(&r, "attribute 'wall_thickness' needs 'young_modulus'");
  double area, second_moment;
  vsc_tube_section(d->radius, wall_given ? wall : 0.0, &area, &second_moment);
  double stretch_default = young_given ? young * area / d->length : d->stretch_stiffness * 4.0 / d->length;
  double bend_default = young_given ? 0.0 : d->bend_stiffness * 4.0 / d->length;
  double global_default = young_given ? 0.0 : d->global_stretch_stiffness;
  double rigidity_default = young_given ? young * second_moment : 0.0;
  failed =
      read_positive(&r, "radius_max", d->radius, &c->radius_max) ||
      read_positive(&r, "radius_min", c->radius_max, &c->radius_min) ||
      // the springs' defaults describe one material at any length (stiffness x
      // length constant); the global term is a length regulator acting on the
      // end points, so scaling it up for short intestines would only make them
      // unstable: its default does not scale
      read_nonnegative(&r, "stretch_stiffness", stretch_default, &d->stretch_stiffness) ||
      read_nonnegative(&r, "bend_stiffness", bend_default, &d->bend_stiffness) ||
      read_nonnegative(&r, "global_stretch_stiffness", global_default, &d->global_stretch_stiffness) ||
      read_nonnegative(&r, "bending_rigidity", rigidity_default, &d->bending_rigidity) ||
      read_nonnegative(&r, "damping", d->damping, &d->damping) ||
      read_positive(&r, "contact_stiffness", d->contact_stiffness, &d->contact_stiffness) ||
      read_nonnegative(&r, "contact_damping", d->contact_damping, &d->contact_damping) ||
      read_count(&r, "substeps", c->step.substeps, 1, 10000, &c->step.substeps) ||  // absent: chosen per step
      read_count(&r, "divergence_retries", c->step.retries, 0, 10, &c->step.retries) ||
      read_count(&r, "collision_spheres", vsc_default_collision_sphere_count(d->length, d->radius), 2,
                 VSC_MAX_COLLISION_SPHERES, &d->collision_sphere_count);
  if (failed) return -1;
  c->auto_substeps = raw(&r, "substeps") == NULL;
  if (d->collision_sphere_count < 2)  // the default overflowed
    return fail(&r, "attributes 'length' = '%g' and 'radius' = '%g' need more than %d collision spheres: "
                "give 'collision_spheres'", d->length, d->radius, VSC_MAX_COLLISION_SPHERES);
  int self_collision = 1;
  failed = read_count(&r, "self_collision", 1, 0, 1, &self_collision) ||
           read_nonnegative(&r, "self_friction", d->self_friction, &d->self_friction);
  if (failed) return -1;
  d->self_collision = self_collision;
  // mesentery: tension-only tethers from the axis to a root line (off by default)
  static const double no_root[6] = {0, 0, 0, 0, 0, 0};
  if (read_nonnegative(&r, "mesentery_stiffness", 0.0, &d->mesentery_stiffness) ||
      read_nonnegative(&r, "mesentery_length", 0.15, &d->mesentery_length) ||
      read_count(&r, "mesentery_points", 32, 1, 100000, &d->mesentery_points) ||
      read_vector(&r, "mesentery_root", 6, no_root, d->mesentery_root))
    return -1;
  if (d->mesentery_stiffness > 0.0 && !raw(&r, "mesentery_root"))
    return fail(&r, "attribute 'mesentery_root' is required by 'mesentery_stiffness' > 0 (6 numbers, m)");
  if (d->mesentery_stiffness == 0.0) d->mesentery_points = 0;
  if (read_count(&r, "skin_rings_per_segment", 4, 1, 64, &c->skin_rings_per_segment) ||
      read_count(&r, "skin_ring_points", 16, 3, 256, &c->skin_ring_points))
    return -1;
  c->friction = -1.0;
  if (raw(&r, "friction") && read_nonnegative(&r, "friction", 0.0, &c->friction)) return -1;
  if (c->radius_min > c->radius_max)
    return fail(&r, "attribute 'radius_min' = '%g' exceeds 'radius_max' = '%g'", c->radius_min, c->radius_max);
  if (d->stretch_stiffness == 0.0 && d->bend_stiffness == 0.0 && d->global_stretch_stiffness == 0.0)
    return fail(&r, "attributes 'stretch_stiffness', 'bend_stiffness' and 'global_stretch_stiffness' are all 0: "
                "nothing holds the intestine together");
  if (!isfinite(d->stretch_stiffness) || !isfinite(d->bending_rigidity))
    return fail(&r, "attribute 'young_modulus' = '%s' gives non-finite stiffnesses", raw(&r, "young_modulus"));
  int integrator, lumped, clamp;
  if (read_choice(&r, "integrator", VSC_INTEGRATOR_LEAPFROG, &integrator) ||
      read_choice(&r, "mass_matrix", 1, &lumped) ||  // lumped unless told otherwise
      read_choice(&r, "clamped", 0, &clamp))
    return -1;
  c->step.integrator = (vsc_integrator)integrator;
  d->lumped_mass = lumped;
  d->clamp_start = clamp & 1;
  d->clamp_end = (clamp >> 1) & 1;
  // refuse absurd resolutions here, with the keys that set them, rather than
  // let the allocation crash or the OOM killer end the process
  double bytes = vsc_rod_memory_bytes(d);
  if (bytes > VSC_MAX_ROD_BYTES)
    return fail(&r, "attributes 'control_points' = %d, 'samples_per_segment' = %d and 'collision_spheres' = %d "
                "would need %.1f GB, more than the %.1f GB one intestine may take", d->control_count,
                d->samples_per_segment, d->collision_sphere_count, bytes / 1e9, VSC_MAX_ROD_BYTES / 1e9);
  if (read_pinned(&r, c) || read_shape(&r, c) || read_graspers(&r, c)) {
    vsc_plugin_config_free(c);
    return -1;
  }
  return 0;
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
      status = vsc_layout_serpentine(n, c->rod.length, c->rod.radius, c->box, q);
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
