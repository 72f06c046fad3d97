"""The socket device (viscera.teleop.socket_device): its protocol, its coupling force, the tissue
force it passes on, its rate beside a real-time session, its robustness (a fuzz of 10,000 bad
datagrams) and the C reference client."""

import json
import math
import random
import shutil
import socket
import struct
import subprocess
import sys
import time
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from viscera.teleop import protocol
from viscera.teleop.devices import DeviceError, Snapshot, ToolInfo
from viscera.teleop.socket_device import INVALID_KINDS, SocketDevice

DEG = math.pi / 180.0
TOOLS = [ToolInfo("grasper", 0, np.array([20.0, 20.0, 400.0, 2.0, 0.5]), np.array([-60.0, -60.0, 0.0, -180.0, 0.0]),
                  np.array([60.0, 60.0, 0.22, 180.0, 40.0]), np.array([0.0, 0.0, 0.0, 0.0, 40.0]), True),
         ToolInfo("retractor", 1, np.array([20.0, 20.0, 400.0, 2.0, 0.0]), np.array([-60.0, -60.0, 0.0, -180.0, 0.0]),
                  np.array([60.0, 60.0, 0.22, 180.0, 0.0]), np.zeros(5), False)]
WAIT_S = 5.0  # the longest any reply may take (CI under load); never slept, only waited on


def snapshot(time_s=1.0, q=None, tissue=None, holding=None, warning=None) -> Snapshot:
    q = q or {}
    tissue = tissue or {}
    return Snapshot(time_s, {t.name: np.asarray(q.get(t.name, t.initial), dtype=float) for t in TOOLS},
                    {t.name: np.zeros(5) for t in TOOLS},
                    {t.name: np.asarray(tissue.get(t.name, np.zeros(3)), dtype=float) for t in TOOLS},
                    {t.name: bool((holding or {}).get(t.name)) for t in TOOLS},
                    {t.name: bool((warning or {}).get(t.name)) for t in TOOLS})


class Peer:
    """A client socket with replies waited on, never slept for."""

    def __init__(self, port: int):
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.socket.connect(("127.0.0.1", port))
        self.sequence = 0
        self.inbox = []  # replies received while waiting for another

    def send(self, data: bytes) -> None:
        self.socket.send(data)

    def pose(self, poses, sequence=None, client_time=None) -> int:
        if sequence is None:
            self.sequence += 1
            sequence = self.sequence
        self.send(protocol.pack_pose(sequence, time.perf_counter() if client_time is None else client_time, poses))
        return sequence

    def reply(self, kind, sequence, timeout_s=WAIT_S):
        """The reply of type `kind` echoing `sequence`, or None after `timeout_s`."""
        for message in self.inbox:
            if isinstance(message, kind) and message.sequence == sequence:
                self.inbox.remove(message)
                return message
        end = time.monotonic() + timeout_s
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return None
            self.socket.settimeout(left)
            try:
                data = self.socket.recv(4096)
            except (TimeoutError, ConnectionRefusedError):
                continue
            message = protocol.unpack(data)
            if isinstance(message, kind) and message.sequence == sequence:
                return message
            self.inbox = self.inbox[-100:] + [message]

    def barrier(self) -> None:
        """Return once the device has handled everything this peer sent (UDP on loopback keeps
        one socket's order, and HELLO is answered whoever drives)."""
        self.sequence += 1
        self.send(protocol.pack_hello(self.sequence, 0.0))
        assert self.reply(protocol.Info, self.sequence) is not None, "the device stopped answering"

    def close(self) -> None:
        self.socket.close()


@pytest.fixture
def device():
    device = SocketDevice(port=0, silence_s=0.2)
    device.start(TOOLS)
    device.feedback(snapshot())
    yield device
    device.close()


# -- the protocol

def test_protocol_round_trips_and_sizes():
    pose = protocol.pack_pose(7, 1.5, [(0, (1.0, -2.0, 0.05, 30.0, 10.0)), (1, (0.0, 0.0, 0.0, 0.0, 0.0))])
    assert len(pose) == 24 + 2 * 44
    assert protocol.unpack(pose) == protocol.Pose(7, 1.5, ((0, (1.0, -2.0, 0.05, 30.0, 10.0)), (1, (0.0,) * 5)))
    force = protocol.pack_force(7, 1.5, 2.25, [(1, 3, (1.0, 2.0, 3.0, 4.0, 5.0), (6.0, 7.0, 8.0))], (1, 2, 3, 4))
    assert len(force) == 48 + 72
    assert protocol.unpack(force) == protocol.Force(7, 1.5, 2.25, (protocol.ToolForce(1, 3, (1.0, 2.0, 3.0, 4.0, 5.0),
                                                                                     (6.0, 7.0, 8.0)),), (1, 2, 3, 4))
    assert protocol.unpack(protocol.pack_hello(3, 0.5)) == protocol.Hello(3, 0.5)
    assert protocol.unpack(protocol.pack_bye(4)) == protocol.Bye(4)
    assert protocol.unpack(protocol.pack_info(5, {"a": [1, 2]})) == protocol.Info(5, {"a": [1, 2]})
    assert len(protocol.pack_force(0, 0, 0, [(i, 0, (0.0,) * 5, (0.0,) * 3) for i in range(6)])) <= 512
    assert protocol.newer(0, 0xFFFFFFFF) and protocol.newer(5, 4) and not protocol.newer(4, 4)
    assert not protocol.newer(3, 4)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600))
def test_unpack_refuses_any_bytes_with_a_protocol_error(data):
    try:
        protocol.unpack(data)
    except protocol.ProtocolError as error:
        assert error.kind in {"oversized", "short", "magic", "version", "type", "count", "length", "json", "nan",
                              "range"}


def test_info_describes_each_tool_within_512_bytes(device):
    peer = Peer(device.port)
    peer.send(protocol.pack_hello(9, 0.0))
    infos = [peer.reply(protocol.Info, 9) for _ in TOOLS]
    peer.close()
    tools = sorted((info.info["tool"] for info in infos), key=lambda t: t["index"])
    assert [t["name"] for t in tools] == ["grasper", "retractor"]
    assert tools[0]["kp"] == [20.0, 20.0, 400.0, 2.0, 0.5] and tools[0]["initial"] == [0.0, 0.0, 0.0, 0.0, 40.0]
    assert all(info.info["version"] == protocol.VERSION and info.info["tool_count"] == 2 for info in infos)
    assert infos[0].info["period_s"] == 0.01


# -- the device

def test_listens_on_loopback_only_unless_told():
    with pytest.raises(DeviceError) as refused:
        SocketDevice(host="0.0.0.0", port=0)
    assert "loopback" in str(refused.value) and "\n" not in str(refused.value)
    SocketDevice(host="localhost", port=0).close()
    SocketDevice(host="0.0.0.0", port=0, allow_remote=True).close()


def test_coupling_force_is_the_spring_and_damper_computed_by_hand(device):
    device.feedback(snapshot(q={"grasper": [10.0, -5.0, 0.05, 30.0, 20.0]},
                             tissue={"grasper": [0.5, -1.25, 2.0]}, holding={"grasper": True}))
    peer = Peer(device.port)
    first = peer.reply(protocol.Force, peer.pose([(0, (12.0, -5.0, 0.06, 30.0, 10.0))], client_time=1.0))
    # no velocity yet: F = -K (q_device - q_tool), in rad and m
    assert first.tools[0].coupling == pytest.approx((-20.0 * 2.0 * DEG, 0.0, -400.0 * 0.01, 0.0, -0.5 * -10.0 * DEG),
                                                    rel=1e-12, abs=1e-15)
    assert first.tools[0].tissue == (0.5, -1.25, 2.0) and first.tools[0].flags == protocol.FLAG_HOLDING
    assert first.sim_time_s == 1.0 and first.client_time_s == 1.0
    # 1 ms later pitch is 0.1 deg further: velocity 0.1 deg/ms, low-passed at 50 Hz, damped with B = K T
    second = peer.reply(protocol.Force, peer.pose([(0, (12.1, -5.0, 0.06, 30.0, 10.0))], client_time=1.001))
    tau = 1.0 / (2.0 * math.pi * 50.0)
    velocity = 0.001 / (0.001 + tau) * (0.1 * DEG / 0.001)  # rad/s
    assert second.tools[0].coupling[0] == pytest.approx(-20.0 * 2.1 * DEG - 20.0 * 0.01 * velocity, rel=1e-12)
    assert second.tools[0].coupling[2] == pytest.approx(-4.0, rel=1e-12)
    assert device.targets(0.0)["grasper"].tolist() == [12.1, -5.0, 0.06, 30.0, 10.0]
    assert "retractor" not in device.targets(0.0)  # left out of the POSEs: it holds
    peer.close()


def test_serves_from_a_process_or_a_thread_and_stops_on_close():
    before = sys.getswitchinterval()
    for process in (True, False):
        device = SocketDevice(port=0, process=process)
        device.start(TOOLS)
        device.feedback(snapshot(tissue={"grasper": [1.0, 2.0, 3.0]}))
        peer = Peer(device.port)
        assert peer.reply(protocol.Force, peer.pose([(0, (0.0,) * 5)])).tools[0].tissue == (1.0, 2.0, 3.0)
        peer.close()
        # a thread of this process needs the GIL handed over quickly; a process of its own does not
        assert (sys.getswitchinterval() < before) == (not process)
        assert device.alive
        device.close()
        assert sys.getswitchinterval() == before and not device.alive


# -- with the task: the tissue force is the sensor's, a held contact is still

@pytest.fixture(scope="module")
def pressed():
    """clear_area with the grasper driven over the socket into the bowel on the posterior wall
    and held there, ticked as fast as it goes: per tick, the FORCE answering a POSE sent after it."""
    from viscera.tasks.policies import Tools
    from viscera.teleop.session import Session

    device = SocketDevice(port=0)
    session = Session("clear_area", seed=0, device=device, record=False)
    physics = session.physics
    axis = physics.axis_points(100)
    point = axis[np.argmin(np.linalg.norm(axis[:, :2] - physics.target()[:2], axis=1))]
    goal = Tools(session.env).coordinates("grasper", [point[0], point[1], point[2] + physics.intestine().radius - 0.01])
    pose = (0, tuple(goal[c] for c in ("pitch", "yaw", "depth", "roll")) + (0.0,))
    peer = Peer(device.port)
    forces = []
    try:
        for _ in range(450):  # 4.5 s: 3 s to get there at the tools' velocity limits, 1.5 s held
            assert peer.reply(protocol.Force, peer.pose([pose])) is not None
            session.tick()
            forces.append(peer.reply(protocol.Force, peer.pose([pose])))
        sensor = np.array(physics.named.data.sensordata["grasper_force"][:3])
        yield forces, sensor, device
    finally:
        peer.close()
        session.close()


def test_tissue_force_is_the_tool_sensor_of_the_snapshot(pressed):
    forces, sensor, _ = pressed
    assert np.linalg.norm(sensor) > 0.1  # pressed into the bowel
    assert forces[-1].tools[0].tissue == tuple(sensor)  # exact: the sensor's float64 values


def test_held_contact_does_not_oscillate(pressed):
    forces, _, device = pressed
    depth = np.array([f.tools[0].coupling[2] for f in forces[-100:]])  # the last 1 s held
    assert abs(depth.mean()) > 0.5
    assert np.ptp(depth) < 0.05 * abs(depth.mean())
    assert device.stats["internal"] == 0


def test_reference_client_beside_a_real_time_session(tmp_path):
    """The reference 1 kHz client against a real-time session: it runs its whole schedule, every
    message it sends is valid, the device answers it, and the coupling stays passive. What the
    loop does, not how fast this machine runs it: rates and deadline misses are
    python/tools/bench_haptics.py's to measure."""
    from viscera.teleop.session import Session

    device = SocketDevice(port=0)
    session = Session("clear_area", seed=0, device=device, record=False)
    out = tmp_path / "client.json"
    duration_s = 3.0
    client = subprocess.Popen([sys.executable, "-m", "viscera.teleop.haptic_client", "--port", str(device.port),
                               "--duration", str(duration_s), "--sweep", "vigorous", "--json", str(out)])
    try:
        result = session.run(on_frame=lambda _: client.poll() is None)
    finally:
        client.wait(timeout=60)
        session.close()
    assert client.returncode == 0
    measured = json.loads(out.read_text())
    assert measured["periods"] == pytest.approx(duration_s * 1000.0, abs=1)  # its schedule, at 1 ms periods
    assert measured["sent"] + measured["skipped"] == measured["periods"] and measured["sent"] > 0
    assert measured["server_dropped"]["invalid"] == 0  # the reference client speaks the protocol
    answered = measured["sent"] - measured["lost"]
    assert answered > 0 and device.stats["answered"] >= answered  # each answer it counts, the device sent
    assert measured["passivity_min_j"] > -1e-3  # the coupling never gave the hand energy
    assert result.ticks > 0


def test_a_pinned_server_runs_on_its_core_above_a_client_sharing_it():
    """SocketDevice(cpu=k): the server process on core k only, one real-time priority above the
    reference client's loop (where the system grants real-time), so that a POSE from a client on the
    same core preempts it at once; a core the machine lacks is a DeviceError naming it."""
    import os

    from viscera.teleop.haptic_client import REALTIME_PRIORITY

    core = max(os.sched_getaffinity(0))
    device = SocketDevice(port=0, cpu=core)
    device.start(TOOLS)
    try:
        assert os.sched_getaffinity(device._server.pid) == {core}
        assert device.scheduling.endswith(f"core {core}")
        if device.scheduling.startswith("SCHED_FIFO"):
            assert device.scheduling.startswith(f"SCHED_FIFO {REALTIME_PRIORITY + 1}")
        device.feedback(snapshot())
        peer = Peer(device.port)
        assert peer.reply(protocol.Force, peer.pose([(0, (0.0,) * 5)])) is not None
        peer.close()
    finally:
        device.close()
    with pytest.raises(DeviceError, match=f"cannot run on core {os.cpu_count()}"):
        SocketDevice(port=0, cpu=os.cpu_count())


def test_the_servo_loops_make_no_reference_cycles():
    """The client and the server process run with the cyclic collector off (haptic_client.
    collector_paused): that leaks nothing only if their loops make no reference cycles. Run both
    (the server from a thread here) with the collector off, 100 and then 1,000 periods: the
    garbage in cycles they leave must not grow with the periods."""
    import gc

    from viscera.teleop import haptic_client

    device = SocketDevice(port=0, process=False)
    device.start(TOOLS)
    device.feedback(snapshot())
    was_enabled = gc.isenabled()
    left = {}
    try:
        gc.collect()
        gc.disable()
        for periods in (100, 1000):
            result = haptic_client.run("127.0.0.1", device.port, 1000.0, sweep="vigorous",
                                       duration_s=periods / 1000.0, realtime=False)
            assert result["sent"] > periods // 2 and result["sent"] - result["lost"] > 0  # the loops ran
            left[periods] = gc.collect()
    finally:
        if was_enabled:
            gc.enable()
        device.close()
    assert left[1000] <= left[100], left


# -- robustness

def bad_messages(rng: random.Random, good_pose: bytes, last_sequence: int):
    """(kind, datagram) pairs of every kind of bad message the device must drop."""
    head = protocol.POSE_HEAD
    tool = protocol.POSE_TOOL

    def pose(sequence=None, count=None, tools=((0, (1.0, 2.0, 0.01, 3.0, 4.0)),), client_time=1.0, version=1,
             magic=protocol.MAGIC, kind=protocol.POSE):
        body = b"".join(tool.pack(i, *v) for i, v in tools)
        return head.pack(magic, version, kind, sequence if sequence is not None else rng.getrandbits(32), client_time,
                         len(tools) if count is None else count) + body

    garbage = lambda n: bytes(rng.getrandbits(8) for _ in range(n))  # noqa: E731
    value = lambda: rng.choice([1.0, -3.0, 0.02])  # noqa: E731
    yield "oversized", garbage(rng.randint(513, 3000))                      # some past the 2048-byte buffer
    yield "oversized", good_pose + bytes(rng.randint(513 - len(good_pose), 600))
    yield "short", garbage(rng.randint(0, 7))
    yield "magic", b"XSCR" + garbage(rng.randint(4, 400))
    yield "magic", pose(magic=bytes([rng.randint(0, 255)]) + b"SCR" if rng.random() < 0.5 else b"vscr")
    yield "version", pose(version=rng.choice([0, 2, 255, 65535]))
    yield "version", struct.pack("<4sHHI", protocol.MAGIC, 2, protocol.BYE, 1)
    yield "type", pose(kind=rng.choice([0, 6, 99, 65535]))
    yield "type", protocol.pack_info(1, {"x": 1})                            # server to client only
    yield "type", protocol.pack_force(1, 0.0, 0.0, [])
    cut = good_pose[:rng.randint(8, len(good_pose) - 1)]                     # truncated
    yield ("short" if len(cut) < head.size else "length"), cut
    yield "length", pose(count=2)                                            # says 2, carries 1
    yield "length", protocol.pack_hello(1, 0.0)[:-1]
    yield "count", pose(count=rng.choice([7, 1000, 2**32 - 1]))
    yield "nan", pose(tools=((0, (value(), math.nan, value(), value(), value())),))
    yield "nan", pose(tools=((1, (value(), value(), rng.choice([math.inf, -math.inf]), value(), value())),))
    yield "nan", pose(client_time=math.nan)
    yield "range", pose(tools=((0, (rng.choice([400.0, -1e300]), 0.0, 0.0, 0.0, 0.0)),))
    yield "range", pose(tools=((0, (0.0, 0.0, rng.choice([1.5, -2.0]), 0.0, 0.0)),))
    yield "unknown_tool", pose(sequence=last_sequence + 1, tools=((rng.choice([2, 6, 2**32 - 1]), (0.0,) * 5),))
    yield "duplicate_tool", pose(sequence=last_sequence + 1, tools=((0, (0.0,) * 5), (0, (1.0,) * 5)))
    yield "stale", good_pose                                                  # a replay
    yield "stale", pose(sequence=(last_sequence - rng.randint(1, 1000)) & 0xFFFFFFFF)  # out of order (wraps)


def test_fuzz_ten_thousand_bad_messages():
    device = SocketDevice(port=0, silence_s=0.2, flood_per_ms=2)
    device.start(TOOLS)
    device.feedback(snapshot(tissue={"grasper": [0.25, 0.5, -1.0]}))
    rng = random.Random(29)
    expected = Counter()
    peer = Peer(device.port)
    good = (0, (5.0, -5.0, 0.03, 10.0, 20.0))
    try:
        while sum(expected.values()) < 10_000:
            floods = device.stats["flood"]
            sequence = peer.pose([good])
            peer.barrier()
            # a loop faster than flood_per_ms a millisecond has its good POSE dropped as a flood,
            # as it should be: it sends the next one
            if device.stats["flood"] > floods:
                continue
            answer = peer.reply(protocol.Force, sequence)  # good ones interleaved are still answered
            assert answer is not None and answer.tools[0].tissue == (0.25, 0.5, -1.0)
            good_pose = protocol.pack_pose(sequence, 0.0, [good])
            for kind, datagram in bad_messages(rng, good_pose, sequence):
                peer.send(datagram)
                expected[kind] += 1
            peer.barrier()  # every bad one handled before the next good one
            assert {k: device.stats[k] for k in expected} == dict(expected)
        # a flood: 100 POSEs at once, at most 2 a millisecond accepted, the rest counted
        answered, floods = device.stats["answered"], device.stats["flood"]
        for _ in range(100):
            peer.pose([good])
        peer.barrier()
        flooded = device.stats["flood"] - floods
        assert flooded >= 1 and flooded + device.stats["answered"] - answered == 100
        expected["flood"] = device.stats["flood"]
        # a second client while the first drives: busy; then the first vanishes (no BYE) and,
        # once it has been silent for silence_s, the second takes over
        other = Peer(device.port)
        other.sequence = 10**6
        peer.close()
        takeover = None
        while takeover is None:
            sent = other.pose([(1, (1.0, 2.0, 0.04, 0.0, 0.0))])
            other.barrier()
            if device.stats["takeover"]:
                takeover = other.reply(protocol.Force, sent)
            else:
                expected["busy"] += 1
            assert device.stats["busy"] == expected["busy"]
        assert takeover.tools[0].tool == 1
        # the grasper, left out of the new client's POSEs, holds the old client's last target
        assert {k: v.tolist() for k, v in device.targets(0.0).items()} == \
            {"grasper": list(good[1]), "retractor": [1.0, 2.0, 0.04, 0.0, 0.0]}
        other.close()
    finally:
        device.close()
    assert sum(expected.values()) >= 10_000 and all(expected[k] > 0 for k in (*INVALID_KINDS, "stale", "flood", "busy"))
    assert {k: device.stats[k] for k in (*INVALID_KINDS, "stale", "flood", "busy")} == \
        {k: expected.get(k, 0) for k in (*INVALID_KINDS, "stale", "flood", "busy")}
    assert device.stats["internal"] == 0 and device.last_error is None
    assert not device.alive  # closed, having survived: it was alive up to close (the barriers)


def test_no_bad_value_reaches_the_targets(device):
    peer = Peer(device.port)
    assert peer.reply(protocol.Force, peer.pose([(0, (1.0, 2.0, 0.05, 3.0, 4.0))])) is not None
    for bad in (math.nan, math.inf, 1e9):
        peer.send(protocol.POSE_HEAD.pack(protocol.MAGIC, 1, protocol.POSE, peer.sequence + 1, 0.0, 1)
                  + protocol.POSE_TOOL.pack(0, bad, 0.0, 0.0, 0.0, 0.0))
    peer.barrier()
    targets = device.targets(0.0)
    assert targets["grasper"].tolist() == [1.0, 2.0, 0.05, 3.0, 4.0]
    peer.send(protocol.pack_bye(peer.sequence + 1))  # BYE: the tools hold at once
    peer.barrier()
    assert device.targets(0.0) == {} and device.stats["bye"] == 1
    peer.close()


def test_a_diverged_simulation_sends_no_nan(device):
    device.feedback(snapshot(q={"grasper": [math.nan, 0.0, 0.0, 0.0, 0.0]}, tissue={"grasper": [math.inf, 0.0, 0.0]}))
    peer = Peer(device.port)
    force = peer.reply(protocol.Force, peer.pose([(0, (1.0, 0.0, 0.0, 0.0, 40.0))]))
    peer.close()
    assert all(map(math.isfinite, force.tools[0].coupling + force.tools[0].tissue))
    assert device.active_tool == "grasper"


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")
def test_c_reference_client(tmp_path, device):
    from pathlib import Path

    source = Path(__file__).resolve().parents[2] / "docs" / "haptics" / "haptic_client.c"
    binary = tmp_path / "haptic_client"
    subprocess.run(["cc", "-O2", "-Wall", "-Werror", "-std=c11", "-o", str(binary), str(source), "-lm"], check=True)
    device.feedback(snapshot(tissue={"grasper": [0.125, -0.5, 1.5]}, holding={"grasper": True}))
    run = subprocess.run([str(binary), str(device.port), "0.5"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert '"name":"grasper"' in run.stdout and "tissue 0.1250 -0.5000 1.5000 N flags 1" in run.stdout
    assert device.stats["answered"] >= 100 and device.stats["internal"] == 0
