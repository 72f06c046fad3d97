"""The socket device: an external haptic device drives the tools over UDP and feels the tissue.

    device = SocketDevice()                 # UDP 127.0.0.1:47000 (viscera.teleop.protocol)
    Session("clear_area", seed=0, device=device).run()

A thread of its own answers every valid POSE at once with a FORCE, at whatever rate the client
sends (1 kHz or faster), from the latest tool state the session handed over (`feedback`, once
per control tick, 100 Hz). The session reads the newest pose once per tick (`targets`) and moves
the tools towards it, no faster than their velocity limits.

The force is a virtual coupling (Colgate, Stanley and Brown, IROS 1995; Adams and Hannaford,
IEEE Trans. Robot. Autom. 15(3):465-474, 1999): a spring-damper between the device's pose q_d
and the simulated tool's q_t, per coordinate, in SI (rad, m):

    F = -K (q_d - q_t) - B qdot_d,    K = the tool's position actuator gain, B = K T

K is the stiffness with which the simulation's actuator pulls the tool towards the device's
pose, so the hand feels what the actuator does, the tissue's resistance included. q_t is a
sample held for up to one control period T (10 ms), seen after up to one more; for a sampled
spring, Colgate and Schenkel (J. Robotic Systems 14(1):37-47, 1997) show passivity needs a
damping b > K T / 2. The device-side damping B = K T is twice that bound, on the velocity
qdot_d estimated from successive poses (their client send times), low-passed at 50 Hz. The
reference client's passivity observer (Hannaford and Ryu, IEEE Trans. Robot. Autom.
18(1):1-10, 2002) checks that the coupling never gives the hand more energy than it took.

Robustness: nothing a client sends raises into the session. Bad datagrams are dropped and
counted in `stats` by kind: protocol errors (viscera.teleop.protocol.unpack's kinds: oversized,
short, magic, version, type, count, length, nan, range), unknown_tool, duplicate_tool, stale
(sequence not newer), flood (over FLOOD_PER_MS POSEs in a millisecond), busy (a second client
while the first is live). After SILENCE_S without a POSE the tools hold their pose and any
client may take over. `stats` also counts received, answered, hello, bye, takeover, silences,
send_error, recv_error and internal (a bug: counted, not raised).
"""

from __future__ import annotations

import ipaddress
import math
import socket
import sys
import threading
import time

import numpy as np

from viscera.teleop import protocol
from viscera.teleop.devices import Device, DeviceError, Snapshot, ToolInfo
from viscera.teleop.haptic_client import realtime_thread
from viscera.trajectory import COORDINATES, UNITS

TO_SI = (math.pi / 180.0, math.pi / 180.0, 1.0, math.pi / 180.0, math.pi / 180.0)  # user units -> rad, m
CONTROL_PERIOD_S = 0.01   # T until the session's snapshots show theirs
SILENCE_S = 0.5           # s without a POSE: the client has vanished, the tools hold
FLOOD_PER_MS = 8          # POSEs accepted per millisecond; beyond, a flood
VELOCITY_CUTOFF_HZ = 50.0  # the low-pass on the device's velocity (a 1 kHz difference is noisy)
MAX_HAND_SPEED = (20.0, 20.0, 2.0, 20.0, 20.0)  # rad/s, m/s: faster is a jump, not a hand (no damping spike)
MAX_GAP_S = 0.1           # poses further apart restart the velocity estimate
RECEIVE_BYTES = 2048      # the receive buffer: larger than any message, MSG_TRUNC tells the true size
POLL_S = 0.05             # the thread looks at its stop flag this often when no datagram comes
SWITCH_INTERVAL_S = float(__import__("os").environ.get("SW", "2e-4"))  # the GIL hand-over while running: at Python's 5 ms default the thread
                          # waits behind the simulation's thread for up to 5 ms per POSE
INVALID_KINDS = ("oversized", "short", "magic", "version", "type", "count", "length", "nan", "range",
                 "unknown_tool", "duplicate_tool")
STAT_KINDS = ("received", "answered", "hello", "bye", *INVALID_KINDS, "stale", "flood", "busy", "takeover",
              "silences", "send_error", "recv_error", "internal")


def loopback(host: str) -> bool:
    """Whether every address `host` resolves to is a loopback address."""
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(host, None, socket.AF_INET, socket.SOCK_DGRAM)}
    except OSError:
        return False
    return bool(addresses) and all(ipaddress.ip_address(a).is_loopback for a in addresses)


class SocketDevice(Device):
    """Tools driven by an external haptic device through viscera.teleop.protocol (see the module
    doc). `port` 0 takes a free port (`self.port` tells which). `host` must be a loopback
    address unless `allow_remote` (the protocol has no authentication)."""

    name = "socket"

    def __init__(self, host: str = "127.0.0.1", port: int = protocol.PORT, allow_remote: bool = False,
                 control_period_s: float = CONTROL_PERIOD_S, silence_s: float = SILENCE_S, realtime: bool = True):
        super().__init__()
        if not allow_remote and not loopback(host):
            raise DeviceError(f"--device socket listens on loopback only, and {host!r} is not loopback "
                              "(SocketDevice(allow_remote=True) to listen on it: the protocol has no authentication)")
        self.host = host
        self.period_s = float(control_period_s)
        self.silence_s = float(silence_s)
        self.stats: dict[str, int] = {kind: 0 for kind in STAT_KINDS}
        self.realtime = realtime
        self.scheduling = "not started"  # what realtime_thread got for the thread
        try:
            self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.socket.bind((host, int(port)))
        except OSError as error:
            raise DeviceError(f"--device socket: cannot listen on UDP {host}:{port} ({error.strerror or error})") from None
        self.socket.settimeout(POLL_S)
        self.port = self.socket.getsockname()[1]
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._switch_interval: float | None = None
        self._state = (0.0, {})        # (sim time s, {index: (q_t SI (5), tissue N (3), flags)}), swapped whole
        self._poses: dict[int, tuple] = {}  # index -> latest accepted pose (user units), swapped whole
        self._client = None            # the address whose POSEs drive the tools
        self._last_pose_s = -math.inf  # time.monotonic() of its latest accepted POSE
        self._silent = True
        self.last_error: str | None = None  # the latest internal error (a bug), for its report
        self._by_index: dict[int, ToolInfo] = {}
        self._gain: dict[int, tuple] = {}
        self._previous_snapshot_s = None
        self._reset_client()

    # -- the Device interface (the session's thread)
    def start(self, tools: list[ToolInfo]) -> None:
        super().start(tools)
        if len(tools) > protocol.MAX_TOOLS:
            raise DeviceError(f"--device socket drives at most {protocol.MAX_TOOLS} tools, the task has {len(tools)}")
        self._by_index = {t.index: t for t in tools}
        self._gain = {t.index: tuple(float(k) for k in t.kp) for t in tools}
        self._state = (0.0, {t.index: (tuple(float(v) * s for v, s in zip(t.initial, TO_SI)), (0.0, 0.0, 0.0), 0)
                             for t in tools})
        self._poses = {}
        self._client, self._last_pose_s, self._silent = None, -math.inf, True
        self._reset_client()
        self._previous_snapshot_s = None
        if self._thread is None or not self._thread.is_alive():
            if self._switch_interval is None:
                self._switch_interval = sys.getswitchinterval()
                sys.setswitchinterval(SWITCH_INTERVAL_S)
            self._stop.clear()
            self._thread = threading.Thread(target=self._serve, name=f"viscera-socket-device:{self.port}", daemon=True)
            self._thread.start()

    def targets(self, now_s: float) -> dict[str, np.ndarray]:
        if self._client is None:
            return {}
        if time.monotonic() - self._last_pose_s > self.silence_s:
            if not self._silent:  # the client vanished: the tools hold where they are
                self._silent = True
                self.stats["silences"] += 1
            return {}
        return {self._by_index[i].name: np.array(values) for i, values in self._poses.items()}

    def feedback(self, snapshot: Snapshot) -> None:
        if self._previous_snapshot_s is not None and snapshot.time_s > self._previous_snapshot_s:
            self.period_s = snapshot.time_s - self._previous_snapshot_s  # the session's control period
        self._previous_snapshot_s = snapshot.time_s
        tools = {}
        for tool in self.tools:
            q = tuple(float(v) * s for v, s in zip(snapshot.q[tool.name], TO_SI))
            tissue = tuple(float(f) for f in snapshot.tissue_force[tool.name][:3])
            flags = (protocol.FLAG_HOLDING if snapshot.holding.get(tool.name) else 0) | \
                    (protocol.FLAG_WARNING if snapshot.warning.get(tool.name) else 0)
            tools[tool.index] = (q, tissue, flags)
        self._state = (float(snapshot.time_s), tools)  # one reference swap: the thread sees a whole tick

    def help_lines(self) -> list[tuple[str, str]]:
        if self._client is None:
            status = "waiting for a client"
        elif self._silent or time.monotonic() - self._last_pose_s > self.silence_s:
            status = "client silent: tools hold"
        else:
            status = f"{self._client[0]}:{self._client[1]}"
        dropped = sum(self.stats[k] for k in (*INVALID_KINDS, "stale", "flood", "busy"))
        return [("UDP", f"{self.host}:{self.port}"), ("client", status),
                ("poses", f"{self.stats['answered']} answered, {dropped} dropped")]

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.socket.close()
        if self._switch_interval is not None:
            sys.setswitchinterval(self._switch_interval)
            self._switch_interval = None

    @property
    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def info(self, tool: ToolInfo) -> dict:
        """The JSON of the INFO about `tool` (viscera.teleop.protocol)."""
        def values(array):
            return [float(f"{float(v):.6g}") for v in array]
        return {"version": protocol.VERSION, "period_s": self.period_s, "silence_s": self.silence_s,
                "coordinates": ",".join(f"{c} {UNITS[c]}" for c in COORDINATES), "tool_count": len(self.tools),
                "tool": {"index": tool.index, "name": tool.name, "kp": values(tool.kp), "lower": values(tool.lower),
                         "upper": values(tool.upper), "initial": values(tool.initial)}}

    # -- the thread
    def _reset_client(self) -> None:
        self._sequence = None          # newest accepted sequence
        self._velocity = {}            # index -> (q_d SI (5), client time s, qdot_d SI (5) filtered)
        self._window_ms = -1
        self._window_count = 0

    def _serve(self) -> None:
        self.scheduling = realtime_thread() if self.realtime else "default"
        buffer = bytearray(RECEIVE_BYTES)
        view = memoryview(buffer)
        truncate = getattr(socket, "MSG_TRUNC", 0)  # Linux: the datagram's true size even when cut
        stats = self.stats
        while not self._stop.is_set():
            try:
                size, address = self.socket.recvfrom_into(buffer, RECEIVE_BYTES, truncate)
            except TimeoutError:
                continue
            except OSError:  # an ICMP error from a vanished client, an oversized datagram on some systems
                if self._stop.is_set():
                    break
                stats["recv_error"] += 1
                continue
            stats["received"] += 1
            try:
                reply = self._answer(view, size, address)
            except protocol.ProtocolError as error:
                stats[error.kind] += 1
                continue
            except Exception as error:  # a bug of ours: count it, keep serving
                stats["internal"] += 1
                self.last_error = f"{type(error).__name__}: {error}"
                continue
            if reply is not None:
                self._send(reply, address)

    def _send(self, reply: bytes, address) -> None:
        try:
            self.socket.sendto(reply, address)
        except OSError:  # the client's socket is gone or its buffer full: it will send again
            self.stats["send_error"] += 1

    def _answer(self, view: memoryview, size: int, address) -> bytes | None:
        stats = self.stats
        message = protocol.unpack(view, size)
        if isinstance(message, protocol.Pose):
            return self._pose(message, address)
        if isinstance(message, protocol.Hello):
            stats["hello"] += 1
            for tool in self.tools[:-1]:
                self._send(protocol.pack_info(message.sequence, self.info(tool)), address)
            return protocol.pack_info(message.sequence, self.info(self.tools[-1])) if self.tools else None
        if isinstance(message, protocol.Bye):
            if address == self._client:
                stats["bye"] += 1
                self._last_pose_s = -math.inf  # silent now: the tools hold, another client may drive
            else:
                stats["busy"] += 1
            return None
        stats["type"] += 1  # INFO and FORCE go from the server, never to it
        return None

    def _pose(self, pose: protocol.Pose, address) -> bytes | None:
        stats = self.stats
        seen = set()
        for index, _ in pose.tools:
            if index not in self._by_index:
                raise protocol.ProtocolError("unknown_tool", f"tool {index} unknown")
            if index in seen:
                raise protocol.ProtocolError("duplicate_tool", f"tool {index} twice")
            seen.add(index)
        now = time.monotonic()
        if address != self._client:
            if self._client is not None and now - self._last_pose_s <= self.silence_s:
                stats["busy"] += 1
                return None
            if self._client is not None:
                stats["takeover"] += 1
            self._client = address
            self._reset_client()
        elif now - self._last_pose_s > self.silence_s:
            self._reset_client()  # back after a silence: its sequence may have restarted
        if self._sequence is not None and not protocol.newer(pose.sequence, self._sequence):
            stats["stale"] += 1
            return None
        window = int(now * 1000.0)
        if window != self._window_ms:
            self._window_ms, self._window_count = window, 0
        self._window_count += 1
        if self._window_count > FLOOD_PER_MS:
            stats["flood"] += 1
            return None
        self._sequence = pose.sequence
        self._last_pose_s = now
        self._silent = False
        poses = dict(self._poses)
        sim_time, state = self._state
        alpha_tau = 1.0 / (2.0 * math.pi * VELOCITY_CUTOFF_HZ)
        answers = []
        for index, values in pose.tools:
            poses[index] = values
            q_d = tuple(v * s for v, s in zip(values, TO_SI))
            previous = self._velocity.get(index)
            qdot = (0.0,) * 5
            if previous is not None:
                dt = pose.client_time_s - previous[1]
                if 0.0 < dt <= MAX_GAP_S:
                    alpha = dt / (dt + alpha_tau)
                    qdot = tuple(v + alpha * (max(-m, min(m, (q - p) / dt)) - v)
                                 for q, p, v, m in zip(q_d, previous[0], previous[2], MAX_HAND_SPEED))
                elif dt <= 0.0:  # the client's clock did not advance: keep the estimate
                    qdot = previous[2]
            self._velocity[index] = (q_d, pose.client_time_s, qdot)
            q_t, tissue, flags = state[index]
            gain = self._gain[index]
            damping = self.period_s
            coupling = tuple(-k * (d - t) - k * damping * v for k, d, t, v in zip(gain, q_d, q_t, qdot))
            answers.append((index, flags, coupling, tissue))
        self._poses = poses
        stats["answered"] += 1
        return protocol.pack_force(pose.sequence, pose.client_time_s, sim_time, answers, self.dropped())

    def dropped(self) -> tuple[int, int, int, int]:
        """FORCE's counters: invalid, stale, flood, busy."""
        stats = self.stats
        return (sum(stats[k] for k in INVALID_KINDS), stats["stale"], stats["flood"], stats["busy"])
