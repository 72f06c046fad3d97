// A few core functions exported for the Python package (ctypes), so Python
// evaluates the axis with the very basis the plugin uses and reads the config
// attribute list from its single definition.
#include "config.h"
#include "viscera/vsc_spline.h"

#define VSC_EXPORT __attribute__((visibility("default")))

/// Number of config attributes of viscera.intestine.
VSC_EXPORT int viscera_attribute_count(void) { return vsc_plugin_attribute_count; }

/// Name of config attribute i (static storage), NULL if out of range.
VSC_EXPORT const char* viscera_attribute_name(int i) {
  return i >= 0 && i < vsc_plugin_attribute_count ? vsc_plugin_attributes[i] : 0;
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

/// Resolved mechanics of intestine `instance` of model `m`, defaults applied,
/// as the plugin itself reads them: out = {length (m), radius (m), mass (kg),
/// control points, collision spheres, samples per segment}. Returns 0, or -1
/// if the instance is not a viscera.intestine.
VSC_EXPORT int viscera_intestine_info(const mjModel* m, int instance, double out[6]) {
  vsc_plugin_config config;
  char error[256];
  int slot = -1;
  if (instance < 0 || instance >= m->nplugin) return -1;
  if (!mjp_getPlugin("viscera.intestine", &slot) || m->plugin[instance] != slot) return -1;
  if (vsc_plugin_config_read(m, instance, &config, error, (int)sizeof(error))) return -1;
  out[0] = config.rod.length;
  out[1] = config.rod.radius;
  out[2] = config.rod.mass;
  out[3] = config.rod.control_count;
  out[4] = config.rod.collision_sphere_count;
  out[5] = config.rod.samples_per_segment;
  vsc_plugin_config_free(&config);
  return 0;
}
