"""Arithmetic that gives the same bits on every x86-64 CPU, for what feeds an action or an
observation: a seed and a scripted policy play the same episode, bit for bit, on any machine.

Why it exists: the physics is deterministic, but one last-bit difference in an action grows, in
the bowel's contacts, into another episode (clear_area seed 0 succeeded at 29.36 s with numpy's
AVX-512 kernels and at 24.54 s without them). Measured sources, all picked per CPU at run time:
- numpy's transcendental ufuncs: np.arcsin, np.arctan2 (and the like) on float64 run SVML kernels
  where the CPU has AVX-512 and glibc's libm elsewhere; they differ in the last bit for a few
  inputs in a thousand (the first difference of clear_area seed 0: the grasper's yaw, np.arcsin
  in Tools.coordinates, played at step 98);
- BLAS: np.linalg.norm of a vector without `axis` is sqrt(x.dot(x)), and np.dot, `@` and
  np.matmul on float64 call OpenBLAS, whose kernel (its summation order, FMA or not) depends on
  the CPU (OPENBLAS_CORETYPE): even a 2-vector's norm differs.

So, on those paths:
- norms and dot products are the elementwise products summed along the last axis (`norm`,
  `norms`, `dot`): numpy's own add reduction, the same order on every instruction set, then
  np.sqrt (correctly rounded); never np.linalg.norm without `axis`, np.dot, `@`, np.einsum;
- transcendentals of scalars go through Python's `math` on floats, never numpy's ufuncs;
- elementwise + - * /, np.sqrt, comparisons, np.clip, min, max, np.sum, np.mean and np.cumsum
  are exact or done in a fixed order: they need nothing.
tests/python/test_machine_independence.py plays the tasks' scripted episodes with numpy's SIMD
dispatch and OpenBLAS's kernel switched to older CPUs', and keeps such calls out of the policies.

Not bit-exact even so: glibc's libm, which `math` calls, has FMA variants that it picks on CPUs
with FMA and AVX2 (GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA turns them off); they differ in the
last bit for about one input in 1500. MuJoCo and the plugin call the same libm (sin, cos, exp,
pow...), so with the same actions the physics itself already differs there (clear_area seed 0:
MuJoCo's kinematics of a tool's hinges, in the 64th control step): an episode is the same on
every CPU on which the same glibc picks the same variants (all those with FMA and AVX2,
x86-64-v3: Intel since 2013, AMD since 2015), not across that line.
"""

from __future__ import annotations

import math

import numpy as np


def dot(a, b) -> np.ndarray | float:
    """The dot product along the last axis of `a` and `b` (broadcast): what `a @ b` is for
    vectors, and `matrix @ vector` row by row, without BLAS."""
    product = np.asarray(a, dtype=float) * np.asarray(b, dtype=float)
    total = product.sum(axis=-1)
    return float(total) if total.ndim == 0 else total


def norms(a) -> np.ndarray:
    """The Euclidean norm of each vector along the last axis of `a` (np.linalg.norm(a, axis=-1))."""
    a = np.asarray(a, dtype=float)
    return np.sqrt((a * a).sum(axis=-1))


def norm(v) -> float:
    """The Euclidean norm of the vector `v` (np.linalg.norm(v)), without BLAS."""
    v = np.asarray(v, dtype=float).ravel()
    return math.sqrt(float((v * v).sum()))
