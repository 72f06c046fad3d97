// A few core functions exported for the Python package (ctypes), so Python
// evaluates the axis with the very basis the plugin uses and reads the config
// attribute list from its single definition.
#include <math.h>
#include <stdlib.h>

#include "caches.h"
#include "config.h"
#include "grasps.h"
#include "intestine.h"
#include "state_layout.h"
#include "viscera/viscera.h"  // the core's whole public API: a check that the umbrella compiles

#define VSC_EXPORT __attribute__((visibility("default")))

/// How many times the caches' mutex was taken in this process (caches.h): for
/// the test that a step takes no lock.
VSC_EXPORT long viscera_cache_locks_taken(void) { return vsc_caches_locks_taken(); }

/// Number of config attributes of viscera.intestine.
VSC_EXPORT int viscera_attribute_count(void) { return vsc_plugin_attribute_count; }

/// Name of config attribute i (static storage), NULL if out of range.
VSC_EXPORT const char* viscera_attribute_name(int i) {
  return i >= 0 && i < vsc_plugin_attribute_count ? vsc_plugin_attributes[i] : 0;
}

/// Documentation of config attribute i (keys.h): `field` is "unit",
/// "default", "meaning" (Markdown), "kind" or "values"; written into out (size
/// bytes). Returns the text's full length, or -1 for an unknown index or field.
VSC_EXPORT int viscera_attribute_field(int i, const char* field, char* out, int size) {
  return vsc_plugin_key_field(i, field, out, size);
}

/// Allowed value i of an enumerated config key (integrator, shape, clamped,
/// mass_matrix), in enum order (static storage); NULL past the last one or
/// for a key that is not enumerated.
VSC_EXPORT const char* viscera_allowed_value(const char* key, int i) {
  const char* const* names = key ? vsc_plugin_allowed_values(key) : 0;
  if (!names || i < 0) return 0;
  for (int k = 0; k < i; ++k)
    if (!names[k]) return 0;
  return names[i];
}

/// Basis windows of `count` abscissae s (in [0, 1]) of an n-point spline:
/// first[i] and weight[4 i .. 4 i + 3], as in vsc_spline_basis (a NaN s reads
/// as 0). Returns 0, or -1 if n < 4.
VSC_EXPORT int viscera_spline_basis(int n, int count, const double* s, int* first, double* weight) {
  if (n < 4) return -1;
  for (int i = 0; i < count; ++i) {
    vsc_basis b = vsc_spline_basis(n, s[i]);
    first[i] = b.first;
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) weight[4 * i + j] = b.weight[j];
  }
  return 0;
}

/// Points of an n-point spline (control points q, m, n x 3, row-major) at
/// `count` abscissae s (in [0, 1]), into out (m, count x 3): each the four
/// basis terms summed in order, ((w0 q0 + w1 q1) + w2 q2) + w3 q3, the same
/// bits as that sum in numpy. Returns 0, or -1 if n < 4.
// Coordinate c of the spline point at basis window b: the four terms summed in order.
static double spline_coordinate(const double* q, vsc_basis b, int c) {
  const double* p = q + 3 * b.first;
  double sum = b.weight[0] * p[c] + b.weight[1] * p[3 + c];
  sum += b.weight[2] * p[6 + c];
  return sum + b.weight[3] * p[9 + c];
}

VSC_EXPORT int viscera_spline_points(int n, const double* q, int count, const double* s, double* out) {
  if (n < 4) return -1;
  for (int i = 0; i < count; ++i) {
    vsc_basis b = vsc_spline_basis(n, s[i]);
    for (int c = 0; c < 3; ++c) out[3 * i + c] = spline_coordinate(q, b, c);
  }
  return 0;
}

/// Which cells of a grid in the xy plane an n-point spline's tube lies over, as the tasks
/// measure a target's coverage (viscera.tasks.base.grid_under_tube, the same booleans): the
/// axis at `count` abscissae s (as viscera_spline_points); the samples outside the grid's
/// bounds grown by `radius` (m) skipped; a cell (xs[i], ys[j]) (m) covered when a sample's
/// dx * dx + dy * dy (m^2, dx = cell - sample, each product rounded, no fused multiply-add)
/// is at most `radius_squared`. out[j * nx + i] = 1.0 or 0.0 (meshgrid's order: rows of y).
/// Returns the covered count, or -1 if n < 4 or the grid is empty.
VSC_EXPORT int viscera_grid_under_axis(int n, const double* q, int count, const double* s, int nx, const double* xs,
                                       int ny, const double* ys, double radius, double radius_squared, double* out) {
  if (n < 4 || nx < 1 || ny < 1) return -1;
  double low_x = xs[0], high_x = xs[0], low_y = ys[0], high_y = ys[0];
  for (int i = 1; i < nx; ++i) low_x = fmin(low_x, xs[i]), high_x = fmax(high_x, xs[i]);
  for (int j = 1; j < ny; ++j) low_y = fmin(low_y, ys[j]), high_y = fmax(high_y, ys[j]);
  low_x -= radius, high_x += radius, low_y -= radius, high_y += radius;
  for (int k = 0; k < nx * ny; ++k) out[k] = 0.0;
  int covered = 0;
  for (int k = 0; k < count; ++k) {
    vsc_basis b = vsc_spline_basis(n, s[k]);
    double x = spline_coordinate(q, b, 0), y = spline_coordinate(q, b, 1);
    if (!(x >= low_x && x <= high_x && y >= low_y && y <= high_y)) continue;
    for (int j = 0; j < ny; ++j) {
      double dy = ys[j] - y, dy2 = dy * dy;
      if (dy2 > radius_squared) continue;  // dx * dx >= 0 cannot bring the sum back down
      for (int i = 0; i < nx; ++i) {
        double dx = xs[i] - x;
        if (out[j * nx + i] == 0.0 && dx * dx + dy2 <= radius_squared) {
          out[j * nx + i] = 1.0;
          ++covered;
        }
      }
    }
  }
  return covered;
}

// The config of plugin instance `instance` if it is a viscera.intestine
// (returns 0; the caller frees it), else -1.
static int read_intestine(const mjModel* m, int instance, vsc_plugin_config* config) {
  char error[256];
  int slot = -1;
  if (instance < 0 || instance >= m->nplugin) return -1;
  if (!mjp_getPlugin("viscera.intestine", &slot) || m->plugin[instance] != slot) return -1;
  return vsc_plugin_config_read(m, instance, config, error, (int)sizeof(error)) ? -1 : 0;
}

/// Resolved mechanics of intestine `instance` of model `m`, defaults applied,
/// as the plugin itself reads them: out = {length (m), radius (m), mass (kg),
/// control points, collision spheres, samples per segment, sleep (1 on, 0 off),
/// sleep_time (s), radius at the end (m; the same as at the start unless it
/// tapers)}. Returns 0, or -1 if the instance is not a viscera.intestine.
VSC_EXPORT int viscera_intestine_info(const mjModel* m, int instance, double out[9]) {
  vsc_plugin_config config;
  if (read_intestine(m, instance, &config)) return -1;
  out[0] = config.rod.length;
  out[1] = config.rod.radius;
  out[2] = config.rod.mass;
  out[3] = config.rod.control_count;
  out[4] = config.rod.collision_sphere_count;
  out[5] = config.rod.samples_per_segment;
  out[6] = config.step.sleep.enabled;
  out[7] = config.step.sleep.rest_time;
  out[8] = vsc_rod_def_radius_at(&config.rod, 1.0);
  vsc_plugin_config_free(&config);
  return 0;
}

/// Each grasper's pinch now and the pull its hold would slip at, as the plugin
/// takes them (grasps.h): out[2 i] = pinch (N; -1: no actuator drives the jaw),
/// out[2 i + 1] = slip pull (N), for the first `capacity` graspers. Returns the
/// grasper count, or -1 if `instance` is not a viscera.intestine.
VSC_EXPORT int viscera_grasp_pinches(const mjModel* m, const mjData* d, int instance, double* out, int capacity) {
  vsc_grasper_config g;
  // d's caches hold the config read at load: parsing it again (its control points) took 0.3 ms, the
  // score asks every control tick
  if (!vsc_intestine_grasper_config(m, d, instance, &g)) {
    vsc_plugin_config config;
    if (read_intestine(m, instance, &config)) return -1;
    g = config.grasp;
    vsc_plugin_config_free(&config);
  }
  for (int i = 0; i < g.count && i < capacity; ++i) {
    out[2 * i] = vsc_mujoco_grasp_pinch(m, d, &g, i);
    out[2 * i + 1] = vsc_mujoco_grasp_slip_pull(&g, out[2 * i]);
  }
  return g.count;
}

/// The colours the renderer draws the wall's damage in (intestine.h): out =
/// rgb of a full bruise, rgb of a tear, in [0, 1].
VSC_EXPORT void viscera_damage_colours(double out[6]) { vsc_damage_colours(out); }

/// Rebuild data `d`'s caches of intestine `instance` from model `m`'s config as
/// it now is (vsc_intestine_reconfigure): after the config's values were
/// rewritten in place. Returns 0, or -1 with a message in `error`.
VSC_EXPORT int viscera_intestine_reconfigure(const mjModel* m, mjData* d, int instance, char* error, int error_size) {
  return vsc_intestine_reconfigure(m, d, instance, error, error_size);
}

/// The stretch and bend stiffnesses (N/m) an intestine of rest length `length`
/// (m) takes by default, as config.c derives them from the core's defaults (one
/// material at any length): out = {stretch_stiffness, bend_stiffness}. Returns 0,
/// or -1 for a length that is not positive and finite.
VSC_EXPORT int viscera_default_stiffnesses(double length, double out[2]) {
  if (!(length > 0.0) || !isfinite(length)) return -1;
  vsc_rod_def core = vsc_default_rod_def();
  out[0] = vsc_plugin_default_stretch_stiffness(&core, length);
  out[1] = vsc_plugin_default_bend_stiffness(&core, length);
  return 0;
}

/// Number of blocks in an intestine's plugin_state (state_layout.h).
VSC_EXPORT int viscera_state_block_count(void) { return VSC_STATE_BLOCK_COUNT; }

/// Name of state block i (static storage), NULL if out of range.
VSC_EXPORT const char* viscera_state_block_name(int i) {
  return i >= 0 && i < VSC_STATE_BLOCK_COUNT ? vsc_state_block_names[i] : 0;
}

/// Numbers per item of state block i (per control point, body, sphere or
/// grasper), or -1 if out of range.
VSC_EXPORT int viscera_state_block_width(int i) {
  return i >= 0 && i < VSC_STATE_BLOCK_COUNT ? vsc_state_block_width[i] : -1;
}

/// Name of grasper status i (the grasps block's first number per grasper;
/// static storage), NULL if out of range.
VSC_EXPORT const char* viscera_grasp_status_name(int i) {
  return i >= 0 && i <= VSC_GRASP_CLOSED_EMPTY ? vsc_grasp_status_names[i] : 0;
}

/// The plugin_state layout of intestine `instance`: offset[i] and size[i]
/// (mjtNums, from the instance's plugin_stateadr) of block i, for i below
/// viscera_state_block_count(). Returns the total, or -1 if the instance is
/// not a viscera.intestine.
VSC_EXPORT int viscera_intestine_layout(const mjModel* m, int instance, int* offset, int* size) {
  vsc_plugin_config config;
  if (read_intestine(m, instance, &config)) return -1;
  vsc_state_layout l = vsc_state_layout_of(config.rod.control_count, config.rod.collision_sphere_count, (int)m->nbody,
                                           config.grasp.count);
  vsc_plugin_config_free(&config);
  for (int b = 0; b < VSC_STATE_BLOCK_COUNT; ++b) {
    offset[b] = l.offset[b];
    size[b] = l.size[b];
  }
  return l.total;
}

/// The skin of intestine `instance` (paper 3.2) from `state`, the instance's
/// plugin_state (positions first, m): *vertex_count and *triangle_count
/// receive its sizes; when they fit the capacities, vertices (m, 3 each), unit
/// normals and triangles (3 vertex indices each) are written. A positive
/// rings_per_segment / ring_points overrides the config's. The config is the
/// one data `d` read when its caches were built (d may be NULL: then it is
/// read here). Python guesses the sizes from its last call and calls again
/// only when they changed. Returns 0 (built), 1 (too small: sizes only), or -1 (not an
/// intestine, too few ring points, or a state that cannot be skinned).
VSC_EXPORT int viscera_skin(const mjModel* m, const mjData* d, int instance, int rings_per_segment, int ring_points,
                            const double* state, int vertex_capacity, int triangle_capacity, double* vertices,
                            double* normals, int* triangles, int* vertex_count, int* triangle_count) {
  vsc_skin_def def;
  int n;
  if (!vsc_intestine_skin_def(m, d, instance, &def, &n)) {  // else as d's caches read it
    vsc_plugin_config config;
    if (read_intestine(m, instance, &config)) return -1;
    def = config.skin;
    n = config.rod.control_count;
    vsc_plugin_config_free(&config);
  }
  if (rings_per_segment > 0) def.rings_per_segment = rings_per_segment;
  if (ring_points > 0) def.ring_points = ring_points;
  if (def.ring_points < 3 || m->plugin_statenum[instance] < 3 * n) return -1;
  *vertex_count = vsc_skin_vertex_count(n, &def);
  *triangle_count = vsc_skin_triangle_count(n, &def);
  if (*vertex_count > vertex_capacity || *triangle_count > triangle_capacity) return 1;
  return vsc_skin_build(state, n, &def, vertices, normals, triangles) == VSC_OK ? 0 : -1;
}

// The rod of intestine `instance` as the plugin builds it, with its initial control
// points (m, 3n, owned by the caller like the rod and the config: release them with
// release_initial_rod). Returns 0, or -1 with nothing left to release.
static int create_initial_rod(const mjModel* m, int instance, vsc_plugin_config* config, double** initial_q,
                              vsc_rod** rod) {
  char error[256];
  *initial_q = NULL;
  *rod = NULL;
  if (read_intestine(m, instance, config)) return -1;
  *initial_q = (double*)malloc(sizeof(double) * 3 * (size_t)config->rod.control_count);
  if (*initial_q && vsc_plugin_config_layout(config, *initial_q, error, (int)sizeof(error)) == 0 &&
      vsc_plugin_config_clamp(config, *initial_q, error, (int)sizeof(error)) == 0 &&
      vsc_rod_create(&config->rod, rod) == VSC_OK) {
    return 0;
  }
  free(*initial_q);
  vsc_plugin_config_free(config);
  return -1;
}

static void release_initial_rod(vsc_plugin_config* config, double* initial_q, vsc_rod* rod) {
  vsc_rod_destroy(rod);
  free(initial_q);
  vsc_plugin_config_free(config);
}

/// Energies of intestine `instance` at control points q (m, 3n) and velocities
/// v (m/s, 3n) under `gravity` (m/s^2): out = {elastic, gravitational (zero at
/// the origin), kinetic} (J). Builds the rod it measures with (O(n)): for
/// checks and benchmarks, not for every step. Returns 0, or -1.
VSC_EXPORT int viscera_intestine_energy(const mjModel* m, int instance, const double* q, const double* v,
                                        const double gravity[3], double out[3]) {
  vsc_plugin_config config;
  double* initial_q;
  vsc_rod* rod;
  if (create_initial_rod(m, instance, &config, &initial_q, &rod)) return -1;
  out[0] = vsc_rod_elastic_energy(rod, q);
  out[1] = vsc_rod_gravity_energy(rod, gravity, q);
  out[2] = vsc_rod_kinetic_energy(rod, v);
  release_initial_rod(&config, initial_q, rod);
  return 0;
}

/// Stability of intestine `instance` at its initial shape: out = {highest
/// elastic angular frequency its substeps meet (rad/s: without the global
/// length term where the kick takes it implicitly), highest contact angular
/// frequency (rad/s), substeps the plugin takes per step of the model's
/// timestep (vsc_plugin_config_plan)}. Returns 0, or -1.
VSC_EXPORT int viscera_intestine_stability(const mjModel* m, int instance, double out[3]) {
  vsc_plugin_config config;
  double* initial_q;
  vsc_rod* rod;
  if (create_initial_rod(m, instance, &config, &initial_q, &rod)) return -1;
  double elastic, kicked;
  vsc_rod_frequencies(rod, initial_q, 0, &elastic, &out[1]);
  vsc_rod_frequencies(rod, initial_q, 1, &kicked, &out[1]);
  vsc_plugin_step_plan plan = vsc_plugin_config_plan(&config, elastic, kicked, out[1], vsc_rod_contact_damping_rate(rod),
                                                     m->opt.timestep);
  out[0] = plan.elastic;
  out[2] = plan.substeps;
  release_initial_rod(&config, initial_q, rod);
  return 0;
}
