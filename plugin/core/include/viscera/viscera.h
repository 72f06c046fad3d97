// viscera's C core, the whole public API in one include (the MuJoCo adapter
// and the core's tests may include the pieces they use instead).
//
// Plain C11, no MuJoCo, SI units throughout; every allocation is made by a
// vsc_*_create function and released by its vsc_*_destroy twin (vsc_base.h).
// One concept per header:
//   vsc_base.h       status codes, pi, runtime-dispatched vector clones
//   vsc_spline.h     the Catmull-Rom basis and its end closure
//   vsc_band.h       band-7 and wide band LDL^T factorisations
//   vsc_rod.h        the rod: its model, definition, creation and queries
//   vsc_world.h      what surrounds a rod: gravity, geoms, held points, reactions
//   vsc_place.h      placement: samples and collision spheres from the control points
//   vsc_elastic.h    the elastic energy and the axis length
//   vsc_forces.h     one force evaluation and the accelerations
//   vsc_energy.h     kinetic, gravitational and active energies
//   vsc_geom.h       rigid geoms: signed distances, point velocities, wrenches
//   vsc_grid.h       the sphere grid (spatial hash)
//   vsc_contact.h    penalty contacts: the model, its constants, its energy
//   vsc_friction.h   the friction state
//   vsc_grasp.h      held points (grasping jaws)
//   vsc_damage.h     tissue damage: bruising, perforation and tears
//   vsc_jacobian.h   band force Jacobians (the implicit step)
//   vsc_integrate.h  the integrators' table and the step with its divergence retries
//   vsc_stability.h  frequencies and the substeps a timestep needs
//   vsc_layout.h     initial shapes (line, polyline, serpentine)
//   vsc_skin.h       the tube's skin mesh
#ifndef VISCERA_VISCERA_H
#define VISCERA_VISCERA_H

#include "viscera/vsc_base.h"
#include "viscera/vsc_band.h"
#include "viscera/vsc_contact.h"
#include "viscera/vsc_damage.h"
#include "viscera/vsc_elastic.h"
#include "viscera/vsc_energy.h"
#include "viscera/vsc_forces.h"
#include "viscera/vsc_friction.h"
#include "viscera/vsc_geom.h"
#include "viscera/vsc_grasp.h"
#include "viscera/vsc_grid.h"
#include "viscera/vsc_integrate.h"
#include "viscera/vsc_jacobian.h"
#include "viscera/vsc_layout.h"
#include "viscera/vsc_place.h"
#include "viscera/vsc_resolution.h"
#include "viscera/vsc_rod.h"
#include "viscera/vsc_skin.h"
#include "viscera/vsc_sleep.h"
#include "viscera/vsc_spline.h"
#include "viscera/vsc_stability.h"
#include "viscera/vsc_world.h"

#endif  // VISCERA_VISCERA_H
