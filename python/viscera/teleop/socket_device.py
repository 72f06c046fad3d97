"""The socket device: an external haptic device drives the tools over UDP and feels the tissue.

    device = SocketDevice()                 # UDP 127.0.0.1:47000 (viscera.teleop.protocol)
    Session("clear_area", seed=0, device=device).run()

A server of its own answers every valid POSE at once with a FORCE, at whatever rate the client
sends (1 kHz or faster), from the latest tool state the session handed over (`feedback`, once
per control tick, 100 Hz). The session reads the newest pose once per tick (`targets`) and moves
the tools towards it, no faster than their velocity limits.

The force is a virtual coupling (Colgate, Stanley and Brown, IROS 1995; Adams and Hannaford,
IEEE Trans. Robot. Autom. 15(3):465-474, 1999): a spring-damper between the device's pose q_d
and the simulated tool's q_t, per coordinate, in SI (rad, m):

    F = -K (q_d - q_t) - B qdot_d,    K = the tool's position actuator gain, B = K T

K is the stiffness with which the simulation's actuator pulls the tool towards the device's
pose, so the hand feels what the actuator does, the tissue's resistance included. The tool's
state q_t reaches the coupling as a sample held for one control period T (10 ms). Colgate and
Schenkel (J. Robotic Systems 14(1):37-47, 1997) show that a spring of stiffness K sampled and
held every T is passive only with a damping b > K T / 2 (plus any virtual damping) to absorb
the energy the hold generates. The coupling adds B = K T, twice that bound, on the device's
velocity qdot_d, estimated from successive poses (their client send times: the haptic rate, far
faster than T) and low-passed at 50 Hz. That is a design margin, not a proof: the reference
client's passivity observer (Hannaford and Ryu, IEEE Trans. Robot. Autom. 18(1):1-10, 2002)
measures that the coupling never gives the hand more energy than it took
(python/tools/bench_haptics.py).

The server runs in a process of its own (`python -m viscera.teleop.socket_device`, started by
`start`), with real-time priority if the system grants it (haptic_client.realtime_thread). In a
thread of the session's process, an answer needs the GIL, which the simulation's thread holds
while it runs Python: measured on 2 cores at 1 kHz (python/tools/bench_haptics.py), that
thread missed 0.4 to 0.8 % of the periods on an idle machine and 5 to 7 % with the cores busy
(the simulation's thread, holding the GIL, waits for a core: priority inversion); the process
0.01 to 0.02 % idle, 0.02 to 0.15 % busy. The two processes
share one small memory map: the tool state (written by the session each tick) and the latest
pose (written by the server each POSE), each double-buffered so that neither ever waits for the
other. `SocketDevice(process=False)` serves from a thread instead (no child process; the GIL is
then handed over every SWITCH_INTERVAL_S instead of Python's 5 ms).

Robustness: nothing a client sends raises into the session. Bad datagrams are dropped and
counted in `stats` by kind: protocol errors (viscera.teleop.protocol.unpack's kinds: oversized,
short, magic, version, type, count, length, nan, range), unknown_tool, duplicate_tool, stale
(sequence not newer), flood (over FLOOD_PER_MS POSEs in a millisecond), busy (a second client
while the first is live). After SILENCE_S without a POSE the tools hold their pose and any
client may take over. `stats` also counts received, answered, hello, bye, takeover, silences,
send_error, recv_error and internal (a bug: counted, not raised; `last_error` says what).
"""

from __future__ import annotations

import array
import ipaddress
import json
import math
import mmap
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

from viscera.teleop import protocol
from viscera.teleop.devices import Device, DeviceError, Snapshot, ToolInfo
from viscera.teleop.haptic_client import REALTIME_PRIORITY, collector_paused, realtime_thread
from viscera.trajectory import COORDINATES, TO_SI, UNITS

CONTROL_PERIOD_S = 0.01   # T until the session's snapshots show theirs
SILENCE_S = 0.5           # s without a POSE: the client has vanished, the tools hold
FLOOD_PER_MS = 8          # POSEs accepted per millisecond; beyond, a flood
VELOCITY_CUTOFF_HZ = 50.0  # the low-pass on the device's velocity (a 1 kHz difference is noisy)
LOW_PASS_TAU_S = 1.0 / (2.0 * math.pi * VELOCITY_CUTOFF_HZ)
MAX_HAND_SPEED = (20.0, 20.0, 2.0, 20.0, 20.0)  # rad/s, m/s: faster is a jump, not a hand (no damping spike)
MAX_GAP_S = 0.1           # poses further apart restart the velocity estimate
RECEIVE_BYTES = 2048      # the receive buffer: larger than any message, MSG_TRUNC tells the true size
POLL_S = 0.05             # the server looks at its stop flag (and its parent) this often when idle
START_TIMEOUT_S = 30.0    # the server process imports viscera (about 0.5 s; longer on a loaded CI machine)
SWITCH_INTERVAL_S = 5e-5  # process=False: the GIL hand-over (measured: 2e-4 s missed 1.6 % of periods, 5e-5 s 0.5 %)
SERVER_ACCEPTS = (protocol.HELLO, protocol.POSE, protocol.BYE)  # INFO and FORCE go from the server only
INVALID_KINDS = ("oversized", "short", "magic", "version", "type", "count", "length", "nan", "range",
                 "unknown_tool", "duplicate_tool")
STAT_KINDS = ("received", "answered", "hello", "bye", *INVALID_KINDS, "stale", "flood", "busy", "takeover",
              "silences", "send_error", "recv_error", "internal")
KIND = {kind: number for number, kind in enumerate(STAT_KINDS)}

# The shared memory, in float64 words (counters too: exact to 2^53).
STOP, READY = 0, 1                          # session -> server: stop; server -> session: serving
COUNTERS = 2                                # the server's counts, STAT_KINDS order
STATE = COUNTERS + len(STAT_KINDS)          # the tool state board: the session writes, the server reads
STATE_VALUES = 2 + 9 * protocol.MAX_TOOLS   # sim time s, period s; per tool q_t (5, SI), tissue (3, N), flags
POSES = STATE + 1 + 2 * (STATE_VALUES + 2)  # the pose board: the server writes, the session reads
POSE_VALUES = 2 + 6 * protocol.MAX_TOOLS    # last POSE (time.monotonic s), client present; per tool valid, pose (5)
WORDS = POSES + 1 + 2 * (POSE_VALUES + 2)
ERROR_BYTES = 256                           # the server's last internal error, UTF-8, after the words
SCHEDULING_BYTES = 64                       # what realtime_thread got for the server, UTF-8, after that
MEMORY_BYTES = 8 * WORDS + ERROR_BYTES + SCHEDULING_BYTES


def loopback(host: str) -> bool:
    """Whether every address `host` resolves to is a loopback address."""
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(host, None, socket.AF_INET, socket.SOCK_DGRAM)}
    except OSError:
        return False
    return bool(addresses) and all(ipaddress.ip_address(a).is_loopback for a in addresses)


class Board:
    """Values one side writes and the other reads, in shared words: two slots, each framed by a
    sequence number before and after; the writer fills the idle slot and then points at it, a
    reader copies the slot pointed at and retries if its frame does not match. Neither side ever
    waits for the other (a lock held by a preempted writer would stall the haptic loop)."""

    def __init__(self, words: memoryview, base: int, count: int):
        self.words, self.base, self.count = words, base, count
        self.last = None

    def write(self, values) -> None:
        words, slot = self.words, 1 - int(self.words[self.base])
        start = self.base + 1 + slot * (self.count + 2)
        sequence = words[start] + 1.0
        words[start] = sequence
        words[start + 1:start + 1 + self.count] = array.array("d", values)
        words[start + 1 + self.count] = sequence
        words[self.base] = slot

    def read(self) -> list | None:
        """The latest values written (a list of count floats), None before the first write."""
        for _ in range(8):
            start = self.base + 1 + int(self.words[self.base]) * (self.count + 2)
            values = self.words[start:start + self.count + 2].tolist()
            if values[0] == values[-1]:
                if values[0] > 0.0:
                    self.last = values[1:-1]
                break
        return self.last


class Server:
    """Answers POSEs (see the module doc); runs in the server process, or a thread."""

    def __init__(self, sock: socket.socket, memory, config: dict):
        self.socket = sock
        self.memory = memoryview(memory)
        self.words = self.memory[:8 * WORDS].cast("d")
        self.error = self.memory[8 * WORDS:8 * WORDS + ERROR_BYTES]
        self.tools = config["tools"]
        self.by_index = {t["index"]: t for t in self.tools}
        self.silence_s, self.flood_per_ms = config["silence_s"], config["flood_per_ms"]
        self.state = Board(self.words, STATE, STATE_VALUES)
        self.poses = Board(self.words, POSES, POSE_VALUES)
        self.pose = {}                  # index -> latest accepted pose (user units)
        self.client = None              # the address whose POSEs drive the tools
        self.last_pose_s = -math.inf    # time.monotonic() of its latest accepted POSE
        self.reset_client()

    def scheduled(self, how: str) -> None:
        text = how.encode()[:SCHEDULING_BYTES]
        self.memory[MEMORY_BYTES - SCHEDULING_BYTES:MEMORY_BYTES] = text + bytes(SCHEDULING_BYTES - len(text))

    def count(self, kind: str) -> None:
        self.words[COUNTERS + KIND[kind]] += 1.0

    def dropped(self) -> list[int]:
        """FORCE's counters: invalid, stale, flood, busy."""
        words = self.words
        return [int(sum(words[COUNTERS + KIND[k]] for k in INVALID_KINDS)), int(words[COUNTERS + KIND["stale"]]),
                int(words[COUNTERS + KIND["flood"]]), int(words[COUNTERS + KIND["busy"]])]

    def reset_client(self) -> None:
        self.sequence = None            # newest accepted sequence
        self.velocity = {}              # index -> (q_d SI (5), client time s, qdot_d SI (5) filtered)
        self.window_ms, self.window_count = -1, 0

    def publish(self) -> None:
        values = [self.last_pose_s if math.isfinite(self.last_pose_s) else -1e300, float(self.client is not None)]
        for index in range(protocol.MAX_TOOLS):
            pose = self.pose.get(index)
            values += (0.0, 0.0, 0.0, 0.0, 0.0, 0.0) if pose is None else (1.0, *pose)
        self.poses.write(values)

    def serve(self, stopped) -> None:
        buffer = bytearray(RECEIVE_BYTES)
        view = memoryview(buffer)
        truncate = getattr(socket, "MSG_TRUNC", 0)  # Linux: the datagram's true size even when cut
        self.socket.settimeout(POLL_S)
        self.words[READY] = 1.0
        while not stopped():
            try:
                size, address = self.socket.recvfrom_into(buffer, RECEIVE_BYTES, truncate)
            except TimeoutError:
                continue
            except OSError:  # an ICMP error from a vanished client, an oversized datagram on some systems
                self.count("recv_error")
                continue
            self.count("received")
            try:
                reply = self.answer(view, size, address)
            except protocol.ProtocolError as error:
                self.count(error.kind)
                continue
            except Exception as error:  # a bug of ours: count it, keep serving
                self.count("internal")
                text = f"{type(error).__name__}: {error}".encode()[:ERROR_BYTES]
                self.error[:] = text + bytes(ERROR_BYTES - len(text))
                continue
            if reply is not None:
                self.send(reply, address)

    def send(self, reply: bytes, address) -> None:
        try:
            self.socket.sendto(reply, address)
        except OSError:  # the client's socket is gone or its buffer full: it will send again
            self.count("send_error")

    def answer(self, view: memoryview, size: int, address) -> bytes | None:
        message = protocol.unpack(view, size, SERVER_ACCEPTS)
        if isinstance(message, protocol.Pose):
            return self.answer_pose(message, address)
        if isinstance(message, protocol.Hello):
            self.count("hello")
            for tool in self.tools[:-1]:
                self.send(protocol.pack_info(message.sequence, self.info(tool)), address)
            return protocol.pack_info(message.sequence, self.info(self.tools[-1])) if self.tools else None
        if address == self.client:  # BYE: silent now, the tools hold and another client may drive
            self.count("bye")
            self.last_pose_s = -math.inf
            self.publish()
        else:
            self.count("busy")
        return None

    def info(self, tool: dict) -> dict:
        """The JSON of the INFO about `tool` (viscera.teleop.protocol)."""
        state = self.state.read()
        return {"version": protocol.VERSION, "period_s": state[1] if state else CONTROL_PERIOD_S,
                "silence_s": self.silence_s, "coordinates": ",".join(f"{c} {UNITS[c]}" for c in COORDINATES),
                "tool_count": len(self.tools), "tool": tool}

    def answer_pose(self, pose: protocol.Pose, address) -> bytes | None:
        seen = set()
        for index, _ in pose.tools:
            if index not in self.by_index:
                raise protocol.ProtocolError("unknown_tool", f"tool {index} unknown")
            if index in seen:
                raise protocol.ProtocolError("duplicate_tool", f"tool {index} twice")
            seen.add(index)
        now = time.monotonic()
        if address != self.client:
            if self.client is not None and now - self.last_pose_s <= self.silence_s:
                self.count("busy")
                return None
            if self.client is not None:
                self.count("takeover")
            self.client = address
            self.reset_client()
        elif now - self.last_pose_s > self.silence_s:
            self.reset_client()  # back after a silence: its sequence may have restarted
        if self.sequence is not None and not protocol.newer(pose.sequence, self.sequence):
            self.count("stale")
            return None
        window = int(now * 1000.0)
        if window != self.window_ms:
            self.window_ms, self.window_count = window, 0
        self.window_count += 1
        if self.window_count > self.flood_per_ms:
            self.count("flood")
            return None
        self.sequence, self.last_pose_s = pose.sequence, now
        state = self.state.read()
        sim_time, period = (state[0], state[1]) if state else (0.0, CONTROL_PERIOD_S)
        time_s = pose.client_time_s
        fields = [protocol.MAGIC, protocol.VERSION, protocol.FORCE, pose.sequence, time_s, sim_time,
                  len(pose.tools), *self.dropped()]
        for index, values in pose.tools:
            self.pose[index] = values
            q_d = [v * s for v, s in zip(values, TO_SI)]
            previous = self.velocity.get(index)
            if previous is None:
                qdot = [0.0] * 5
            else:
                q_p, time_p, qdot = previous
                dt = time_s - time_p
                if 0.0 < dt <= MAX_GAP_S:
                    alpha = dt / (dt + LOW_PASS_TAU_S)
                    qdot = [v + alpha * (max(-m, min(m, (q - p) / dt)) - v)
                            for q, p, v, m in zip(q_d, q_p, qdot, MAX_HAND_SPEED)]
                elif dt > MAX_GAP_S:
                    qdot = [0.0] * 5
                # dt <= 0: the client's clock did not advance, keep the estimate
            self.velocity[index] = (q_d, time_s, qdot)
            tool = self.by_index[index]
            if state:
                base = 2 + 9 * index
                q_t, tissue, flags = state[base:base + 5], state[base + 5:base + 8], int(state[base + 8])
            else:  # no tick yet: the tool is where it starts
                q_t, tissue, flags = [v * s for v, s in zip(tool["initial"], TO_SI)], (0.0, 0.0, 0.0), 0
            fields += (index, flags, *[-k * (d - t) - k * period * v for k, d, t, v in zip(tool["kp"], q_d, q_t, qdot)],
                       *tissue)
        self.publish()
        self.count("answered")
        return protocol.FORCE_ALL[len(pose.tools)].pack(*fields)


class SocketDevice(Device):
    """Tools driven by an external haptic device through viscera.teleop.protocol (see the module
    doc). `port` 0 takes a free port (`self.port` tells which). `host` must be a loopback
    address unless `allow_remote` (the protocol has no authentication). `process` False serves
    from a thread of this process instead of a process of its own."""

    name = "socket"

    def __init__(self, host: str = "127.0.0.1", port: int = protocol.PORT, allow_remote: bool = False,
                 control_period_s: float = CONTROL_PERIOD_S, silence_s: float = SILENCE_S, realtime: bool = True,
                 flood_per_ms: int = FLOOD_PER_MS, process: bool = True, cpu: int | None = None):
        super().__init__()
        if not allow_remote and not loopback(host):
            raise DeviceError(f"--device socket listens on loopback only, and {host!r} is not loopback "
                              "(SocketDevice(allow_remote=True) to listen on it: the protocol has no authentication)")
        self.host = host
        self.period_s = float(control_period_s)
        self.silence_s = float(silence_s)
        self.flood_per_ms = int(flood_per_ms)
        self.realtime = realtime
        cores = os.cpu_count() or 1
        if cpu is not None and not (hasattr(os, "sched_setaffinity") and 0 <= int(cpu) < cores):
            raise DeviceError(f"--device socket: its server cannot run on core {cpu}: "
                              f"this machine has cores 0 to {cores - 1}" if hasattr(os, "sched_setaffinity")
                              else f"--device socket: cpu={cpu}: this system cannot pin a process to a core")
        self.cpu = None if cpu is None else int(cpu)
        self.process = process and os.name == "posix"  # the memory map is passed as an inherited descriptor
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.socket.bind((host, int(port)))
        except (OSError, OverflowError) as error:
            self.socket.close()
            why = getattr(error, "strerror", None) or error
            raise DeviceError(f"--device socket: cannot listen on UDP {host}:{port} ({why})") from None
        self.port = self.socket.getsockname()[1]
        if self.process:
            self._file = tempfile.TemporaryFile()
            self._file.truncate(MEMORY_BYTES)
            self._memory = mmap.mmap(self._file.fileno(), MEMORY_BYTES)
        else:
            self._file, self._memory = None, bytearray(MEMORY_BYTES)
        self._view = memoryview(self._memory)
        self._words = self._view[:8 * WORDS].cast("d")
        self._state = Board(self._words, STATE, STATE_VALUES)
        self._poses = Board(self._words, POSES, POSE_VALUES)
        self._server: subprocess.Popen | threading.Thread | None = None
        self._switch_interval: float | None = None
        self._silences = 0
        self._silent = True
        self._previous_snapshot_s = None
        self._by_index: dict[int, ToolInfo] = {}

    # -- the Device interface (the session's thread)
    def start(self, tools: list[ToolInfo]) -> None:
        super().start(tools)
        if len(tools) > protocol.MAX_TOOLS:
            raise DeviceError(f"--device socket drives at most {protocol.MAX_TOOLS} tools, the task has {len(tools)}")
        self._stop_server()
        self._by_index = {t.index: t for t in tools}
        self._previous_snapshot_s = None
        self._silent = True

        def values(array_):
            return [float(f"{float(v):.6g}") for v in array_]
        config = {"silence_s": self.silence_s, "flood_per_ms": self.flood_per_ms, "realtime": self.realtime,
                  "cpu": self.cpu, "parent": os.getpid(),
                  "tools": [{"index": t.index, "name": t.name, "kp": values(t.kp), "lower": values(t.lower),
                             "upper": values(t.upper), "initial": values(t.initial)} for t in tools]}
        self._words[STOP] = self._words[READY] = 0.0
        if self.process:
            fds = (self.socket.fileno(), self._file.fileno())
            self._server = subprocess.Popen([sys.executable, "-m", "viscera.teleop.socket_device", str(fds[0]),
                                             str(fds[1]), json.dumps(config)], pass_fds=fds)
        else:
            if self._switch_interval is None:
                self._switch_interval = sys.getswitchinterval()
                sys.setswitchinterval(SWITCH_INTERVAL_S)
            server = Server(self.socket, self._memory, config)
            self._server = threading.Thread(target=_serve_thread, args=(server, config, self._words),
                                            name=f"viscera-socket-device:{self.port}", daemon=True)
            self._server.start()
        deadline = time.monotonic() + START_TIMEOUT_S
        while self._words[READY] == 0.0:  # a client's first POSE finds it serving
            if not self.alive or time.monotonic() > deadline:
                self._stop_server()
                raise DeviceError(f"--device socket: its server did not start (UDP {self.host}:{self.port})")
            time.sleep(0.005)

    def targets(self, now_s: float) -> dict[str, np.ndarray]:
        poses = self._poses.read()
        if poses is None or not poses[1]:
            return {}
        if time.monotonic() - poses[0] > self.silence_s:
            if not self._silent:  # the client vanished: the tools hold where they are
                self._silent = True
                self._silences += 1
            return {}
        self._silent = False
        return {tool.name: np.array(poses[3 + 6 * index:8 + 6 * index]) for index, tool in self._by_index.items()
                if poses[2 + 6 * index]}

    def feedback(self, snapshot: Snapshot) -> None:
        if self._previous_snapshot_s is not None and snapshot.time_s > self._previous_snapshot_s:
            self.period_s = snapshot.time_s - self._previous_snapshot_s  # the session's control period
        self._previous_snapshot_s = snapshot.time_s
        previous = self._state.last
        values = [float(snapshot.time_s), self.period_s] + [0.0] * (9 * protocol.MAX_TOOLS)
        for tool in self.tools:
            base = 2 + 9 * tool.index
            q = [float(v) * s for v, s in zip(snapshot.q[tool.name], TO_SI)]
            tissue = [float(f) for f in snapshot.tissue_force[tool.name][:3]]
            if not all(map(math.isfinite, q + tissue)):  # a diverged simulation: no NaN to a motor
                q = previous[base:base + 5] if previous else [v * s for v, s in zip(tool.initial, TO_SI)]
                tissue = [0.0, 0.0, 0.0]
            flags = (protocol.FLAG_HOLDING if snapshot.holding.get(tool.name) else 0) | \
                    (protocol.FLAG_WARNING if snapshot.warning.get(tool.name) else 0)
            values[base:base + 9] = q + tissue + [float(flags)]
        self._state.write(values)
        self._state.last = values

    @property
    def stats(self) -> dict[str, int]:
        """How many datagrams of each kind the server has seen (see the module doc)."""
        counts = {kind: int(self._words[COUNTERS + KIND[kind]]) for kind in STAT_KINDS}
        counts["silences"] = self._silences
        return counts

    @property
    def last_error(self) -> str | None:
        """The server's latest internal error (a bug), or None."""
        text = bytes(self._view[8 * WORDS:8 * WORDS + ERROR_BYTES]).rstrip(b"\0").decode(errors="replace")
        return text or None

    @property
    def scheduling(self) -> str:
        """How the server is scheduled: what haptic_client.realtime_thread got for it."""
        return bytes(self._view[MEMORY_BYTES - SCHEDULING_BYTES:]).rstrip(b"\0").decode() or "not started"

    @property
    def alive(self) -> bool:
        server = self._server
        if isinstance(server, subprocess.Popen):
            return server.poll() is None
        return server is not None and server.is_alive()

    @property
    def active_tool(self) -> str | None:
        """The tools the client drives (a haptic device may drive several at once)."""
        return " + ".join(sorted(self.targets(0.0))) or None

    def help_lines(self) -> list[tuple[str, str]]:
        poses = self._poses.read()
        if poses is None or not poses[1]:
            status = "waiting for a client"
        elif time.monotonic() - poses[0] > self.silence_s:
            status = "client silent: tools hold"
        else:
            status = "driving"
        stats = self.stats
        dropped = sum(stats[k] for k in (*INVALID_KINDS, "stale", "flood", "busy"))
        return [("UDP", f"{self.host}:{self.port}"), ("client", status),
                ("poses", f"{stats['answered']} answered, {dropped} dropped")]

    def close(self) -> None:
        self._stop_server()
        if self._switch_interval is not None:
            sys.setswitchinterval(self._switch_interval)
            self._switch_interval = None
        self.socket.close()
        if self._file is not None:  # the map stays readable (stats) until collected
            self._file.close()

    def _stop_server(self) -> None:
        server, self._server = self._server, None
        if server is None:
            return
        self._words[STOP] = 1.0
        if isinstance(server, subprocess.Popen):
            try:
                server.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        else:
            server.join(timeout=2.0)


def _scheduling(config: dict) -> str:
    """The server's thread made real-time (haptic_client.realtime_thread) and put on its core.
    Pinned, it runs one priority above a client's loop (REALTIME_PRIORITY) that may share the
    core: a POSE from that client then preempts it at once, on the same core, with no wake-up of
    an idle core to wait for."""
    if not config["realtime"]:
        return "default"
    pinned = config.get("cpu") is not None
    return realtime_thread(REALTIME_PRIORITY + 1 if pinned else REALTIME_PRIORITY, cpu=config.get("cpu"))


def _serve_thread(server: Server, config: dict, words) -> None:
    server.scheduled(_scheduling(config))
    server.serve(lambda: words[STOP] != 0.0)


def main(argv: list[str]) -> int:
    """The server process: `python -m viscera.teleop.socket_device SOCKET_FD MEMORY_FD CONFIG_JSON`
    (SocketDevice.start runs it with the descriptors it inherits)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the session's: it stops this server
    sock = socket.socket(fileno=int(argv[0]))
    memory = mmap.mmap(int(argv[1]), MEMORY_BYTES)
    config = json.loads(argv[2])
    server = Server(sock, memory, config)
    server.scheduled(_scheduling(config))
    parent = config["parent"]
    words = server.words
    with collector_paused():  # the process serves and does nothing else
        server.serve(lambda: words[STOP] != 0.0 or os.getppid() != parent)  # a parent gone: nothing to serve
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit("viscera.teleop.socket_device: the server process SocketDevice.start runs; "
                 "to drive the tools, run python -m viscera teleop TASK --device socket")
    sys.exit(main(sys.argv[1:]))
