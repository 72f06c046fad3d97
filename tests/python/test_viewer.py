"""The skin and the meshcat viewer, as a person would see them: in headless Chromium."""

import base64
import os
import pathlib
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

import matplotlib.image
import mujoco
import numpy as np
import pytest

import viscera
import viscera.viewer
from viscera.viewer import MeshcatViewer

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = ROOT / "assets" / "scenes" / "fall_on_plane.xml"
ABDOMEN = ROOT / "assets" / "scenes" / "abdomen.xml"
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


@pytest.mark.skipif(not socket.has_ipv6 or not pathlib.Path("/proc/net/tcp6").exists(), reason="no IPv6")
def test_viewer_url_brackets_an_ipv6_host():
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    with MeshcatViewer(model, host="::1") as viewer:
        assert viewer.url.startswith("http://[::1]:")
        with urllib.request.urlopen(viewer.url, timeout=30) as page:  # a URL a browser can open
            assert page.status == 200


@needs_chromium
def test_live_view_shows_the_intestine(tmp_path):
    model, data = settled_scene()
    with MeshcatViewer(model) as viewer:
        viewer.update(data)
        shown = intestine_pixels(screenshot(viewer.url, tmp_path / "shown.png"))
        viewer.set_intestines_visible(False)
        assert viewer.flush() is not None  # the server has it before the browser asks
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



@needs_chromium
def test_a_recording_shorter_than_a_frame_shows_the_intestine(tmp_path):
    """Fewer steps than one recorded frame apart: the first and the final states are recorded."""
    page = tmp_path / "short.html"
    result = subprocess.run([sys.executable, "-m", "viscera", "run", str(SCENE), "--duration", "0.05", "--quiet",
                             "--record", str(page)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert result.returncode == 0, result.stderr
    assert intestine_pixels(screenshot(page.as_uri(), tmp_path / "short.png", virtual_ms=1000)).sum() > 2000

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


def servers_running(owner: int | None = None) -> list[str]:
    """Pids of live viscera.meshcat_server processes started by viewers in process `owner`
    (default: this one), from /proc (no pgrep needed). Others' servers are not ours to judge."""
    running = []
    mark = b"viscera.meshcat_server\0--host\0"
    parent = b"\0--parent\0%d\0" % (os.getpid() if owner is None else owner)
    for entry in pathlib.Path("/proc").iterdir():
        try:
            command = (entry / "cmdline").read_bytes() if entry.name.isdigit() else b""
            if mark in command and parent in command:
                if "State:\tZ" not in (entry / "status").read_text():
                    running.append(entry.name)
        except OSError:
            continue
    return running


def poll(condition, timeout: float = 20.0):
    """The first truthy value of `condition()` within `timeout` s, else its last value."""
    deadline = time.monotonic() + timeout
    while not (value := condition()) and time.monotonic() < deadline:
        time.sleep(0.05)
    return value


def started_servers(monkeypatch) -> list[subprocess.Popen]:
    """The processes viscera.viewer starts from now on in this test (not anyone else's)."""
    started = []

    class Recorded(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            started.append(self)

    monkeypatch.setattr(viscera.viewer.subprocess, "Popen", Recorded)
    return started


def test_viewer_that_cannot_start_raises_and_leaves_no_server(monkeypatch):
    started = started_servers(monkeypatch)
    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    with pytest.raises(RuntimeError, match="meshcat server"):
        MeshcatViewer(model, host="300.1.1.1")  # not an address
    assert len(started) == 1 and started[0].poll() is not None  # its own server: started, and gone


def test_unknown_camera_is_refused_at_construction_naming_the_cameras(monkeypatch):
    started = started_servers(monkeypatch)
    model = mujoco.MjModel.from_xml_path(str(ABDOMEN))
    with pytest.raises(ValueError, match=r"'topp'.*overview, top"):
        MeshcatViewer(model, camera="topp")
    with pytest.raises(ValueError, match="no cameras"):
        MeshcatViewer(mujoco.MjModel.from_xml_string("<mujoco/>"), camera=0)
    assert started == []  # refused before a server was started


OWNER = """
import os, signal, sys, mujoco
from viscera.viewer import MeshcatViewer
viewer = MeshcatViewer(mujoco.MjModel.from_xml_path(sys.argv[1]))
print(viewer.url, viewer._server.pid, os.getpid(), flush=True)
how = sys.argv[2]
if how == "raise":
    raise RuntimeError("the user's script fails")
if how in ("SIGTERM", "SIGKILL"):
    os.kill(os.getpid(), getattr(signal, how))
"""


@pytest.mark.parametrize("how", ["exit", "raise", "SIGTERM", "SIGKILL"])
def test_server_ends_with_its_owner(how):
    """A viewer never closed: its server goes when the owning process ends, however it ends."""
    owner = subprocess.run([sys.executable, "-c", OWNER, str(SCENE), how], capture_output=True, text=True, timeout=120)
    assert owner.returncode == {"exit": 0, "raise": 1, "SIGTERM": -15, "SIGKILL": -9}[how], owner.stderr
    url, pid, owner_pid = owner.stdout.split()
    assert poll(lambda: servers_running(int(owner_pid)) == []), f"server {pid} outlived its owner ({how})"
    assert poll(lambda: not listening_addresses(web_port(url))), "the web port is still taken"


HOLDER = """
import sys, mujoco
from viscera.viewer import MeshcatViewer
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
mujoco.mj_step(model, data)
with MeshcatViewer(model) as viewer:
    viewer.update(data)
    print(viewer.url, flush=True)
    viewer.hold()
    print("held", flush=True)
"""


def test_hold_serves_until_sigterm():
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(SCENE)], stdout=subprocess.PIPE, text=True)
    try:
        url = holder.stdout.readline().strip()
        # holding: SIGTERM is caught (bit 15 of SigCgt), not the default action
        assert poll(lambda: int(re.search(r"SigCgt:\s*(\w+)", pathlib.Path(f"/proc/{holder.pid}/status").read_text())
                                .group(1), 16) & (1 << (signal.SIGTERM - 1)))
        page = urllib.request.urlopen(url, timeout=10).read()  # still served after the run
        assert b"MeshCat" in page and holder.poll() is None
        holder.send_signal(signal.SIGTERM)
        assert holder.wait(timeout=30) == 0
        assert holder.stdout.read().strip() == "held"
    finally:
        holder.kill()
        holder.stdout.close()
    assert poll(lambda: servers_running(holder.pid) == [])


LIVE_RUN = """
import select, sys, time, mujoco
from viscera.viewer import MeshcatViewer
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
with MeshcatViewer(model, camera="top") as viewer:
    print(viewer.url, flush=True)
    slowest = 0.0
    while not select.select([sys.stdin], [], [], 0)[0]:  # until the test says stop
        for _ in range(16):
            mujoco.mj_step(model, data)
        tick = time.perf_counter()
        viewer.update(data)
        slowest = max(slowest, time.perf_counter() - tick)
    status = viewer.flush()
    print(data.time, slowest, status["connections"], status["browsers"], flush=True)
"""


def stalled_browser(url: str) -> socket.socket:
    """A websocket client that connects and then never reads: the slowest browser there is."""
    port = web_port(url)
    client = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connect: the window is agreed then
    client.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    client.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                   f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode())
    return client


@needs_chromium
def test_browsers_come_and_go_while_the_simulation_runs(tmp_path):
    """Chromium connects, leaves, connects again, a stalled client never reads: the run
    never waits for any of them and ends normally; each Chromium saw the bowel."""
    run = subprocess.Popen([sys.executable, "-c", LIVE_RUN, str(ABDOMEN)], stdin=subprocess.PIPE,
                           stdout=subprocess.PIPE, text=True)
    try:
        url = run.stdout.readline().strip()
        stalled = stalled_browser(url)
        seen = [intestine_pixels(screenshot(url, tmp_path / f"visit{k}.png")).sum() for k in range(2)]
        stalled.close()
        run.stdin.write("stop\n")
        run.stdin.flush()
        assert run.wait(timeout=60) == 0
        simulated, slowest, connections, browsers = run.stdout.read().split()
    finally:
        run.kill()
        run.stdout.close()
    assert min(seen) > 0.15 * 800 * 600, seen
    assert float(simulated) > 0.5  # it kept going meanwhile
    assert float(slowest) < 0.25  # one update never waited for a browser
    assert int(connections) == 3 and int(browsers) == 0


def framed_pixels(image: np.ndarray) -> tuple[float, float, float]:
    """The intestine's share of the frame and its centre as fractions of width and height."""
    mask = intestine_pixels(image)
    rows, cols = np.nonzero(mask)
    return mask.mean(), cols.mean() / mask.shape[1], rows.mean() / mask.shape[0]


MUJOCO_TOP_VIEW = """
import sys
import viscera  # first: it picks EGL when there is no display, before mujoco loads
import matplotlib.image, mujoco
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
while data.time < float(sys.argv[3]):
    mujoco.mj_step(model, data)
with mujoco.Renderer(model, 600, 800) as renderer:
    renderer.update_scene(data, camera="top")
    matplotlib.image.imsave(sys.argv[2], renderer.render())
"""


def target_pixels(image: np.ndarray) -> np.ndarray:
    """Mask of the cavity's target area, the green site (0.2, 0.8, 0.3), lit or shaded."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (g > 0.45) & (g > 1.5 * r) & (g > 1.3 * b)


def mujoco_top_view(path: pathlib.Path, seconds: float) -> np.ndarray:
    """MuJoCo's own picture of the abdomen from its `top` camera (in a process of its own:
    the GL backend is chosen when mujoco is first imported)."""
    subprocess.run([sys.executable, "-c", MUJOCO_TOP_VIEW, str(ABDOMEN), str(path), str(seconds)], check=True,
                   timeout=120)
    return matplotlib.image.imread(path)[..., :3]


def abdomen_views(live_png: pathlib.Path, recorded_png: pathlib.Path, work: pathlib.Path) -> tuple:
    """Screenshots of the abdomen after 0.2 s, live and recorded, from its `top` camera; and MuJoCo's own."""
    model = mujoco.MjModel.from_xml_path(str(ABDOMEN))
    data = mujoco.MjData(model)
    with MeshcatViewer(model, camera="top") as viewer:
        while data.time < 0.2:
            mujoco.mj_step(model, data)
            if round(data.time / model.opt.timestep) % 50 == 0:
                viewer.record(data)
        viewer.update(data)
        assert viewer.flush() is not None
        live = screenshot(viewer.url, live_png)
        page = work / "abdomen.html"
        viewer.save(str(page))
    recorded = screenshot(page.as_uri(), recorded_png, virtual_ms=3000)
    return live, recorded, mujoco_top_view(work / "mujoco.png", 0.2)


@needs_chromium
def test_abdomen_opens_framed_from_its_top_camera(tmp_path):
    live, recorded, reference = abdomen_views(tmp_path / "live.png", tmp_path / "recorded.png", tmp_path)
    expected = intestine_pixels(reference)
    for name, image in (("live", live), ("recorded", recorded)):
        share, x, y = framed_pixels(image)
        assert share > 0.15 and 0.4 < x < 0.6 and 0.4 < y < 0.6, (name, share, x, y)
        shown = intestine_pixels(image)
        overlap = (shown & expected).sum() / (shown | expected).sum()
        assert overlap > 0.6, (name, overlap)  # the same bowel at the same place as MuJoCo's own view
        # sites are drawn as MuJoCo draws them: the green target area shows where it shows there
        target, expected_target = target_pixels(image), target_pixels(reference)
        assert expected_target.sum() > 100
        assert (target & expected_target).sum() / (target | expected_target).sum() > 0.5, name
        # no axes triad at the origin (pure red and green lines), no grid
        assert ((image[..., 0] > 0.9) & (image[..., 1] < 0.1) & (image[..., 2] < 0.1)).sum() < 20


def recorded_commands(page: pathlib.Path) -> list[dict]:
    """The drawing commands a saved page draws, in order."""
    import umsgpack
    return [umsgpack.unpackb(base64.b64decode(b64)) for b64 in re.findall(r'draw\("([A-Za-z0-9+/=]*)"\)',
                                                                           page.read_text())]


def test_save_leaves_the_live_view_alone(tmp_path):
    """The recorded page is built apart: the server (every browser) is sent nothing, and the
    live scene keeps its skin, so a hold after it shows the final state."""
    model, data = settled_scene(0.1)
    with MeshcatViewer(model) as viewer:
        for _ in range(3):
            viewer.record(data)
        viewer.update(data)
        before = viewer.flush()["commands"]
        viewer.save(str(tmp_path / "run.html"))
        assert viewer.flush()["commands"] == before
        live = {path.decode() for _, path, _ in viewer._channel.scene.commands}
    assert "/meshcat/intestines/intestine" in live and not any(path.startswith("/meshcat/recording") for path in live)
    paths = [command["path"] for command in recorded_commands(tmp_path / "run.html")]
    assert "/meshcat/recording/intestine/2" in paths and "/meshcat/intestines/intestine" not in paths


def test_a_recorder_starts_no_server(tmp_path, monkeypatch):
    started = started_servers(monkeypatch)
    model, data = settled_scene(0.1)
    with MeshcatViewer(model, serve=False) as recorder:
        assert recorder.url is None and not recorder.serving and recorder.flush() is None
        recorder.update(data)
        recorder.record(data)
        recorder.record(data)
        assert recorder.save(str(tmp_path / "run.html")) > 10_000
        with pytest.raises(RuntimeError, match="no meshcat server"):
            recorder.hold(timeout=1)
    assert started == []
    assert "/meshcat/recording/intestine/1" in [c["path"] for c in recorded_commands(tmp_path / "run.html")]


def test_server_drops_malformed_messages_and_keeps_serving():
    model, data = settled_scene(0.1)
    with MeshcatViewer(model) as viewer:
        socket_ = viewer._channel.socket
        for message in ([b"set_object", b"/x"], [b"sync"], [b"sync", b"1", b"2"], [b"set_object", b"/x", b"", b"", b"more"]):
            socket_.send_multipart(message)
        status = viewer.flush()
        assert status is not None and status["dropped"] == 4
        viewer.update(data)
        assert viewer.flush()["commands"] > status["commands"]


def test_hold_raises_when_the_server_has_died():
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    with MeshcatViewer(model) as viewer:
        viewer._server.kill()
        viewer._server.wait()
        with pytest.raises(RuntimeError, match="meshcat server stopped"):
            viewer.hold(timeout=30)
    with MeshcatViewer(model) as viewer:  # dying during the hold
        import threading
        killer = threading.Timer(1.0, viewer._server.kill)
        killer.start()
        tick = time.monotonic()
        with pytest.raises(RuntimeError, match="meshcat server stopped"):
            viewer.hold(timeout=30)
        assert time.monotonic() - tick < 20
        killer.join()


if __name__ == "__main__":  # python tests/python/test_viewer.py: redraw the figures in docs/
    abdomen_views(ROOT / "docs" / "cavity_meshcat_live.png", ROOT / "docs" / "cavity_meshcat_recorded.png",
                  pathlib.Path(tempfile.mkdtemp()))


def test_the_skin_colours_the_marked_band_as_the_renderer_does():
    """A marked_band's rings are coloured MARKED_RGB in the meshcat skin, the rest INTESTINE_RGB."""
    from viscera.viewer import INTESTINE_RGB, MARKED_RGB, skin_colours
    xml = (f'<mujoco>{viscera.extension_xml("gut", length=1.0, control_points=11, marked_band=[0.2, 0.3])}'
           '<worldbody/></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    vertices, _, _ = viscera.skin(model, data, gut.instance)
    colours = skin_colours(gut, len(vertices))
    ring_x = vertices[:-2, 0].reshape(-1, 16).mean(axis=1)  # the rings' positions along the line (m)
    marked = np.all(colours[:-2].reshape(-1, 16, 3) == MARKED_RGB, axis=(1, 2))
    assert marked.any() and np.all((ring_x[marked] >= 0.2 - 1e-9) & (ring_x[marked] <= 0.3 + 1e-9))
    assert np.all(colours[:-2][~np.repeat(marked, 16)] == INTESTINE_RGB)
