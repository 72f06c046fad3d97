"""Loads and steps the MJCF scenes test_fuzz.py sends, in a process of its own.

Protocol: one JSON object a line on stdin, {"xml": ..., "steps": ...}; one JSON
reply a line on the original stdout: {"outcome": "refused", "message": ...}
(a ValueError at load) or {"outcome": "stepped", "non_finite": [...]} naming
the arrays that held a NaN or Inf after the steps (empty when all are finite).
MuJoCo's and the plugin's own prints go to stderr, so they cannot corrupt the
replies. A crash or a hang ends or stalls this process; the parent sees it
and reports the input that did it.
"""

import json
import os
import sys

import mujoco
import numpy as np

import viscera

SKIN_VERTEX_LIMIT = 2_000_000  # skins past this are a user's deliberate choice, not a load check


def run(xml: str, steps: int) -> dict:
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as error:
        return {"outcome": "refused", "message": str(error)}
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    for _ in range(steps):
        if model.nu:
            data.ctrl[:] = rng.uniform(-1.0, 1.0, model.nu)
        mujoco.mj_step(model, data)
    arrays = {"qpos": data.qpos, "qvel": data.qvel, "plugin_state": data.plugin_state,
              "sensordata": data.sensordata}
    # the plugin's other outputs: axis points, skin and the scene geoms it draws
    for gut in viscera.intestines(model):
        arrays[f"{gut.name} axis"] = gut.axis_points(data, 200)
        rings = int(gut.config.get("skin_rings_per_segment", 4))
        ring_points = int(gut.config.get("skin_ring_points", 16))
        if gut.control_count * rings * ring_points < SKIN_VERTEX_LIMIT:
            vertices, normals, _ = viscera.skin(model, data, gut.name)
            arrays[f"{gut.name} skin"] = vertices
            arrays[f"{gut.name} normals"] = normals
    scene = mujoco.MjvScene(model, maxgeom=2000)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, mujoco.MjvCamera(),
                           mujoco.mjtCatBit.mjCAT_ALL, scene)
    arrays["scene geoms"] = np.array([scene.geoms[i].pos for i in range(scene.ngeom)]).reshape(-1, 3)
    return {"outcome": "stepped", "non_finite": [k for k, v in arrays.items() if not np.isfinite(v).all()]}


def main() -> None:
    replies = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # everything else printed to stdout (MuJoCo warnings) goes to stderr
    sys.stdout = sys.stderr
    replies.write(json.dumps({"outcome": "ready"}) + "\n")
    for line in sys.stdin:
        job = json.loads(line)
        replies.write(json.dumps(run(job["xml"], job["steps"])) + "\n")


if __name__ == "__main__":
    main()
