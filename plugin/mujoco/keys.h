// viscera.intestine's config keys: the one table of them. One row per key:
//   X(name, kind, field, minimum, maximum, unit, default, meaning)
// - kind: how the value is read and bounded (config.c reads every row the same
//   way): VSC_KEY_KIND_REAL (a finite number in [minimum, maximum]), VSC_KEY_KIND_POSITIVE (> 0),
//   VSC_KEY_KIND_NONNEGATIVE (>= 0), VSC_KEY_KIND_COUNT (an integer in [minimum, maximum]),
//   VSC_KEY_KIND_VECTOR (exactly `maximum` finite numbers), VSC_KEY_KIND_TAPER (one positive number, or
//   two: at the start and the end, into two adjacent fields), VSC_KEY_KIND_CHOICE (a name from the
//   key's list in config.c, tied to its enum), VSC_KEY_KIND_CUSTOM (read by its own code:
//   indices, names, point lists).
// - field: where the value goes in vsc_plugin_config (FIELD(member) or NO_FIELD).
// - default: CORE (the core's own default, vsc_default_rod_def and friends,
//   printed from it for the docs), VALUE("text") (read as if the user wrote it)
//   or DERIVED("what the docs say"): computed from other keys in config.c.
// MuJoCo is told the names in this order (plugin_attr keeps it); Python reads
// the table (viscera.attribute_names, viscera.attribute_docs) and docs/config.md's
// table is generated from it (docs/tables.py; a test fails when they differ).
#ifndef VISCERA_PLUGIN_KEYS_H
#define VISCERA_PLUGIN_KEYS_H

#define VSC_PLUGIN_KEYS(X) \
  X(length, VSC_KEY_KIND_POSITIVE, FIELD(rod.length), 0, 0, "m", CORE, \
    "rest length of the axis") \
  X(tolerance, VSC_KEY_KIND_POSITIVE, FIELD(tolerance), 0, 0, "relative error", DERIVED("none"), \
    "the relative error the scene accepts, below 1: it chooses `control_points`, `samples_per_segment`, " \
    "`collision_spheres` and the substeps' accuracy from the validation cases' measured convergence; a " \
    "key given explicitly wins. Refused below what the validation cases reach or past the plugin's limits " \
    "(see [tolerance](#tolerance))") \
  X(control_points, VSC_KEY_KIND_COUNT, FIELD(rod.control_count), 4, VSC_MAX_CONTROL_POINTS, "count", CORE, \
    "control points n (with `samples_per_segment` and `collision_spheres` at most 2.1 GB of memory per " \
    "intestine, checked at load)") \
  X(mass, VSC_KEY_KIND_POSITIVE, FIELD(rod.mass), 0, 0, "kg", DERIVED("density x pi radius^2 x length (1.963)"), \
    "total mass; give `mass` or `density`, not both") \
  X(density, VSC_KEY_KIND_POSITIVE, FIELD(density), 0, 0, "kg/m^3", VALUE("1000"), \
    "used when `mass` is absent") \
  X(radius, VSC_KEY_KIND_TAPER, FIELD(rod.radius), 0, 0, "m", CORE, \
    "tube radius: the collision spheres' radius. Two values taper the tube: the radius at the start and at " \
    "the end, linear in the rest length between; the spheres, contacts, skin, drawing, mass (as radius^2) " \
    "and springs (as the section's area and second moment; the stiffnesses are the start's) follow the local radius (see [taper](model.md#taper))") \
  X(radius_min, VSC_KEY_KIND_POSITIVE, FIELD(skin.radius_min), 0, 0, "m", DERIVED("`radius_max`"), \
    "skin radius between control points (<= `radius_max`)") \
  X(radius_max, VSC_KEY_KIND_POSITIVE, FIELD(skin.radius_max), 0, 0, "m", DERIVED("`radius`"), \
    "skin radius at control points") \
  X(stretch_stiffness, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.stretch_stiffness), 0, 0, "N/m", \
    DERIVED("40 N / `length` (10 at 4 m)"), \
    "axial stiffness EA/L of the whole intestine's stretch springs; the default is one material at any " \
    "length; 0 turns them off") \
  X(bend_stiffness, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.bend_stiffness), 0, 0, "N/m", DERIVED("4 N / `length` (1 at 4 m)"), \
    "same, for the bend springs (sample a to a+2); 0 turns them off") \
  X(global_stretch_stiffness, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.global_stretch_stiffness), 0, 0, "N/m", CORE, \
    "K in 1/2 K (l - length)^2 on the sampled length l; 0 turns it off") \
  X(damping, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.damping), 0, 0, "1/s", CORE, \
    "mass-proportional viscous damping: force -damping m v along the axis, velocities decay at this rate") \
  X(substeps, VSC_KEY_KIND_COUNT, FIELD(step.substeps), 1, 10000, "count", DERIVED("from the timestep"), \
    "integrator substeps per MuJoCo step. By default the fewest with omega h <= 2.7 (RK4) or " \
    "1.8 (leapfrog, symplectic Euler; the implicit step's explicit friction and self-contacts), omega the " \
    "rod's highest elastic or contact frequency at its initial shape (power iteration, tested against the " \
    "measured limits), and for leapfrog and symplectic Euler omega^2 h^2 + 2 gamma h <= 1.8^2 with gamma " \
    "the contact damping's rate (see [integrators](integrators.md)); for leapfrog and symplectic Euler the " \
    "global length term is taken implicitly in the kick, and a pile's gamma h held to 0.9, where that saves " \
    "a substep: 3 at 2 ms for the box abdomen and the paper's fall, 1 at 1 ms for the anatomical abdomen; " \
    "for a 1 m, 60-point rod, 6 at 5 ms (dm_control's humanoid) and 11 at 10 ms (cheetah). A given value " \
    "wins, with the length term implicit") \
  X(integrator, VSC_KEY_KIND_CHOICE, FIELD(step.integrator), 0, 0, "-", CORE, \
    "the rod's integrator: `leapfrog` (Stormer-Verlet, 2nd order, 1 force evaluation a substep, bounded " \
    "energy), `rk4` (the paper's: 4th order, 4 evaluations a substep), `symplectic_euler` (1st order, 1 " \
    "evaluation), `implicit` (linearly implicit backward Euler: 1 evaluation plus a band Jacobian and an " \
    "O(n) solve; stable at any stiffness); see [integrators](integrators.md)") \
  X(contact_stiffness, VSC_KEY_KIND_POSITIVE, FIELD(rod.contact_stiffness), 0, 0, "N/m", CORE, \
    "penalty stiffness of each contact (normal, and the tangential stick spring)") \
  X(contact_damping, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.contact_damping), 0, 0, "N s/m", CORE, \
    "penalty damping, normal and tangential (contacts push, never pull); where contacts pile up on a few " \
    "spheres past its explicit limit (gamma h < 2 per control point, see [integrators](integrators.md)) " \
    "their damping is scaled down to it") \
  X(collision_spheres, VSC_KEY_KIND_COUNT, FIELD(rod.collision_sphere_count), 2, VSC_MAX_COLLISION_SPHERES, "count", \
    DERIVED("ceil(length / radius) + 1 (321)"), \
    "spheres uniform in abscissa, one radius apart") \
  X(pinned, VSC_KEY_KIND_CUSTOM, NO_FIELD, 0, 0, "indices", DERIVED("none"), \
    "space-separated control point indices held fixed in space; negative ones count from the end (-1 is the " \
    "last), as where `tolerance` chooses the count") \
  X(shape, VSC_KEY_KIND_CHOICE, FIELD(shape), 0, 0, "-", VALUE("line"), \
    "initial shape") \
  X(start, VSC_KEY_KIND_VECTOR, FIELD(start), 0, 3, "m", VALUE("0 0 0"), \
    "`line`: first control point") \
  X(direction, VSC_KEY_KIND_VECTOR, FIELD(direction), 0, 3, "-", VALUE("1 0 0"), \
    "`line`: direction (normalised)") \
  X(points, VSC_KEY_KIND_CUSTOM, NO_FIELD, 0, 0, "m", DERIVED("-"), \
    "`polyline`: vertices, 3 numbers each (>= 2); the axis follows it from its first vertex over " \
    "`length`. `control_points`: the n control points themselves (a settled state)") \
  X(box, VSC_KEY_KIND_VECTOR, FIELD(box), 0, 6, "m", DERIVED("-"), \
    "`serpentine`: min then max corner; rows along x, one diameter apart, stacked along y then z") \
  X(samples_per_segment, VSC_KEY_KIND_COUNT, FIELD(rod.samples_per_segment), 1, 64, "count", CORE, \
    "spring sample points per spline segment S") \
  X(self_collision, VSC_KEY_KIND_COUNT, FIELD(rod.self_collision), 0, 1, "0 or 1", CORE, \
    "the intestine collides with itself") \
  X(friction, VSC_KEY_KIND_NONNEGATIVE, FIELD(friction), 0, 0, "Coulomb coefficient", DERIVED("each geom's `friction[0]`"), \
    "Coulomb coefficient against every rigid geom") \
  X(self_friction, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.self_friction), 0, 0, "Coulomb coefficient", CORE, \
    "Coulomb coefficient of the intestine against itself") \
  X(skin_rings_per_segment, VSC_KEY_KIND_COUNT, FIELD(skin.rings_per_segment), 1, 64, "count", CORE, \
    "skin rings per spline segment") \
  X(skin_ring_points, VSC_KEY_KIND_COUNT, FIELD(skin.ring_points), 3, 256, "count", CORE, \
    "skin vertices per ring") \
  X(mesentery_stiffness, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.mesentery_stiffness), 0, 0, "N/m", VALUE("0"), \
    "stiffness of each mesentery tether: tension-only springs from the axis to a root line, E = 1/2 k " \
    "max(0, d - L)^2; 0: no mesentery") \
  X(mesentery_length, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.mesentery_length), 0, 0, "m", VALUE("0.15"), \
    "slack length L of every tether (the mesentery's depth)") \
  X(mesentery_points, VSC_KEY_KIND_COUNT, FIELD(rod.mesentery_points), 1, 100000, "count", VALUE("32"), \
    "tethers, at abscissae (i + 1/2) / count, each to the same fraction of the root line") \
  X(mesentery_root, VSC_KEY_KIND_VECTOR, FIELD(rod.mesentery_root), 0, 6, "m", DERIVED("-"), \
    "the root line on the posterior wall: from, to; required when the stiffness is > 0") \
  X(exclude, VSC_KEY_KIND_CUSTOM, NO_FIELD, 0, 0, "names", DERIVED("none"), \
    "names of other intestine instances it does not collide with (space-separated), as MuJoCo's " \
    "`<exclude>` does for a body pair: either instance's list excludes the pair. Otherwise every " \
    "intestine instance of a model collides with every other, with the larger of their `self_friction`s") \
  X(grasp_sites, VSC_KEY_KIND_CUSTOM, NO_FIELD, 0, 0, "names", DERIVED("none"), \
    "sites where grasping jaws hold the axis (up to 8)") \
  X(grasp_joints, VSC_KEY_KIND_CUSTOM, NO_FIELD, 0, 0, "names", DERIVED("none"), \
    "the hinge or slide joint opening each jaw, one per site") \
  X(grasp_closed_below, VSC_KEY_KIND_REAL, FIELD(grasp.closed_below), -HUGE_VAL, HUGE_VAL, "rad or m", VALUE("0.1"), \
    "a jaw is closed while its joint is at or below this") \
  X(grasp_reach, VSC_KEY_KIND_POSITIVE, FIELD(grasp.reach), 0, 0, "m", DERIVED("2 `radius`"), \
    "farthest axis point (from the site) a closing jaw takes") \
  X(grasp_stiffness, VSC_KEY_KIND_NONNEGATIVE, FIELD(grasp.stiffness), 0, 0, "N/m", VALUE("1000"), \
    "the hold's spring") \
  X(grasp_damping, VSC_KEY_KIND_NONNEGATIVE, FIELD(grasp.damping), 0, 0, "N s/m", VALUE("2"), \
    "the hold's damping") \
  X(grasp_slip_force, VSC_KEY_KIND_POSITIVE, FIELD(grasp.slip_force), 0, 0, "N", VALUE("5"), \
    "a hold pulling harder slips out of the jaw, whatever the pinch") \
  X(grasp_friction, VSC_KEY_KIND_NONNEGATIVE, FIELD(grasp.friction), 0, 0, "-", VALUE("0.8333"), \
    "friction coefficient of each jaw face on the serosa: a hold slips once it pulls harder than 2 x this x " \
    "the pinch (two faces; the pinch is the jaw actuators' squeeze, see [grasp](model.md#grasp)). The " \
    "default is Heijnsdijk et al. (Surg Endosc 2004): 5 N of pull on pig small bowel needed 3.0 N of pinch. " \
    "A jaw no actuator drives slips at `grasp_slip_force` only") \
  X(grasp_lever, VSC_KEY_KIND_POSITIVE, FIELD(grasp.lever), 0, 0, "m", DERIVED("the hinge axis to the site"), \
    "hinge jaws: the pinch is the actuators' torque over this lever, from the hinge to where the jaws meet " \
    "the tissue. By default the distance from the jaw's hinge axis to its grasp site, each step") \
  X(damage_perforation_pinch, VSC_KEY_KIND_POSITIVE, FIELD(damage.perforation_pinch), 0, 0, "N", CORE, \
    "a held pinch at least this perforates the wall at the held point (human small bowel 10.3 +- 2.9 N: " \
    "Heijnsdijk et al., Surg Endosc 2003); see [damage](model.md#damage)") \
  X(damage_force_time, VSC_KEY_KIND_POSITIVE, FIELD(damage.force_time_product), 0, 0, "N s", CORE, \
    "the pinch integrated over a hold's time that bruises the wall fully (histological damage past 300 N s: " \
    "Barrie et al., Surg Endosc 2018, porcine colon)") \
  X(damage_tear_strain, VSC_KEY_KIND_POSITIVE, FIELD(damage.tear_strain), 0, 0, "-", CORE, \
    "a segment between control points stretched past this strain tears (human small intestine fails at " \
    "140 %: Egorov et al., J Biomech 2002)") \
  X(young_modulus, VSC_KEY_KIND_POSITIVE, FIELD(young_modulus), 0, 0, "Pa", DERIVED("none"), \
    "material: sets `stretch_stiffness` = EA / length and `bending_rigidity` = EI, and turns the bend " \
    "springs and global term off by default (see [material parameters](validation.md#material-parameters))") \
  X(wall_thickness, VSC_KEY_KIND_POSITIVE, FIELD(wall_thickness), 0, 0, "m", DERIVED("solid"), \
    "tube wall (at most `radius`) for A and I: with `young_modulus`, EA and EI; with a tapered `radius`, " \
    "how the springs scale along the tube. Needs one of the two") \
  X(bending_rigidity, VSC_KEY_KIND_NONNEGATIVE, FIELD(rod.bending_rigidity), 0, 0, "N m^2", DERIVED("E I, else 0"), \
    "EI of the curvature bending energy") \
  X(clamped, VSC_KEY_KIND_CHOICE, FIELD(clamped), 0, 0, "-", VALUE("none"), \
    "the end held in place and in direction (its initial tangent). With a `bending_rigidity` (or " \
    "`young_modulus`) the end control point is pinned and a clamp term (2 EI / l0)(1 - t . e / abs(e)) " \
    "holds the end spring edge e along t; without one (the paper's springs) the neighbouring control " \
    "point is pinned too") \
  X(divergence_retries, VSC_KEY_KIND_COUNT, FIELD(step.retries), 0, 10, "count", CORE, \
    "a diverged step is retried from its start with twice the substeps, up to this many times (4: up to " \
    "16x) and at most 1024 substeps, before it is restored") \
  X(sleep, VSC_KEY_KIND_COUNT, FIELD(step.sleep.enabled), 0, 1, "0 or 1", VALUE("0"), \
    "control points at rest (slower than `sleep_speed` on average over `sleep_time`) and untouched stop " \
    "being integrated until a moving neighbour within 3 points, a geom or part of the intestine moving " \
    "against them, a jaw, a change in their load, of gravity or a reset wakes them (see " \
    "[sleeping](model.md#sleeping)); it stops what creeps slower than `sleep_speed`, so it is off unless " \
    "a scene turns it on where it is measured: the shipped cavity and its tasks do. Needs `mass_matrix` " \
    "`lumped` and an explicit integrator") \
  X(sleep_speed, VSC_KEY_KIND_NONNEGATIVE, FIELD(step.sleep.rest_speed), 0, 0, "m/s", CORE, \
    "a control point whose mean speed over `sleep_time` is below this is at rest (it stays within " \
    "`sleep_speed` x `sleep_time` of where its rest began); a neighbour moving at this speed over a step " \
    "wakes it, and a geom moving at 1 % of it; 0: nothing sleeps") \
  X(sleep_time, VSC_KEY_KIND_POSITIVE, FIELD(step.sleep.rest_time), 0, 0, "s", CORE, \
    "at rest this long, a control point sleeps") \
  X(mass_matrix, VSC_KEY_KIND_CHOICE, FIELD(rod.lumped_mass), 0, 0, "-", CORE, \
    "`lumped` (each row of the band matrix summed on its diagonal: same total mass, gravity and rest " \
    "shapes; highest frequencies 1.4x lower, so 3 leapfrog substeps per 2 ms where `consistent` needs 5 " \
    "on the fall; every validation case within its tolerance) or `consistent` (the paper's M_ij = m " \
    "integral b_i b_j ds, band 7)") \
  X(marked_band, VSC_KEY_KIND_VECTOR, FIELD(marked_band), 0, 2, "m", DERIVED("none"), \
    "a stretch of the axis drawn in its own colour (blue) by MuJoCo's renderer: from, to, along the rest " \
    "axis (0 <= from < to <= `length`); the band a task marks, e.g. to be grasped") \
  X(rgba, VSC_KEY_KIND_VECTOR, FIELD(rgba), 0, 4, "-", VALUE("0.85 0.45 0.45 1"), \
    "the colour MuJoCo's renderer and the meshcat viewer draw the intestine in: red, green, blue, " \
    "opacity, each in [0, 1] (e.g. to tell a colon from the small bowel)") \
  X(draw_capsules, VSC_KEY_KIND_COUNT, FIELD(draw_capsules), 1, 100000, "count", \
    DERIVED("one per spring sample interval (`samples_per_segment` x (n - 1))"), \
    "capsules MuJoCo's renderer draws along the axis, evenly spaced in the rest abscissa: fewer draw " \
    "faster (a camera without a GPU spends its time on geometry, not pixels); drawing only, the " \
    "physics is the same")

#endif  // VISCERA_PLUGIN_KEYS_H
