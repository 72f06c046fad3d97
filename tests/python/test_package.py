"""The package's front doors: import, MJCF builders, the CLI."""

import pathlib
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import viscera

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = ROOT / "assets" / "scenes" / "fall_on_plane.xml"


def test_import_loads_the_plugin_once():
    from viscera import _library
    assert _library.load() == viscera.PLUGIN_LIBRARY  # idempotent: no second registration
    assert "length" in viscera.attribute_names() and "pinned" in viscera.attribute_names()


def test_dm_control_mjcf_builder_compiles_and_simulates():
    from dm_control import mjcf
    root = mjcf.RootElement(model="built")
    root.worldbody.add("geom", type="plane", size=[2, 2, 0.1])
    viscera.add_to_mjcf(root, "gut", length=1.0, control_points=30, shape="line", start=[0, 0, 0.2])
    physics = mjcf.Physics.from_mjcf_model(root)
    gut = viscera.intestine(physics.model.ptr, "gut")
    assert gut.control_count == 30
    while physics.data.time < 1.5:
        physics.step()
    assert abs(gut.positions(physics.data.ptr)[:, 2].mean() - 0.0125) < 1e-3  # fell and rests on the plane


def test_default_scene_settles_on_the_plane():
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    assert (gut.control_count, gut.rest_length) == (250, 4.0)
    while data.time < 3.0:
        mujoco.mj_step(model, data)
    axis = gut.axis_points(data, 2000)
    assert axis[:, 2].max() < 0.05  # everything came down from 0.3 m
    assert axis[:, 2].min() > 0.0125 - 0.005  # and nothing went through the floor
    assert abs(gut.length(data) - 4.0) < 0.04
    assert gut.divergence_count(data) == 0


def test_cli_runs_the_default_scene_and_renders(tmp_path):
    png = tmp_path / "out.png"
    result = subprocess.run([sys.executable, "-m", "viscera", "run", str(SCENE), "--duration", "0.5", "--quiet",
                             "--png", str(png)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert result.returncode == 0, result.stderr
    for words in ("simulated time   0.500 s", "real-time factor", "length", "lowest axis point"):
        assert words in result.stdout, result.stdout
    import matplotlib.image
    image = matplotlib.image.imread(png)
    assert image.shape[:2] == (600, 800)
    assert image[..., :3].std() > 0.02  # a picture, not a blank frame
    pink = (image[..., 0] > 0.7) & (image[..., 1] < 0.6) & (image[..., 2] < 0.6)
    assert pink.sum() > 200  # the intestine is in it


def test_cli_rejects_bad_duration(tmp_path):
    result = subprocess.run([sys.executable, "-m", "viscera", "run", str(SCENE), "--duration", "-1"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode != 0 and "--duration" in result.stderr


def test_benchmark_runs_both_peers(tmp_path):
    import bench_fall as bench
    result = bench.run(duration=0.05, runs=1, quiet=True)
    assert set(result["peers"]) == {"viscera", "viscera_noself", "flexcomp", "flexcomp_self"}
    for peer in result["peers"].values():
        assert np.isfinite(peer["wall_s_per_sim_s_median"]) and peer["wall_s_per_sim_s_median"] > 0
    # the piled chains really are piles: contacts grow in proportion to the spheres
    rows = result["collision_pass"]["rows"]
    assert rows[-1]["contacts"] > rows[0]["contacts"] * rows[-1]["spheres"] / rows[0]["spheres"] / 3


def test_dm_control_render_shows_the_intestine():
    from dm_control import mujoco as dm_mujoco
    physics = dm_mujoco.Physics.from_xml_path(str(SCENE))
    image = physics.render(height=240, width=320, camera_id="overview")
    pink = (image[..., 0] > 180) & (image[..., 1] < 150) & (image[..., 2] < 150)
    assert pink.sum() > 100  # the plugin's visualize callback drew it


def test_intestines_skips_other_plugins_and_reports_resolved_defaults():
    xml = f"""<mujoco>
      <extension><plugin plugin="mujoco.elasticity.cable"/></extension>
      {viscera.extension_xml("gut", length=2.0, density=900)}
      <worldbody>
        <composite type="cable" curve="s" count="6 1 1" size="1" initial="none">
          <plugin plugin="mujoco.elasticity.cable"><config key="twist" value="1e6"/><config key="bend" value="1e9"/></plugin>
          <joint kind="main" damping=".015"/><geom type="capsule" size=".005" density="1"/>
        </composite>
      </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    assert model.nplugin >= 2
    guts = viscera.intestines(model)
    assert [g.name for g in guts] == ["gut"]
    gut = guts[0]
    assert (gut.rest_length, gut.radius, gut.control_count, gut.samples_per_segment) == (2.0, 0.0125, 250, 2)
    assert gut.sphere_count == 161
    assert gut.mass == pytest.approx(900 * np.pi * 0.0125**2 * 2.0)


def _defined_at_top(module) -> set[str]:
    """The names a module's own source defines at its top level (functions, classes, constants)."""
    import ast
    import inspect
    names = set()
    for node in ast.parse(inspect.getsource(module)).body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return names


def test_the_learning_interfaces_keep_their_old_names():
    """viscera.batch, viscera.vector and viscera.gymnasium_env re-export what viscera.scale's
    modules define (one home for the learning and scale-out interfaces): every public name, the
    very same objects, as documented re-exports rather than module aliases."""
    import viscera.batch
    import viscera.gymnasium_env
    import viscera.scale.batch
    import viscera.scale.gym_env
    import viscera.scale.vector
    import viscera.vector
    for old, new in ((viscera.batch, viscera.scale.batch), (viscera.vector, viscera.scale.vector),
                     (viscera.gymnasium_env, viscera.scale.gym_env)):
        assert old is not new and old.__doc__
        public = {name for name in _defined_at_top(new) if not name.startswith("_")}
        assert public <= set(old.__all__), (old.__name__, public - set(old.__all__))
        for name in old.__all__:
            assert getattr(old, name) is getattr(new, name)


def test_the_library_imports_no_tool_dependencies_and_ships_no_tools():
    """Importing viscera, loading and stepping a task and making its gymnasium env import none of
    matplotlib, tqdm, pandas or ray; the benchmarks, validation, soak and settle are tools in the
    checkout (python/tools), not modules of the installed library."""
    code = ("import sys, importlib.util, viscera, viscera.tasks, viscera.scale.gym_env\n"
            "env = viscera.tasks.load('clear_area', seed=0)\n"
            "env.reset()\n"
            "env.step(env.action_spec().generate_value())\n"
            "viscera.scale.gym_env.TaskEnv('clear_area', seed=0).reset(seed=0)\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'matplotlib', 'tqdm', 'pandas', 'ray'}))\n"
            "print([m for m in ('bench', 'bench_cavity', 'bench_rollout', 'bench_scale', 'validate', 'peers',\n"
            "                   'references', 'settle', 'soak')\n"
            "       if importlib.util.find_spec('viscera.' + m) is not None])\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split("\n")[:2] == ["[]", "[]"], result.stdout
