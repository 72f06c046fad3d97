// Rigid collision primitives the intestine touches, described by the host
// (the MuJoCo adapter fills them from mjData) in the world frame.
#ifndef VISCERA_VSC_GEOM_H
#define VISCERA_VSC_GEOM_H

/// Primitive types with an exact signed distance.
typedef enum vsc_geom_type {
  VSC_GEOM_PLANE = 0,     ///< half-space below the local z = 0 plane (infinite)
  VSC_GEOM_SPHERE = 1,    ///< size[0] radius (m)
  VSC_GEOM_CAPSULE = 2,   ///< size[0] radius, size[1] half-length along local z (m)
  VSC_GEOM_CYLINDER = 3,  ///< size[0] radius, size[1] half-height along local z (m)
  VSC_GEOM_BOX = 4,       ///< size[0..2] half-extents along local x, y, z (m)
  VSC_GEOM_ELLIPSOID = 5, ///< size[0..2] semi-axes (m); exact distance (closest point by Newton)
  VSC_GEOM_CONVEX = 6,    ///< convex polytope in `convex` (a mesh's hull): exact distance
  VSC_GEOM_HEIGHTFIELD = 7,  ///< `heightfield`: vertical distance to the bilinear surface along its normal
} vsc_geom_type;

/// Convex polytope, local frame (host-owned): outward face planes n . x = offset
/// and the faces' triangles, used outside for the exact closest point.
typedef struct vsc_convex {
  int face_count;
  const double* planes;     ///< n x, n y, n z, offset (m) per face (4 x face_count)
  const double* triangles;  ///< 3 vertices per face (m, 9 x face_count)
} vsc_convex;

/// Height field, local frame (host-owned): heights over [-size[0], size[0]] x
/// [-size[1], size[1]], rows along y, columns along x (MuJoCo's layout).
typedef struct vsc_heightfield {
  int rows, columns;
  const float* elevation;   ///< rows x columns values in [0, 1], times size[2] (m)
  double size[4];           ///< half x, half y, top elevation, base depth (m)
  const double* vertices;   ///< optional, host-owned (NULL: derived at every query): per grid vertex, row by
                            ///< row, its height (m) and slopes dz/dx, dz/dy (3 x rows x columns), written
                            ///< by vsc_heightfield_vertices() whenever `elevation` changes (the plugin: at load)
} vsc_heightfield;

/// Number of doubles vsc_heightfield_vertices() writes for `h`.
int vsc_heightfield_vertex_size(const vsc_heightfield* h);

/// Write every vertex's height (m) and slopes into `out` (vsc_heightfield_vertex_size(h)
/// doubles, caller-owned), to be set as h->vertices: a query then reads 4 records instead of
/// 20 elevations. The same numbers a query derives without them.
void vsc_heightfield_vertices(const vsc_heightfield* h, double* out);

/// One rigid geom, world frame. Owned by the host.
typedef struct vsc_geom {
  vsc_geom_type type;
  double position[3];          ///< frame origin (m)
  double rotation[9];          ///< row-major 3x3, columns are the local axes (MuJoCo xmat)
  double size[3];              ///< see vsc_geom_type (m)
  double bound_radius;         ///< radius of a sphere at `position` holding the geom (m); <= 0: unbounded
  double linear_velocity[3];   ///< velocity of the frame origin (m/s)
  double angular_velocity[3];  ///< angular velocity (rad/s)
  double box[6];               ///< world-frame bounding box, min then max (m); ignored when unbounded
  double friction;             ///< Coulomb coefficient of the intestine against this geom (>= 0)
  int is_static;               ///< 1: never moves (its velocities are ignored)
  int resting;                 ///< 1: it moves only as a resting body chatters (another rod's capsule whose
                               ///< points all rest, vsc_sleep.h): its speed wakes nothing, its depth still does
  const vsc_convex* convex;    ///< VSC_GEOM_CONVEX only
  const vsc_heightfield* heightfield;  ///< VSC_GEOM_HEIGHTFIELD only
} vsc_geom;

/// Signed distance (m) from world point `point` to the geom surface, negative
/// inside, and the outward unit normal at the closest surface point (world).
double vsc_geom_distance(const vsc_geom* geom, const double point[3], double normal[3]);

/// A distance (m) that changes no faster than a point moves, for skipping pairs that cannot
/// touch: every point y within `reach` (m) of `point` for which bound - |y - point| > 0 lies
/// at least that far from the surface (and outside). The exact signed distance for the
/// primitives (it changes no faster); for a height field, whose distance jumps at its sides
/// and turns with its normal, the height above its highest vertex near `point` (within reach,
/// in x and y) over the steepest normal's slant there, or -infinity when not above them (and
/// for a height field that is not static).
double vsc_geom_distance_bound(const vsc_geom* geom, const double point[3], double reach);

/// out += scale (f, torque + arm x f): a force f (N) with a torque (N m, NULL:
/// none), as a wrench about a reference point `arm` (m) behind the force's point
/// (out: force N, torque N m). The one wrench accumulation of the core and the
/// plugin (scale -w: the reaction, weighted over a step).
void vsc_wrench_add(double out[6], double scale, const double f[3], const double* torque, const double arm[3]);

/// Velocity (m/s) of the geom's material point at world position `point`.
void vsc_geom_point_velocity(const vsc_geom* geom, const double point[3], double velocity[3]);

#endif  // VISCERA_VSC_GEOM_H
