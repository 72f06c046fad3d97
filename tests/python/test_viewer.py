"""The skin and the meshcat viewer, as a person would see them: in headless Chromium."""

import pathlib
import shutil
import subprocess
import sys
import tempfile

import matplotlib.image
import mujoco
import numpy as np
import pytest

import viscera
from viscera.viewer import MeshcatViewer

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = ROOT / "assets" / "scenes" / "fall_on_plane.xml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium (.ci/run installs it)")


def screenshot(url: str, path: pathlib.Path, virtual_ms: int = 6000) -> np.ndarray:
    """Render `url` in headless Chromium (flags from NOTES) and return the RGB pixels."""
    command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
               "--disable-component-update", "--disable-sync", "--no-first-run",
               f"--user-data-dir={tempfile.mkdtemp()}", f"--screenshot={path}", "--window-size=800,600",
               f"--virtual-time-budget={virtual_ms}", url]
    subprocess.run(command, capture_output=True, timeout=180, check=True)
    return matplotlib.image.imread(path)[..., :3]


def intestine_pixels(image: np.ndarray) -> np.ndarray:
    """Mask of the intestine's colour (0.85, 0.45, 0.45), lit or shaded."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (r > 0.45) & (r > 1.4 * g) & (r > 1.4 * b) & (np.abs(g - b) < 0.12)


def settled_scene(seconds: float = 2.0):
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    data = mujoco.MjData(model)
    while data.time < seconds:
        mujoco.mj_step(model, data)
    return model, data


def test_skin_is_closed_outward_and_round():
    model, data = settled_scene(0.5)
    vertices, normals, triangles = viscera.skin(model, data)
    gut = viscera.intestine(model)
    rings = (gut.control_count - 1) * 4 + 1
    assert vertices.shape == (rings * 16 + 2, 3) and triangles.shape == (2 * rings * 16, 3)
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0  # positive iff facing outwards
    assert volume == pytest.approx(np.pi * gut.radius**2 * gut.rest_length, rel=0.05)
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()  # closed: every edge shared by two triangles
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)


def web_port(url: str) -> int:
    return int(url.split(":")[2].split("/")[0])


def listening_addresses(port: int) -> set:
    """Local addresses listening on `port`, from /proc/net/tcp and tcp6 (state 0A)."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in pathlib.Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            address, hex_port = fields[1].rsplit(":", 1)
            if fields[3] == "0A" and int(hex_port, 16) == port:
                found.add(address)
    return found


def test_viewer_serves_on_loopback_only():
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    with MeshcatViewer(model) as viewer:
        assert viewer.url.startswith("http://127.0.0.1:")
        assert listening_addresses(web_port(viewer.url)) == {"0100007F"}  # 127.0.0.1, nothing else


@needs_chromium
def test_live_view_shows_the_intestine(tmp_path):
    model, data = settled_scene()
    with MeshcatViewer(model) as viewer:
        viewer.update(data)
        shown = intestine_pixels(screenshot(viewer.url, tmp_path / "shown.png"))
        viewer.set_intestines_visible(False)
        hidden = intestine_pixels(screenshot(viewer.url, tmp_path / "hidden.png"))
    assert shown.sum() > 2000, shown.sum()
    rows, cols = np.nonzero(shown)
    assert 150 < rows.mean() < 450 and 200 < cols.mean() < 600  # in the middle of the frame, on the floor
    assert hidden.sum() < 0.01 * shown.sum()


@needs_chromium
def test_recording_plays_offline(tmp_path):
    """A recorded page plays offline, one frame at a time: the first second shows the
    intestine shifted left, the next one shifted right."""
    model, data = settled_scene(1.0)
    gut = viscera.intestine(model)
    settled = gut.positions(data).copy()
    page = tmp_path / "run.html"
    with MeshcatViewer(model) as viewer:
        for k in range(20):  # 2 s at 10 frames per second
            gut.positions(data)[:] = settled + [0.0, -0.4 if k < 10 else 0.4, 0.0]
            viewer.record(data)
        size = viewer.save(str(page), fps=10.0)
    assert size < 5e6
    early = intestine_pixels(screenshot(page.as_uri(), tmp_path / "early.png", virtual_ms=500))
    late = intestine_pixels(screenshot(page.as_uri(), tmp_path / "late.png", virtual_ms=1600))
    assert early.sum() > 500 and late.sum() > 500
    assert 0.5 < early.sum() / late.sum() < 2.0  # one copy each time, not an accumulation
    assert np.nonzero(early)[1].mean() + 50 < np.nonzero(late)[1].mean()  # left, then right


def test_cli_live_viewer_and_recording(tmp_path):
    page = tmp_path / "cli.html"
    result = subprocess.run([sys.executable, "-m", "viscera", "run", str(SCENE), "--duration", "0.3", "--quiet",
                             "--viewer", "meshcat", "--record", str(page)], capture_output=True, text=True,
                            cwd=tmp_path, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "meshcat viewer: http://127.0.0.1:" in result.stdout
    assert "recording" in result.stdout and page.stat().st_size > 10_000


def test_viewer_follows_a_dm_control_loop():
    from dm_control import mujoco as dm_mujoco
    physics = dm_mujoco.Physics.from_xml_path(str(SCENE))
    with MeshcatViewer(physics.model.ptr) as viewer:
        for _ in range(3):
            for _ in range(10):
                physics.step()
            viewer.update(physics.data.ptr)
            viewer.record(physics.data.ptr)
        assert len(viewer.frames) == 3


def test_capsule_mesh_is_a_tube_with_round_ends():
    from viscera.viewer import _capsule
    mesh = _capsule(0.01, 0.05)
    v = np.asarray(mesh.vertices)
    radial = np.hypot(v[:, 0], v[:, 1])
    assert v[:, 2].min() == pytest.approx(-0.06) and v[:, 2].max() == pytest.approx(0.06)
    middle = np.abs(v[:, 2]) <= 0.05 + 1e-12  # the cylindrical part spans the whole half-length
    assert radial[middle].max() == pytest.approx(0.01) and middle.sum() >= 2 * 24


def test_viewer_that_cannot_start_raises_and_leaves_no_server():
    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    with pytest.raises(RuntimeError, match="meshcat server"):
        MeshcatViewer(model, host="300.1.1.1")  # not an address
    running = []
    for entry in pathlib.Path("/proc").iterdir():  # no pgrep needed
        try:
            if entry.name.isdigit() and b"viscera.meshcat_server" in (entry / "cmdline").read_bytes():
                status = (entry / "status").read_text()
                if "State:\tZ" not in status:
                    running.append(entry.name)
        except OSError:
            continue
    assert running == []
