// Reads and checks the viscera.intestine plugin's config attributes, in one place.
// Units are SI; every key, its unit, default and meaning are in keys.h (and the
// page generated from it, docs/config.md).
#ifndef VISCERA_PLUGIN_CONFIG_H
#define VISCERA_PLUGIN_CONFIG_H

#include <mujoco/mujoco.h>

#include "keys.h"
#include "viscera/vsc_damage.h"
#include "viscera/vsc_integrate.h"
#include "viscera/vsc_resolution.h"
#include "viscera/vsc_rod.h"
#include "viscera/vsc_skin.h"

/// Config attribute names, in the order MuJoCo is told about them (keys.h).
extern const char* const vsc_plugin_attributes[];
extern const int vsc_plugin_attribute_count;

/// Each key's index in the table (keys.h): VSC_KEY_length, ...
#define VSC_KEY_INDEX(name, kind, field, minimum, maximum, unit, default_value, meaning) VSC_KEY_##name,
enum { VSC_PLUGIN_KEYS(VSC_KEY_INDEX) VSC_KEY_COUNT };
#undef VSC_KEY_INDEX

/// How a key's value is read and bounded (see keys.h).
typedef enum vsc_key_kind {
  VSC_KEY_KIND_REAL,
  VSC_KEY_KIND_POSITIVE,
  VSC_KEY_KIND_NONNEGATIVE,
  VSC_KEY_KIND_COUNT,
  VSC_KEY_KIND_VECTOR,
  VSC_KEY_KIND_CHOICE,
  VSC_KEY_KIND_CUSTOM,
  VSC_KEY_KIND_TAPER
} vsc_key_kind;

/// One row of the table of keys (keys.h; static storage).
typedef struct vsc_plugin_key {
  const char* name;
  vsc_key_kind kind;
  long offset;           ///< the value's place in vsc_plugin_config (bytes), -1: read by its own code
  double minimum;        ///< VSC_KEY_KIND_REAL and VSC_KEY_KIND_COUNT: smallest allowed value
  double maximum;        ///< VSC_KEY_KIND_REAL and VSC_KEY_KIND_COUNT: largest; VSC_KEY_KIND_VECTOR: how many numbers
  const char* unit;
  const char* value;     ///< default read as if the user wrote it, or NULL (the core's, or derived)
  const char* derived;   ///< the docs' words for a derived default, or NULL
  const char* meaning;   ///< Markdown
} vsc_plugin_key;
extern const vsc_plugin_key vsc_plugin_keys[];

/// Write key i's documentation field into out (size bytes, NUL-terminated):
/// "unit", "default" (a core default printed from the core's value), "meaning",
/// "kind" (real, positive, nonnegative, count, vector, choice, custom) or "values"
/// (the allowed values in words, Markdown). Returns the full length, or -1 for an
/// unknown key index or field.
int vsc_plugin_key_field(int i, const char* field, char* out, int size);

/// The default stretch and bend stiffnesses (N/m) at rest length `length` (m):
/// the core's defaults (`core`, at its own length) as one material at any
/// length, k core_length / length.
double vsc_plugin_default_stretch_stiffness(const vsc_rod_def* core, double length);
double vsc_plugin_default_bend_stiffness(const vsc_rod_def* core, double length);

/// Initial shape of the axis.
typedef enum vsc_shape_kind {
  VSC_SHAPE_LINE,
  VSC_SHAPE_POLYLINE,
  VSC_SHAPE_SERPENTINE,
  VSC_SHAPE_CONTROL_POINTS  ///< `points` are the n control points themselves (e.g. a settled state)
} vsc_shape_kind;

/// The keys whose values are names from a fixed list (integrator, shape,
/// clamped, mass_matrix): their allowed values, in enum order, NULL-terminated
/// (static storage), or NULL for any other key. The one list per key that the
/// parser, its refusal messages and the exported names read.
const char* const* vsc_plugin_allowed_values(const char* key);

/// Most grasping jaws one intestine serves.
#define VSC_MAX_GRASPERS 8

/// Most actuators driving one jaw joint that its pinch sums.
#define VSC_MAX_JAW_ACTUATORS 4

/// Jaws that take hold of the axis (see grasps.c): grasper i's anchor is
/// site `site[i]`; it is closed while joint `joint[i]`'s position is at most
/// `closed_below`. The actuators on the joint squeeze the held tissue (the
/// pinch); the hold slips past 2 `friction` x pinch (two jaw faces), and past
/// `slip_force` whatever the pinch.
typedef struct vsc_grasper_config {
  int count;                     ///< graspers (0: none)
  int site[VSC_MAX_GRASPERS];    ///< site ids: where the jaws hold
  int joint[VSC_MAX_GRASPERS];   ///< hinge or slide joint ids: the jaw opening
  int actuator[VSC_MAX_GRASPERS][VSC_MAX_JAW_ACTUATORS];  ///< actuator ids on each jaw joint
  int actuator_count[VSC_MAX_GRASPERS];  ///< 0: nothing drives the jaw, only slip_force limits its hold
  double closed_below;           ///< jaw position (rad or m) at or below which it is closed
  double reach;                  ///< farthest axis point a closing jaw takes (m, from the site)
  double stiffness;              ///< hold spring (N/m)
  double damping;                ///< hold damping (N s/m)
  double slip_force;             ///< the hold slips when its spring pulls harder (N), whatever the pinch
  double friction;               ///< jaw face on serosa: slips past 2 friction pinch (dimensionless)
  double lever;                  ///< hinge jaws: pinch = torque / lever (m); 0: the hinge axis's distance to the site
} vsc_grasper_config;

/// Most other intestine instances one excludes from its contacts ('exclude').
#define VSC_MAX_EXCLUDED 64

/// Everything an instance's config defines. Owns `pinned` and `points`.
typedef struct vsc_plugin_config {
  vsc_rod_def rod;            ///< mechanics; rod.pinned points into `pinned`
  vsc_step_options step;      ///< integrator, substeps per MuJoCo step, divergence retries
  int auto_substeps;          ///< 1: 'substeps' not given; chosen per step from the timestep (vsc_plugin_config_substeps)
  double tolerance;           ///< relative error accepted; given[VSC_KEY_tolerance], else the keys' own resolution
  vsc_resolution resolution;  ///< what the tolerance chose (its substeps' accuracy bound); zero without one
  vsc_skin_def skin;          ///< skin resolution and radius profile
  double friction;            ///< Coulomb coefficient against every geom; < 0: each geom's friction[0]
  double density;             ///< kg/m^3, when the mass is not given
  double young_modulus;       ///< Pa; 0: not given (the paper's springs)
  double wall_thickness;      ///< m; 0: a solid section
  int clamped;                ///< clamped ends: bit 0 start, bit 1 end
  double marked_band[2];      ///< drawn in its own colour: from, to (m along the rest axis); given[VSC_KEY_marked_band]
  double rgba[4];             ///< the colour it is drawn in: red, green, blue, opacity in [0, 1]
  int draw_capsules;          ///< capsules drawn along the axis; given[VSC_KEY_draw_capsules], else one per sample interval
  vsc_shape_kind shape;
  double start[3];            ///< line start (m)
  double direction[3];        ///< line direction (unit)
  double box[6];              ///< serpentine box: min then max corner (m)
  double* points;             ///< polyline vertices (m, 3 x point_count)
  int point_count;
  int* pinned;                ///< pinned control point indices
  vsc_grasper_config grasp;   ///< jaws that hold the axis
  vsc_damage_limits damage;   ///< where the wall perforates, bruises and tears
  int exclude[VSC_MAX_EXCLUDED];  ///< plugin instance ids of the intestines it does not collide with
  int exclude_count;
  unsigned char given[VSC_KEY_COUNT];  ///< 1 where the model gave the key (by VSC_KEY_ index)
} vsc_plugin_config;

/// Parse and validate the config of plugin instance `instance`. On a bad
/// value it writes a message naming the attribute and the value into `error`
/// and returns -1 (nothing to free); on success returns 0 and the caller must
/// call vsc_plugin_config_free.
int vsc_plugin_config_read(const mjModel* m, int instance, vsc_plugin_config* config, char* error,
                           int error_size);

/// Set the clamp directions of clamped ends from the initial control points
/// q (m, 3n): the spline's end tangents. Returns 0, or -1 with a message.
int vsc_plugin_config_clamp(vsc_plugin_config* config, const double* q, char* error, int error_size);

/// With a 'tolerance' and the substeps left to it: -1 with a message if the
/// accuracy it asks for needs more than VSC_MAX_AUTO_SUBSTEPS per step dt (s),
/// else 0. Checked when the model compiles (a timestep raised later is met
/// with the most substeps allowed).
int vsc_plugin_config_check_timestep(const vsc_plugin_config* config, double dt, char* error, int error_size);

/// Substeps per step dt (s) when 'substeps' is not given: the fewest the
/// stability estimate allows (vsc_stable_substeps with the rod's elastic and
/// contact frequencies, rad/s, and contact damping rate, 1/s), and with a
/// 'tolerance' at least those that keep its accuracy (vsc_resolution_substeps).
/// With 'substeps' given, that value.
int vsc_plugin_config_substeps(const vsc_plugin_config* config, double elastic, double contact,
                               double contact_damping_rate, double dt);

/// What each step takes at timestep dt (s).
typedef struct vsc_plugin_step_plan {
  int substeps;          ///< substeps per step
  int length_implicit;   ///< 1: the kick takes the global length term implicitly
  double damping_limit;  ///< the bound on a pile's gamma h (vsc_stable_damping_limit)
  double elastic;        ///< the elastic frequency the substeps meet (rad/s)
} vsc_plugin_step_plan;

/// The step's plan from the rod's frequencies (rad/s: elastic with the global
/// length term, `kicked` without it, contact) and contact damping rate (1/s):
/// with 'substeps' given, those, the length term implicit (where the
/// integrator can) and the damping whole; else vsc_plugin_config_substeps, the
/// length term implicit only where that saves a substep (elsewhere the kick
/// stays exactly symplectic and pays nothing for it), and the damping limit
/// those substeps count on.
vsc_plugin_step_plan vsc_plugin_config_plan(const vsc_plugin_config* config, double elastic, double kicked,
                                            double contact, double contact_damping_rate, double dt);

/// Release what vsc_plugin_config_read allocated.
void vsc_plugin_config_free(vsc_plugin_config* config);

/// Lay out the initial control points (m, 3n) described by the config.
/// Returns 0, or -1 with a message in `error` if the shape cannot be laid out.
int vsc_plugin_config_layout(const vsc_plugin_config* config, double* q, char* error, int error_size);

#endif  // VISCERA_PLUGIN_CONFIG_H
