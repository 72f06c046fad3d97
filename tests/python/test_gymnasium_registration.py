"""gymnasium ids: registered by `import viscera`, whatever the import order, without importing gymnasium."""

import subprocess
import sys

import pytest

from viscera.gymnasium_ids import ENV_IDS


def run_python(code: str) -> subprocess.CompletedProcess:
    """`code` in a fresh interpreter (the registry and sys.modules are per process)."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("imports", ["import viscera; import gymnasium as gym",
                                     # an "is it installed" lookup first must not use up the registration
                                     "import viscera, importlib.util; importlib.util.find_spec('gymnasium'); "
                                     "import gymnasium as gym",
                                     "import gymnasium as gym; import viscera",
                                     "import gymnasium as gym; import viscera; gym.register_envs(viscera)"])
def test_ids_are_registered_by_importing_viscera(imports):
    result = run_python(f"{imports}\nenv = gym.make({ENV_IDS['clear_area']!r})\n"
                        "observation, info = env.reset(seed=0)\n"
                        "print(env.spec.id, env.observation_space.contains(observation))")
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == [ENV_IDS["clear_area"], "True"]


def test_module_prefixed_id_imports_viscera():
    result = run_python(f"import gymnasium as gym\nenv = gym.make('viscera:{ENV_IDS['clear_area']}')\n"
                        "print(type(env.unwrapped).__module__)")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "viscera.scale.gym_env"


def test_import_viscera_does_not_import_gymnasium_or_the_tasks():
    result = run_python("import sys, viscera\n"
                        "print(sorted(m for m in ('gymnasium', 'dm_control', 'viscera.tasks') if m in sys.modules))")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_viscera_works_without_gymnasium():
    """gymnasium absent: import viscera and simulate; importing gymnasium fails as it would without viscera."""
    hide = ("import importlib.abc, sys\n"
            "class Hide(importlib.abc.MetaPathFinder):\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            "        if name.split('.')[0] == 'gymnasium': raise ModuleNotFoundError(name)\n"
            "sys.meta_path.insert(0, Hide())\n")
    use = ("import mujoco, viscera\n"
           "model = mujoco.MjModel.from_xml_string('<mujoco>' + viscera.extension_xml('gut', length=0.5, "
           "control_points=10, shape='line') + '</mujoco>')\n"
           "data = mujoco.MjData(model); mujoco.mj_step(model, data); print('stepped')\n"
           "try:\n    import gymnasium\nexcept ModuleNotFoundError:\n    print('no gymnasium')\n")
    result = run_python(hide + use)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["stepped", "no", "gymnasium"]
