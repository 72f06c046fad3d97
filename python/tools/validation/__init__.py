"""Validation cases, one folder each (its analytic reference in its docstring, the case at each
resolution of its convergence study, CASES naming it), laid out as PyElastica lays out its
examples; studies of the integrators and the invariants; the peers. Run them all with
python/tools/validate.py, which writes docs/validation/results.json and the charts.
"""

import importlib
import pathlib

HERE = pathlib.Path(__file__).resolve().parent


def all_cases() -> dict:
    """Every case of every folder with a case.py: name -> (function of n control points, resolutions)."""
    cases: dict = {}
    for folder in sorted(path.parent for path in HERE.glob("*/case.py")):
        cases.update(importlib.import_module(f"validation.{folder.name}.case").CASES)
    return cases
