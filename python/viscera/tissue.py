"""Every tissue parameter the tasks use: its value, the range the tasks draw it from, its unit, and
the measurement behind it, or that none was found and what chose the value instead.

    from viscera.tissue import PARAMETERS, drawn
    drawn("mass_per_length")          # (0.30, 0.60): the tasks' range, in the parameter's unit

One table, read three ways: the tasks' randomisation draws its ranges from it
(viscera.tasks.scene), the docs print it (docs/tables.py `tissue_parameters`, in
docs/tasks.md), and the plugin's own defaults that it names are checked against it
(tests/python/test_tissue.py). Values are the box abdomen's (assets/scenes/abdomen.xml); the
anatomical abdomen's differ where docs/cavity.md says.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One tissue parameter (see the module doc)."""

    name: str                  # what the tasks call it
    keys: str                  # the intestine config keys it sets
    value: float               # the scene's value, in `unit`
    drawn: tuple[float, float] | None  # the tasks' range, drawn uniformly per episode; None: fixed
    unit: str
    measured: str              # what was measured, on what, the figure, the source; "none found" if none
    chosen_by: str             # how the value and range were chosen


PARAMETERS: tuple[Parameter, ...] = (
    Parameter("mass_per_length", "mass (x length)", 0.49, (0.30, 0.60), "kg/m",
              "adult small intestine, wall 0.60 to 0.65 kg and contents 0.28 to 0.35 kg over about 3 m: about "
              "0.3 kg/m (ICRP Publication 89, 2002)",
              "from the measured 0.3 kg/m up to a bowel full of fluid: a tube of water of the 12.5 mm radius is "
              "0.49 kg/m, the scene's value (density 1000 kg/m^3)"),
    Parameter("radius", "radius", 12.5, None, "mm",
              "lumen diameter in vivo, jejunum 24.5 +- 4.2 mm, terminal ileum 18.7 +- 3.6 mm (MR enterography, "
              "Cronin et al.): radii 12.3 and 9.4 mm",
              "the box abdomen's bowel: the jejunum's, one radius along it; the anatomical abdomen's tapers "
              "from 12.25 mm at the duodenojejunal flexure to 9.35 mm at the ileocaecal junction"),
    Parameter("springs", "stretch_stiffness, bend_stiffness", 1.0, (0.7, 1.5), "x default",
              "porcine small intestine, biaxial, low-strain longitudinal modulus 307 +- 30 kPa, 2.21 MPa at "
              "high strain (Terry, Wang, Schoen, Rentschler, IJECB 2014)",
              "the default stretch springs, EA = 40 N, are a 2 mm wall of the 12.5 mm tube at 0.28 MPa; one "
              "factor scales the stretch and bend springs, 0.7 to 1.5: 0.20 to 0.42 MPa around the low-strain "
              "figure (the bowel is handled at small strain)"),
    Parameter("wall_thickness", "(in EA above); wall_thickness", 2.0, None, "mm",
              "small bowel wall 1.5 +- 0.5 mm (MR enterography, Cronin et al.)",
              "2 mm, within one standard deviation; the anatomical abdomen's tapered bowel sets it, and its "
              "springs scale along the taper as a 2 mm wall's section"),
    Parameter("bending", "bend_stiffness", 4.0, None, "N x m / length",
              "none found for the whole bowel's bending stiffness (a thin wall buckles and the contents fill it)",
              "the plugin's default bend springs, 4 N / length (1 N/m at 4 m), scaled by the springs' factor"),
    Parameter("damping", "damping", 1.0, None, "1/s",
              "none found",
              "the plugin's default mass-proportional damping: free velocities decay at 1/s"),
    Parameter("mesentery_stiffness", "mesentery_stiffness", 20.0, (10.0, 40.0), "N/m",
              "none found as a per-tether stiffness; the mesentery's membrane has been tested in tension, not "
              "as the tether the model needs",
              "keeps loops within their mesentery's reach of its root while the tools move them"),
    Parameter("mesentery_depth", "mesentery_length", 0.18, (0.15, 0.21), "m",
              "the small bowel mesentery's depth, root to bowel, about 15 to 20 cm in adults (anatomy texts)",
              "the measured span"),
    Parameter("friction_tools_walls", "friction", 0.3, (0.2, 0.4), "-",
              "mesothelium on mesothelium 0.034 to 0.078, speed-dependent (Loring et al., J Biomech 2005); the "
              "lumen on steel 0.007 to 0.054 (Tribology Letters 51:377, 2013); none found for the serosa on "
              "steel",
              "not the measured figures: the penalty friction also stands in for the drag of the surrounding "
              "tissue and fluid the model leaves out. The tasks at the measured 0.03 to 0.08 were not tried: to "
              "revisit with a measurement of that drag"),
    Parameter("friction_bowel_on_bowel", "self_friction", 0.3, (0.2, 0.4), "-",
              "mesothelium on mesothelium 0.034 to 0.078 (Loring et al., J Biomech 2005)",
              "as for the walls: higher than measured, for the same reason"),
    Parameter("grasp_friction", "grasp_friction", 0.8333, None, "-",
              "pig small bowel pulled at 5 N from laparoscopic jaws needed 3.0 +- 0.4 N of pinch (Heijnsdijk et "
              "al., Surg Endosc 2004)",
              "calibrated: 5 N / (2 faces x 3.0 N); validation.md#against-the-organ checks it through the stack"),
    Parameter("grasp_slip_force", "grasp_slip_force", 5.0, None, "N",
              "the pull of Heijnsdijk's experiment, 5 N; no slip measurement at higher pulls found",
              "caps a hold at the largest pull measured"),
    Parameter("perforation_pinch", "damage_perforation_pinch", 10.3, None, "N",
              "human small bowel perforated at a pinch of 10.3 +- 2.9 N, pig 11.0 +- 2.5 N (Heijnsdijk, de Visser, "
              "Dankelman, Gouma, Surg Endosc 2003)",
              "the human mean"),
    Parameter("damage_force_time", "damage_force_time", 300.0, None, "N s",
              "grasped porcine colon showed histological damage past a force-time product of 300 N s (Barrie et "
              "al., Surg Endosc 2018); none found for small bowel",
              "the colon's figure, counting every pinch from zero: on the safe side"),
    Parameter("tear_strain", "damage_tear_strain", 1.4, None, "-",
              "human small intestine failed at about 140 % strain and 0.9 MPa (Egorov et al., J Biomech 2002)",
              "the measured failure strain"),
)

_BY_NAME = {p.name: p for p in PARAMETERS}


def parameter(name: str) -> Parameter:
    """The parameter called `name` (KeyError naming the known ones otherwise)."""
    if name not in _BY_NAME:
        raise KeyError(f"no tissue parameter {name!r}; the table has {', '.join(_BY_NAME)}")
    return _BY_NAME[name]


def drawn(name: str) -> tuple[float, float]:
    """The range the tasks draw `name` from, in its unit."""
    bounds = parameter(name).drawn
    if bounds is None:
        raise ValueError(f"tissue parameter {name!r} is not drawn: the tasks keep {parameter(name).value}")
    return bounds
