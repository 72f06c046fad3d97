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
} vsc_geom_type;

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
} vsc_geom;

/// Signed distance (m) from world point `point` to the geom surface, negative
/// inside, and the outward unit normal at the closest surface point (world).
double vsc_geom_distance(const vsc_geom* geom, const double point[3], double normal[3]);

/// Velocity (m/s) of the geom's material point at world position `point`.
void vsc_geom_point_velocity(const vsc_geom* geom, const double point[3], double velocity[3]);

#endif  // VISCERA_VSC_GEOM_H
