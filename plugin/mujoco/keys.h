// viscera.intestine's config keys, one row each: name, unit, default,
// meaning (Markdown). The one list of keys: MuJoCo is told the names in this
// order (plugin_attr keeps it), Python reads it (viscera.attribute_names,
// viscera.attribute_docs), and docs/config.md's table is generated
// from it (docs/tables.py; a test fails when they differ). Parsing, bounds and
// refusals are in config.c.
#ifndef VISCERA_PLUGIN_KEYS_H
#define VISCERA_PLUGIN_KEYS_H

#define VSC_PLUGIN_KEYS(X) \
  X(length, "m", "4", \
    "rest length of the axis") \
  X(control_points, "count", "250", \
    "control points n (4 to 10^6; with `samples_per_segment` and `collision_spheres` at most 2.1 GB of " \
    "memory per intestine, checked at load)") \
  X(mass, "kg", "density x pi radius^2 x length (1.963)", \
    "total mass; give `mass` or `density`, not both") \
  X(density, "kg/m^3", "1000", \
    "used when `mass` is absent") \
  X(radius, "m", "0.0125", \
    "tube radius: the collision spheres' radius") \
  X(radius_min, "m", "`radius_max`", \
    "skin radius between control points (<= `radius_max`)") \
  X(radius_max, "m", "`radius`", \
    "skin radius at control points") \
  X(stretch_stiffness, "N/m", "40 N / `length` (10 at 4 m)", \
    "axial stiffness EA/L of the whole intestine's stretch springs; the default is one material at any " \
    "length; 0 turns them off") \
  X(bend_stiffness, "N/m", "4 N / `length` (1 at 4 m)", \
    "same, for the bend springs (sample a to a+2); 0 turns them off") \
  X(global_stretch_stiffness, "N/m", "200", \
    "K in 1/2 K (l - length)^2 on the sampled length l; 0 turns it off") \
  X(damping, "1/s", "1", \
    "mass-proportional viscous damping: force -damping m v along the axis, velocities decay at this rate") \
  X(substeps, "count", "from the timestep", \
    "integrator substeps per MuJoCo step (1 to 10^4). By default the fewest with omega h <= 2.7 (RK4) or " \
    "1.8 (leapfrog, symplectic Euler; the implicit step's explicit friction and self-contacts), omega the " \
    "rod's highest elastic or contact frequency at its initial shape (power iteration, tested against the " \
    "measured limits), and for leapfrog and symplectic Euler omega^2 h^2 + 2 gamma h <= 1.8^2 with gamma " \
    "the contact damping's rate (see [integrators](integrators.md)): 3 at 2 ms for the shipped scenes; " \
    "for a 1 m, 60-point rod, 7 at 5 ms (dm_control's humanoid) and 13 at 10 ms (cheetah). A given value " \
    "wins") \
  X(integrator, "-", "`leapfrog`", \
    "the rod's integrator: `leapfrog` (Stormer-Verlet, 2nd order, 1 force evaluation a substep, bounded " \
    "energy), `rk4` (the paper's: 4th order, 4 evaluations a substep), `symplectic_euler` (1st order, 1 " \
    "evaluation), `implicit` (linearly implicit backward Euler: 1 evaluation plus a band Jacobian and an " \
    "O(n) solve; stable at any stiffness); see [integrators](integrators.md)") \
  X(contact_stiffness, "N/m", "2000", \
    "penalty stiffness of each contact (normal, and the tangential stick spring)") \
  X(contact_damping, "N s/m", "2", \
    "penalty damping, normal and tangential (contacts push, never pull)") \
  X(collision_spheres, "count", "ceil(length / radius) + 1 (321)", \
    "spheres uniform in abscissa, one radius apart") \
  X(pinned, "indices", "none", \
    "space-separated control point indices held fixed in space") \
  X(shape, "-", "`line`", \
    "initial shape: `line`, `polyline`, `serpentine` or `control_points`") \
  X(start, "m", "0 0 0", \
    "`line`: first control point") \
  X(direction, "-", "1 0 0", \
    "`line`: direction (normalised)") \
  X(points, "m", "-", \
    "`polyline`: vertices, 3 numbers each (>= 2); the axis follows it from its first vertex over " \
    "`length`. `control_points`: the n control points themselves (a settled state)") \
  X(box, "m", "-", \
    "`serpentine`: min then max corner; rows along x, one diameter apart, stacked along y then z") \
  X(samples_per_segment, "count", "2", \
    "spring sample points per spline segment S (1 to 64)") \
  X(self_collision, "0 or 1", "1", \
    "the intestine collides with itself") \
  X(friction, "Coulomb coefficient", "each geom's `friction[0]`", \
    "Coulomb coefficient against every rigid geom") \
  X(self_friction, "Coulomb coefficient", "0.3", \
    "Coulomb coefficient of the intestine against itself") \
  X(skin_rings_per_segment, "count", "4", \
    "skin rings per spline segment (1 to 64)") \
  X(skin_ring_points, "count", "16", \
    "skin vertices per ring (3 to 256)") \
  X(mesentery_stiffness, "N/m", "0 (off)", \
    "stiffness of each mesentery tether: tension-only springs from the axis to a root line, E = 1/2 k " \
    "max(0, d - L)^2") \
  X(mesentery_length, "m", "0.15", \
    "slack length L of every tether (the mesentery's depth)") \
  X(mesentery_points, "count", "32", \
    "tethers, at abscissae (i + 1/2) / count, each to the same fraction of the root line") \
  X(mesentery_root, "m", "-", \
    "the root line on the posterior wall: from, to (6 numbers); required when the stiffness is > 0") \
  X(grasp_sites, "names", "none", \
    "sites where grasping jaws hold the axis (up to 8)") \
  X(grasp_joints, "names", "none", \
    "the hinge or slide joint opening each jaw, one per site") \
  X(grasp_closed_below, "rad or m", "0.1", \
    "a jaw is closed while its joint is at or below this") \
  X(grasp_reach, "m", "2 `radius`", \
    "farthest axis point (from the site) a closing jaw takes") \
  X(grasp_stiffness, "N/m", "1000", \
    "the hold's spring") \
  X(grasp_damping, "N s/m", "2", \
    "the hold's damping") \
  X(grasp_slip_force, "N", "5", \
    "a hold pulling harder slips out of the jaw") \
  X(young_modulus, "Pa", "none", \
    "material: sets `stretch_stiffness` = EA / length and `bending_rigidity` = EI, and turns the bend " \
    "springs and global term off by default (see [material parameters](validation.md#material-parameters))") \
  X(wall_thickness, "m", "solid", \
    "tube wall (0 < t <= radius) for A and I; needs `young_modulus`") \
  X(bending_rigidity, "N m^2", "E I, else 0", \
    "EI of the curvature bending energy") \
  X(clamped, "-", "`none`", \
    "`start`, `end` or `both`: the end is held in place and in direction (its initial tangent). With a " \
    "`bending_rigidity` (or `young_modulus`) the end control point is pinned and a clamp term (2 EI / " \
    "l0)(1 - t . e / abs(e)) holds the end spring edge e along t; without one (the paper's springs) the " \
    "neighbouring control point is pinned too") \
  X(divergence_retries, "count", "4", \
    "a diverged step is retried from its start with twice the substeps, up to this many times (0 to 10; " \
    "4: up to 16x) and at most 1024 substeps, before it is restored") \
  X(mass_matrix, "-", "`lumped`", \
    "`lumped` (each row of the band matrix summed on its diagonal: same total mass, gravity and rest " \
    "shapes; highest frequencies 1.4x lower, so 3 leapfrog substeps per 2 ms where `consistent` needs 5 " \
    "on the fall; every validation case within its tolerance) or `consistent` (the paper's M_ij = m " \
    "integral b_i b_j ds, band 7)")

#endif  // VISCERA_PLUGIN_KEYS_H
