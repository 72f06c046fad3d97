"""Pixel observations (viscera.pixels, tasks.load(pixels=True)): what the laparoscope sees is the
intestine where the physics puts it, labelled, coloured and deterministic; several cameras in
threads, copies and pickles render the same; nothing leaks a traceback at exit."""

from __future__ import annotations

import copy
import ctypes.util
import os
import pathlib
import pickle
import subprocess
import sys
import threading

import numpy as np
import pytest
from PIL import Image

import viscera.tasks
from viscera import pixels

REFERENCE = pathlib.Path(__file__).parent / "reference" / "laparoscope_clear_area_seed0.png"


@pytest.fixture(scope="module")
def frame():
    """clear_area, seed 0, after its reset: the environment and its first observation at 128 x 96."""
    env = viscera.tasks.load("clear_area", seed=0, pixels=True, width=128, height=96)
    step = env.reset()
    yield env, step.observation
    viscera.tasks.close(env)


def unproject(physics, depth: np.ndarray, rows: np.ndarray, columns: np.ndarray, camera: str = "laparoscope"):
    """World points (m) of pixels from their depth along the camera's axis, through the camera's
    intrinsics (vertical field of view, pixel centres) and pose (MuJoCo: x right, y up, looking
    along -z)."""
    height, width = depth.shape
    focal = 0.5 * height / np.tan(np.radians(physics.named.model.cam_fovy[camera]) / 2.0)  # pixels
    d = depth[rows, columns].astype(float)
    in_camera = np.stack([(columns + 0.5 - 0.5 * width) / focal * d, -(rows + 0.5 - 0.5 * height) / focal * d, -d],
                         axis=1)
    rotation = physics.named.data.cam_xmat[camera].reshape(3, 3)
    return physics.named.data.cam_xpos[camera] + in_camera @ rotation.T


def distance_to_axis(physics, points: np.ndarray) -> np.ndarray:
    """Each point's distance (m) to the intestine's axis, sampled every 0.6 mm."""
    gut = physics.intestine()
    axis = gut.axis_points(physics.data.ptr, 5000)
    out = np.empty(len(points))
    for start in range(0, len(points), 512):
        chunk = points[start:start + 512]
        out[start:start + 512] = np.sqrt(((chunk[:, None, :] - axis[None, :, :]) ** 2).sum(-1).min(axis=1))
    return out


def test_observations_have_the_documented_shapes_and_types(frame):
    env, observation = frame
    assert observation["pixels"].shape == (96, 128, 3) and observation["pixels"].dtype == np.uint8
    assert observation["depth"].shape == (96, 128) and observation["depth"].dtype == np.float32
    assert observation["segmentation"].shape == (96, 128) and observation["segmentation"].dtype == np.uint8
    spec = env.observation_spec()
    for key in ("pixels", "depth", "segmentation"):
        assert spec[key].shape == observation[key].shape and spec[key].dtype == observation[key].dtype
    # the laparoscope looks at the bowel-covered floor: mostly intestine, some of the target
    assert np.mean(observation["segmentation"] == pixels.LABELS["intestine"]) > 0.5
    assert np.any(observation["segmentation"] == pixels.LABELS["target"])


def test_intestine_pixels_unproject_onto_the_tube_surface(frame):
    """Every pixel labelled intestine, unprojected with its depth, lies on the tube: its distance
    to the axis is the radius r (12.5 mm) up to the drawing's approximations: 8-sided capsules
    (their faces from r cos(pi/8) = 0.92 r to r) along 1.9 cm chords of the spline (a chord of
    length L on a bend of radius R strays L^2 / 8R from it: 2.2 mm, 0.18 r, on the tightest 2 cm
    bends). Every other pixel lies outside the tube."""
    env, observation = frame
    physics = env.physics
    radius = physics.intestine().radius
    rows, columns = np.nonzero(observation["segmentation"] == pixels.LABELS["intestine"])
    distance = distance_to_axis(physics, unproject(physics, observation["depth"], rows, columns))
    assert distance.min() > 0.6 * radius and distance.max() < 1.25 * radius, (distance.min(), distance.max())
    assert np.mean((distance > 0.74 * radius) & (distance < 1.18 * radius)) > 0.97
    assert 0.88 * radius < np.median(distance) < 1.0 * radius
    rows, columns = np.nonzero(observation["segmentation"] != pixels.LABELS["intestine"])
    outside = distance_to_axis(physics, unproject(physics, observation["depth"], rows, columns))
    assert outside.min() > 0.95 * radius


def test_target_pixels_unproject_onto_the_target_patch(frame):
    env, observation = frame
    physics = env.physics
    rows, columns = np.nonzero(observation["segmentation"] == pixels.LABELS["target"])
    points = unproject(physics, observation["depth"], rows, columns)
    target = physics.target()
    assert np.all(np.abs(points[:, :2] - target[:2]) <= target[3:5] + 0.002)  # within a pixel's footprint
    assert np.allclose(points[:, 2], target[2], atol=0.002)


def test_tools_in_view_are_labelled_and_unproject_onto_their_shafts():
    """Both tools lowered into the laparoscope's view: pixels labelled tool, unprojected, lie on a
    tool's shaft (a 2.5 mm capsule along the line from its trocar) or jaw or paddle, within 6 mm."""
    env = viscera.tasks.load("clear_area", seed=0, pixels=True, width=128, height=96)
    env.reset()
    physics = env.physics
    action = np.zeros(env.action_spec().shape)
    for tool in ("grasper", "retractor"):
        action[physics.model.actuator(f"{tool}_depth").id] = 0.14
    for _ in range(40):
        step = env.step(action)
    observation = step.observation
    rows, columns = np.nonzero(observation["segmentation"] == pixels.LABELS["tool"])
    assert len(rows) > 50
    points = unproject(physics, observation["depth"], rows, columns)
    near = np.full(len(points), np.inf)
    for tool in ("grasper", "retractor"):
        start = physics.named.model.body_pos[f"{tool}_trocar"]
        end = physics.working_point(tool)
        axis = (end - start) / np.linalg.norm(end - start)
        along = np.clip((points - start) @ axis, 0.0, np.linalg.norm(end - start) + 0.02)
        near = np.minimum(near, np.linalg.norm(points - (start + along[:, None] * axis), axis=1))
    assert np.mean(near < 0.006) > 0.95, np.percentile(near, [50, 95, 100])
    viscera.tasks.close(env)


def test_intestine_pixels_have_its_colour_under_the_laparoscope_light(frame):
    """The capsules' colour is (0.85, 0.45, 0.45): lit by white light, red over green stays near
    1.9 and green equals blue; the target is green."""
    _, observation = frame
    rgb = observation["pixels"].astype(float)
    gut = rgb[observation["segmentation"] == pixels.LABELS["intestine"]]
    assert np.median(gut[:, 0]) > 100  # lit, not in the dark
    ratio = np.median(gut[:, 0] / np.maximum(gut[:, 1], 1.0))
    assert 1.6 < ratio < 2.2, ratio
    assert np.median(np.abs(gut[:, 1] - gut[:, 2])) <= 2
    target = rgb[observation["segmentation"] == pixels.LABELS["target"]]
    assert np.all(np.median(target, axis=0)[1] > 2 * np.median(target, axis=0)[[0, 2]])


def test_render_matches_the_stored_reference():
    """The laparoscope's first frame of clear_area seed 0 at 84 x 84 against the stored picture
    (made by this test's own code with `VISCERA_WRITE_REFERENCE=1`), within a tolerance for
    another Mesa's rasterisation."""
    env = viscera.tasks.load("clear_area", seed=0, pixels=True)
    image = env.reset().observation["pixels"]
    viscera.tasks.close(env)
    if "VISCERA_WRITE_REFERENCE" in os.environ:
        REFERENCE.parent.mkdir(exist_ok=True)
        Image.fromarray(image).save(REFERENCE)
    reference = np.asarray(Image.open(REFERENCE).convert("RGB")).astype(int)
    difference = np.abs(image.astype(int) - reference)
    assert difference.mean() < 3.0 and np.mean(difference.max(axis=-1) > 40) < 0.02, difference.mean()


def test_same_seed_same_frames_and_the_physics_is_unchanged_by_pixels():
    """Pixels are drawing only: the state with and without them is the same, bit for bit; the
    same seed gives the same frames."""
    def run(pixels_on: bool):
        env = viscera.tasks.load("grasp_lift", seed=3, pixels=pixels_on, width=32, height=24)
        policy = viscera.tasks.scripted_policy(env)
        step = env.reset()
        for _ in range(20):
            step = env.step(policy(step))
        viscera.tasks.close(env)
        return env.physics.get_state().copy(), step.observation

    state, _ = run(False)
    state_with, first = run(True)
    _, second = run(True)
    assert np.array_equal(state, state_with)
    for key in ("pixels", "depth", "segmentation"):
        assert np.array_equal(first[key], second[key])


def test_render_rgb_is_the_frames_rgb():
    """render_rgb (one draw: gymnasium's render(), the pixel policies' evaluation) gives the RGB of
    render()'s frame, bit for bit, on a moving episode, with segmentation draws in between."""
    env = viscera.tasks.load("grasp_lift", seed=2, pixels=True)
    env.reset()
    camera, action = env.task.camera, np.asarray(env.action_spec().maximum) * 0.5
    for _ in range(3):
        for _ in range(10):
            env.step(action)
        frame = camera.render(env.physics)
        assert np.array_equal(camera.render_rgb(env.physics), frame["pixels"])
        assert frame["pixels"].std() > 0  # a picture, not a blank
    viscera.tasks.close(env)


def test_cameras_in_threads_copies_and_pickles_render_alike():
    """Two environments rendered concurrently from two threads, a deep copy and a pickled copy,
    all give the frames one environment gives alone."""
    def first_frame(env):
        return env.reset().observation["pixels"]

    def frames(env):  # the reset's frame, then five steps' under a fixed action
        out = [first_frame(env)]
        for _ in range(5):
            out.append(env.step(np.full(env.action_spec().shape, 0.1)).observation["pixels"])
        return out

    alone = viscera.tasks.load("clear_area", seed=5, pixels=True)
    expected = frames(alone)
    envs = [viscera.tasks.load("clear_area", seed=5, pixels=True) for _ in range(2)]
    results: list = [None, None]
    barrier = threading.Barrier(2)

    def work(i):
        barrier.wait()  # both render at once
        results[i] = frames(envs[i])

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for result in results:
        assert all(np.array_equal(a, b) for a, b in zip(result, expected, strict=True))
    expected = expected[0]
    viscera.tasks.reseed(alone, 5)
    copied, pickled = copy.deepcopy(alone), pickle.loads(pickle.dumps(alone))
    assert np.array_equal(first_frame(copied), expected)
    assert np.array_equal(first_frame(pickled), expected)
    for env in [alone, copied, pickled, *envs]:
        viscera.tasks.close(env)
    assert first_frame(alone).shape == expected.shape  # a closed camera renders again on demand


def test_bad_pixel_arguments_are_refused_by_name():
    with pytest.raises(ValueError, match="pixels = 'yes'"):
        viscera.tasks.load("grasp_lift", pixels="yes")
    with pytest.raises(ValueError, match="width = 0"):
        viscera.tasks.load("grasp_lift", pixels=True, width=0)
    with pytest.raises(ValueError, match="height = 2.5"):
        viscera.tasks.load("grasp_lift", pixels=True, height=2.5)
    with pytest.raises(ValueError, match="camera = 'nope'.*laparoscope"):
        viscera.tasks.load("grasp_lift", pixels=True, camera="nope")
    with pytest.raises(ValueError, match="width = 0"):  # checked with pixels off too
        viscera.tasks.load("grasp_lift", width=0)


def test_gymnasium_dict_spaces_and_pixels_only():
    import gymnasium as gym
    from viscera.scale.gym_env import TaskEnv

    env = TaskEnv("grasp_lift", seed=0, pixels=True, width=32, height=24)
    observation, _ = env.reset(seed=0)
    assert isinstance(env.observation_space, gym.spaces.Dict) and env.observation_space.contains(observation)
    assert observation["pixels"].shape == (24, 32, 3)
    env.close()
    # flatten=True with pixels: the state entries in one float64 vector beside the images, the
    # vector the state-only environment's observation of the same episode followed by the camera's
    # pose (where it is and its unit line of sight, observed with its pixels)
    flat = TaskEnv("grasp_lift", flatten=True, pixels=True, width=32, height=24)
    state_only = TaskEnv("grasp_lift")
    both, _ = flat.reset(seed=0)
    alone, _ = state_only.reset(seed=0)
    assert list(both) == ["state", "pixels", "depth", "segmentation"] and flat.observation_space.contains(both)
    assert np.array_equal(both["state"][:-6], alone) and np.array_equal(both["pixels"], observation["pixels"])
    pose = both["state"][-6:]
    assert np.array_equal(pose, observation["camera_pose"]) and abs(np.dot(pose[3:], pose[3:]) - 1.0) < 1e-12
    band = observation["band"].reshape(5, 3).mean(axis=0)  # the scope is aimed at the band at the start
    sight = (band - pose[:3]) / np.linalg.norm(band - pose[:3])
    assert np.dot(sight, pose[3:]) > np.cos(np.radians(10.0))
    flat.close()
    state_only.close()
    with pytest.raises(ValueError, match="flatten = True with pixels_only"):
        TaskEnv("grasp_lift", flatten=True, pixels=True, pixels_only=True)
    with pytest.raises(ValueError, match="pixels_only = True needs pixels"):
        TaskEnv("grasp_lift", pixels_only=True)
    with pytest.raises(ValueError, match="pixels_only = 'no'"):
        TaskEnv("grasp_lift", pixels=True, pixels_only="no")
    env = gym.make("viscera/GraspLift-v0", pixels=True, pixels_only=True, width=32, height=24)
    observation, _ = env.reset(seed=1)
    assert list(observation) == ["pixels", "depth", "segmentation"] and env.observation_space.contains(observation)
    observation, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(observation)
    env.close()


def test_vector_envs_in_threads_pass_pixels():
    from viscera.scale import vector

    envs = vector.make("grasp_lift", num_envs=2, seed=0, backend="threads", pixels=True, pixels_only=True,
                       width=32, height=24)
    observations, _ = envs.reset(seed=0)
    assert observations["pixels"].shape == (2, 24, 32, 3)
    observations, *_ = envs.step(np.zeros(envs.action_space.shape))
    assert (observations["segmentation"] == pixels.LABELS["intestine"]).any(axis=(1, 2)).all()
    envs.close()


def test_an_open_camera_at_exit_leaves_no_traceback():
    """Processes with several cameras, some collected, that exit without closing the rest (freed
    at exit) or close one explicitly: each exits 0, in time, with nothing on stderr."""
    code = ("import gc, viscera.tasks\n"
            "envs = [viscera.tasks.load('grasp_lift', seed=s, pixels=True) for s in range(4)]\n"
            "for env in envs: env.reset()\n"
            "env = envs[0]\n"
            "del envs[2:]; gc.collect()  # two cameras freed by collection, two left for exit\n"
            "{close}")
    for close in ("", "viscera.tasks.close(env)"):
        done = subprocess.run([sys.executable, "-c", code.format(close=close)], capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == 0, done.stderr
        assert "Traceback" not in done.stderr and "Error" not in done.stderr, done.stderr


@pytest.mark.skipif(ctypes.util.find_library("OSMesa") is None,
                    reason="needs Mesa's OSMesa (.ci/run installs libosmesa6)")
def test_osmesa_renders_the_reference_too(tmp_path):
    """MUJOCO_GL=osmesa (software rendering without EGL) gives the stored reference frame."""
    code = ("import numpy as np, viscera.tasks\n"
            "env = viscera.tasks.load('clear_area', seed=0, pixels=True)\n"
            "import sys\n"
            "np.save(sys.argv[1], env.reset().observation['pixels'])\n")
    out = tmp_path / "frame.npy"
    env = dict(os.environ, MUJOCO_GL="osmesa", PYOPENGL_PLATFORM="osmesa")
    done = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    image = np.load(out).astype(int)
    reference = np.asarray(Image.open(REFERENCE).convert("RGB")).astype(int)
    difference = np.abs(image - reference)
    assert difference.mean() < 3.0 and np.mean(difference.max(axis=-1) > 40) < 0.02, difference.mean()


@pytest.mark.parametrize("task", viscera.tasks.ALL)
def test_each_episode_aims_the_laparoscope_and_its_light_at_the_tasks_working_point(task):
    """After a reset the working point lies on the laparoscope's axis, in front of it; its light
    shines along that axis; the image's up is cranial (+y)."""
    env = viscera.tasks.load(task, seed=3)
    env.reset()
    physics = env.physics
    named = physics.named.data
    rotation = named.cam_xmat["laparoscope"].reshape(3, 3)  # columns: the camera's x, y, z in the world
    seen = rotation.T @ (env.task.view_point(physics) - named.cam_xpos["laparoscope"])
    assert abs(seen[0]) < 1e-6 and abs(seen[1]) < 1e-6 and seen[2] < -0.05
    np.testing.assert_allclose(named.light_xdir["laparoscope_light"], -rotation[:, 2], atol=1e-6)
    assert rotation[1, 1] > 0.5
