// The friction state the host keeps for a rod (its model is in vsc_contact.h):
// per collision sphere, a stick spring towards one rigid partner and one self
// partner, carried from step to step.
#ifndef VISCERA_VSC_FRICTION_H
#define VISCERA_VSC_FRICTION_H

/// Friction state per sphere: rigid partner (geom index, -1 none), its
/// elongation (m, 3), self partner of the segment starting at this sphere
/// (segment index, -1 none), its elongation (m, 3).
#define VSC_STICK_SIZE 8

/// Write the "no contact" friction state for every sphere (VSC_STICK_SIZE each).
void vsc_stick_clear(double* stick, int sphere_count);

#endif  // VISCERA_VSC_FRICTION_H
