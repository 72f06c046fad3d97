"""The reference client of the socket device: what a haptic driver does, and how well it went.

    python -m viscera.teleop.haptic_client --port 47000 --rate 1000 --duration 60 --sweep vigorous --json out.json

It asks the server what it drives (HELLO, one INFO per tool), then sends a POSE every period
(1 ms at 1 kHz) and waits, until that period ends, for the FORCE that answers it; a real driver
would command the force to its motors there. It paces on absolute deadlines (time.perf_counter)
so that lateness does not accumulate, and skips periods it has missed entirely rather than
sending them in a burst. It polls for the answer for REPLY_SPIN_S before blocking, and sleeps
until SPIN_S before the next deadline, then spins: a thread woken from a sleep can be late (on
a virtual machine's idle core, over 0.5 ms in 0.2 to 0.4 % of wake-ups, measured). With `--spin`
it spins through whole periods (a core of its own). Its thread asks for real-time scheduling
(realtime_thread; `--no-realtime` leaves it alone).

It measures (the JSON's keys):
- rate_hz: POSEs sent per second; deadline_misses: the fraction of periods whose FORCE did not
  arrive before the period ended (skipped periods count as missed);
- latency_p50_ms, latency_p99_ms, latency_max_ms: from a POSE sent to its FORCE received (the
  FORCE echoes the send time, so late answers are measured too); lost: POSEs never answered;
- passivity_min_j: a passivity observer (Hannaford and Ryu, IEEE Trans. Robot. Autom.
  18(1):1-10, 2002), the energy the hand has put into the coupling,
  W(n) = sum over k < n of -F_k . (q_{k+1} - q_k), F_k the force rendered while the device went
  from q_k to q_{k+1} (rad, m; N m, N). A passive coupling keeps W >= 0; its minimum over the run
  is the most energy the coupling ever gave the hand;
- skipped: periods the client itself woke too late to send in; scheduling: what realtime_thread got;
- simulation_behind_max_s, simulation_behind_final_s: how far the simulation was behind the
  device's clock (the time since the first answer less the simulated time since it, from each
  FORCE's sim_time): the coupling goes on being rendered at the client's rate when the
  simulation cannot keep real time, and this says by how much it could not;
- phases: per phase of the plan, its net work W and, for a held phase, the mean, the
  peak-to-peak and the oscillation (peak-to-peak less a straight-line drift) of each tool's
  coupling force and tissue force (norm) over the phase's last 3 s.

Only the standard library and numpy: a driver's author can read it as the protocol's example.
The motion is a plan (`--plan FILE.json`, or the one `--sweep` makes): a list of phases,
  {"kind": "sweep", "duration_s": 60, "center": {tool: [5]}, "amplitude": {tool: [5]},
   "frequency_hz": {tool: [5]}}  sines about a centre (pitch deg, yaw deg, depth m, roll deg, jaw deg);
  {"kind": "move", "duration_s": 2, "to": {tool: [5]}}  a smooth move from where the last phase ended;
  {"kind": "hold", "duration_s": 5}                      still where the last phase ended.
Tools left out of a phase stay where they were.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import gc
import json
import os
import platform
import select
import socket
import struct
import sys
import threading
import time

import numpy as np

from viscera import cli
from viscera.teleop import protocol
from viscera.trajectory import TO_SI

SPIN_S = 2e-4           # the last part of a period is spun: a sleep's wake-up can be late
REPLY_SPIN_S = 2e-4     # the answer is polled for this long before blocking: no wake-up to wait for
                        # (spins cost the simulation a core's time: measured, 0.4 + 0.3 ms put 8 %
                        # of its ticks behind real time, 0.2 + 0.2 ms 1 %, with no more misses;
                        # and the kernel throttles a real-time thread that never sleeps)
HELLO_TIMEOUT_S = 10.0  # the server may still be starting
HOLD_WINDOW_S = 3.0     # a held phase's force is judged over its last 3 s
SWEEP_FREQUENCIES_HZ = (0.7, 0.53, 0.41, 0.3, 1.1)  # pitch, yaw, depth, roll, jaw: incommensurate
SWEEP_AMPLITUDE = 0.25  # of each coordinate's range


REALTIME_PRIORITY = 10  # SCHED_FIFO priority of a haptic loop's thread (1-99; the kernel's own are 50 and up)
SLICE_NS = 100_000      # else a 0.1 ms time slice (Linux 6.12+, unprivileged): wakes ahead of busy threads
SCHED_SETATTR = {"x86_64": 314, "aarch64": 274}  # the syscall's number (no libc wrapper)


def realtime_thread(priority: int = REALTIME_PRIORITY, fifo: bool = True, cpu: int | None = None) -> str:
    """Ask the scheduler to wake the calling thread at once when its datagram comes; what it got.

    A haptic loop sleeps most of each millisecond. Linux's scheduler (EEVDF) may wake it on the
    core where the simulation computes, and lets that run out its time slice (1.4 ms on a 2-core
    machine) first: measured, a 0.2 ms sleep then overran by 2 to 7 ms about once per simulation
    tick. Real-time priority (SCHED_FIFO, needs root or CAP_SYS_NICE) preempts at once; without
    it, a short custom slice (sched_setattr's sched_runtime, Linux 6.12+) makes most wake-ups
    preempt. Haptic drivers do the same (dVRK, CHAI3D run their servo loops real-time)."""
    if not sys.platform.startswith("linux"):
        return "default"
    tid = threading.get_native_id()
    core = ""
    if cpu is not None:
        os.sched_setaffinity(tid, {cpu})  # an unknown core raises: a user's mistake, said at once
        core = f", core {cpu}"
    if fifo:
        try:
            os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(priority))
            return f"SCHED_FIFO {priority}{core}"
        except (OSError, AttributeError):
            pass
    number = SCHED_SETATTR.get(platform.machine())
    if number is None:
        return "default"
    # struct sched_attr (56 bytes): size, policy (SCHED_OTHER), flags, nice, priority, runtime (the
    # slice), deadline, period, utilisation min and max
    attr = ctypes.create_string_buffer(struct.pack("<IIQiIQQQII", 56, 0, 0, os.getpriority(os.PRIO_PROCESS, tid),
                                                   0, SLICE_NS, 0, 0, 0, 0))
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.syscall(number, tid, attr, 0) == 0:
        return f"slice {SLICE_NS / 1e6:g} ms{core}"
    return "default" + core


@contextlib.contextmanager
def collector_paused():
    """Python's cyclic garbage collector off for a servo loop's life, and what the process had
    frozen out of its reach.

    The collector runs when allocations pile up, whatever the loop's deadline: measured in a
    28 s bench, each of the client and the server paused for a collection about 90 times, seven
    of them for about 1 ms, a whole period at 1 kHz. A loop that makes no reference cycles (a
    test checks both of ours) leaks nothing with the collector off: reference counting frees
    everything it makes. `gc.freeze` first moves what the imports made out of every later
    collection's reach. Process-wide: for a process (or the one thread) that runs only the loop."""
    was_enabled = gc.isenabled()
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.unfreeze()
        if was_enabled:
            gc.enable()


class Client:
    """A UDP client of the socket device (viscera.teleop.protocol)."""

    def __init__(self, host: str = "127.0.0.1", port: int = protocol.PORT):
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.socket.connect((host, port))  # a connected socket also hears of an absent server
        self.socket.setblocking(False)
        self.sequence = 0

    def hello(self, timeout_s: float = HELLO_TIMEOUT_S) -> dict:
        """The server's INFO, asking every 0.1 s until `timeout_s` (TimeoutError then): the fields
        of its INFOs, with "tools", the tools in index order (one INFO each)."""
        end = time.perf_counter() + timeout_s
        tools, info = {}, None
        while time.perf_counter() < end:
            self.sequence += 1
            try:
                self.socket.send(protocol.pack_hello(self.sequence, time.perf_counter()))
            except OSError:  # nobody listens yet (ICMP port unreachable)
                pass
            reply = self.receive(min(0.1, max(0.0, end - time.perf_counter())))
            while reply is not None:
                if isinstance(reply, protocol.Info) and isinstance(reply.info.get("tool"), dict):
                    info = reply.info
                    tools[reply.info["tool"]["index"]] = reply.info["tool"]
                    if len(tools) == info.get("tool_count"):
                        info = {k: v for k, v in info.items() if k != "tool"}
                        info["tools"] = [tools[i] for i in sorted(tools)]
                        return info
                reply = self.receive(0.02)
        raise TimeoutError(f"no INFO from the server in {timeout_s:g} s")

    def send_pose(self, poses: dict[int, tuple], now: float) -> int:
        self.sequence = (self.sequence + 1) & 0xFFFFFFFF
        try:
            self.socket.send(protocol.pack_pose(self.sequence, now, poses.items()))
        except OSError:
            pass  # the server is gone or its buffer full: the period counts as missed
        return self.sequence

    def receive(self, timeout_s: float) -> protocol.Message | None:
        """The next message within `timeout_s` (select's microseconds: poll's are milliseconds)."""
        if timeout_s > 0.0:
            ready, _, _ = select.select([self.socket], [], [], timeout_s)
            if not ready:
                return None
        try:
            data = self.socket.recv(4096)
        except (BlockingIOError, InterruptedError):
            return None
        except OSError:  # ICMP port unreachable: no server (yet)
            return None
        try:
            return protocol.unpack(data)
        except protocol.ProtocolError:
            return None

    def bye(self) -> None:
        self.sequence += 1
        try:
            self.socket.send(protocol.pack_bye(self.sequence))
        except OSError:
            pass

    def close(self) -> None:
        self.socket.close()


def sweep_plan(info: dict, sweep: str, duration_s: float) -> list[dict]:
    """The plan `--sweep` names: vigorous (every coordinate of every tool in sines over a
    quarter of its range each side of the start), hold (still at the start), for `duration_s`."""
    if sweep == "hold":
        return [{"kind": "hold", "duration_s": duration_s}]
    center, amplitude, frequency = {}, {}, {}
    for tool in info["tools"]:
        lower, upper, initial = (np.array(tool[k], dtype=float) for k in ("lower", "upper", "initial"))
        a = SWEEP_AMPLITUDE * (upper - lower)
        center[tool["name"]] = list(np.clip(initial, lower + a, upper - a))
        amplitude[tool["name"]] = list(a)
        frequency[tool["name"]] = [f * (1.0 + 0.13 * tool["index"]) for f in SWEEP_FREQUENCIES_HZ]
    return [{"kind": "sweep", "duration_s": duration_s, "center": center, "amplitude": amplitude,
             "frequency_hz": frequency}]


class Motion:
    """The device's pose against time from a plan (see the module doc)."""

    def __init__(self, plan: list[dict], info: dict):
        self.names = {tool["name"]: tool["index"] for tool in info["tools"]}
        self.start = {tool["index"]: np.array(tool["initial"], dtype=float) for tool in info["tools"]}
        self.phases, begin, pose = [], 0.0, dict(self.start)
        for phase in plan:
            kind, duration = phase["kind"], float(phase["duration_s"])
            if kind not in ("sweep", "move", "hold") or not duration > 0:
                raise ValueError(f"plan phase {phase!r}: kind sweep, move or hold, and a positive duration_s")
            unknown = (set(phase.get("center", {})) | set(phase.get("to", {}))) - set(self.names)
            if unknown:
                raise ValueError(f"plan phase names tools the server does not have: {sorted(unknown)}")
            entry = {"kind": kind, "begin": begin, "end": begin + duration, "from": dict(pose), "phase": phase}
            self.phases.append(entry)
            begin += duration
            pose = self._at(entry, duration)  # where this phase ends
        self.duration_s = begin

    def _at(self, entry: dict, t: float) -> dict[int, np.ndarray]:
        """The pose of every tool `t` s into the phase."""
        phase, start = entry["phase"], entry["from"]
        poses = {}
        for name, index in self.names.items():
            q = start[index]
            if entry["kind"] == "sweep" and name in phase.get("center", {}):
                c, a, f = (np.array(phase[k][name], dtype=float) for k in ("center", "amplitude", "frequency_hz"))
                q = c + a * np.sin(2.0 * np.pi * f * t)
                if t < 1.0:  # the first second blends from where the device was: no jump
                    s = t * t * (3.0 - 2.0 * t)
                    q = start[index] + s * (q - start[index])
            elif entry["kind"] == "move" and name in phase.get("to", {}):
                u = min(1.0, t / (entry["end"] - entry["begin"]))
                s = u * u * u * (10.0 + u * (-15.0 + 6.0 * u))
                q = start[index] + s * (np.array(phase["to"][name], dtype=float) - start[index])
            poses[index] = q
        return poses

    def __call__(self, t: float) -> tuple[int, dict[int, tuple]]:
        """(phase number, {tool index: pose (5)}) at `t` s into the plan."""
        for number, entry in enumerate(self.phases):
            if t < entry["end"] or number == len(self.phases) - 1:
                poses = self._at(entry, min(t, entry["end"]) - entry["begin"])
                return number, {i: tuple(float(v) for v in q) for i, q in poses.items()}
        raise AssertionError


def run(host: str, port: int, rate_hz: float, plan: list[dict] | None = None, sweep: str = "vigorous",
        duration_s: float = 60.0, progress=None, realtime: bool = True, spin: bool = False,
        cpu: int | None = None) -> dict:
    """Drive the server with a plan (or the `sweep`) at `rate_hz`; the measurements (module doc).
    `progress(seconds)` is called about once a second. `realtime`: run this thread real-time
    (realtime_thread) if the system lets it; `cpu`: on that core only."""
    # a spinning thread must not be real-time: the kernel throttles it for 50 ms each second
    scheduling = realtime_thread(fifo=not spin, cpu=cpu) if realtime else "default"
    client = Client(host, port)
    try:
        info = client.hello()
        if info.get("version") != protocol.VERSION:
            raise RuntimeError(f"the server speaks protocol version {info.get('version')}, "
                               f"this client {protocol.VERSION}")
        motion = Motion(plan if plan is not None else sweep_plan(info, sweep, duration_s), info)
        with collector_paused():
            result = _drive(client, info, motion, rate_hz, progress, spin)
        result["scheduling"] = scheduling
        return result
    finally:
        client.bye()
        client.close()


def _drive(client: Client, info: dict, motion: Motion, rate_hz: float, progress, spin: bool) -> dict:
    period = 1.0 / rate_hz
    periods = int(round(motion.duration_s * rate_hz))
    indices = [tool["index"] for tool in info["tools"]]
    names = {tool["index"]: tool["name"] for tool in info["tools"]}
    latencies = np.full(periods, np.nan)
    send_times = np.full(periods, np.nan)             # perf_counter s, for a trace
    answered_in_time = np.zeros(periods, dtype=bool)
    sim_times = np.full(periods, np.nan)              # s, the simulated time each in-time FORCE came from
    phase_of = np.zeros(periods, dtype=np.int32)
    coupling = np.zeros((periods, len(indices), 5))   # the force rendered during each period (N m, N)
    tissue = np.zeros((periods, len(indices), 3))
    work = np.zeros(periods)                           # the hand's energy into the coupling, W (J)
    force = {i: (0.0,) * 5 for i in indices}           # rendered until a FORCE says otherwise
    tissue_now = {i: (0.0,) * 3 for i in indices}
    sent_at = {}                                       # sequence -> period, for late answers
    last_force = None
    previous_pose, energy, skipped = None, 0.0, 0
    start = time.perf_counter()
    next_report = 1.0
    k = 0
    while k < periods:
        deadline = start + (k + 1) * period
        now = time.perf_counter()
        if now >= deadline:  # this whole period is gone: skip it, do not send a burst
            skipped += 1
            phase_of[k] = motion(now - start)[0]
            for j, i in enumerate(indices):  # the device went on rendering the last force
                coupling[k, j], tissue[k, j] = force[i], tissue_now[i]
            work[k] = energy
            k += 1
            continue
        number, poses = motion(now - start)
        phase_of[k] = number
        send_times[k] = now = time.perf_counter()
        sequence = client.send_pose(poses, now)
        sent_at[sequence] = k
        q = {i: tuple(v * s for v, s in zip(poses[i], TO_SI)) for i in indices}
        if previous_pose is not None:  # the force rendered since the last pose did this work
            energy -= sum(f * (b - a) for i in indices for f, a, b in zip(force[i], previous_pose[i], q[i]))
        previous_pose = q
        while True:  # the answer, until the period ends
            remaining = deadline - time.perf_counter()
            if remaining <= 0.0:
                break
            polling = spin or time.perf_counter() - now < REPLY_SPIN_S
            reply = client.receive(0.0 if polling else remaining)
            if not isinstance(reply, protocol.Force):
                continue
            received = time.perf_counter()
            answered = sent_at.pop(reply.sequence, None)
            if answered is None:
                continue
            latencies[answered] = received - reply.client_time_s
            last_force = reply
            for entry in reply.tools:
                force[entry.tool], tissue_now[entry.tool] = entry.coupling, entry.tissue
            if answered == k:
                answered_in_time[k] = True
                sim_times[k] = reply.sim_time_s
                break
        for j, i in enumerate(indices):
            coupling[k, j], tissue[k, j] = force[i], tissue_now[i]
        work[k] = energy
        if len(sent_at) > 1000:  # answers that never came
            for stale in sorted(sent_at)[:-100]:
                sent_at.pop(stale)
        if progress is not None and k * period >= next_report:
            progress(next_report)
            next_report += 1.0
        k += 1
        wait = deadline - time.perf_counter()  # the next POSE goes at this deadline
        if wait > SPIN_S and not spin:
            time.sleep(wait - SPIN_S)
        while time.perf_counter() < deadline:
            pass
    elapsed = time.perf_counter() - start
    # answers still on their way at the end
    end = time.perf_counter() + 0.05
    while sent_at and time.perf_counter() < end:
        reply = client.receive(max(0.0, end - time.perf_counter()))
        if isinstance(reply, protocol.Force) and reply.sequence in sent_at:
            latencies[sent_at.pop(reply.sequence)] = time.perf_counter() - reply.client_time_s
    sent = periods - skipped
    measured = latencies[np.isfinite(latencies)]
    # how far the simulation fell behind the device's clock: the time since the first answer less
    # the simulated time since it (the session drops lost time; the coupling is rendered anyway)
    known = np.isfinite(sim_times) & np.isfinite(send_times)
    behind = ((send_times[known] - send_times[known][0]) - (sim_times[known] - sim_times[known][0])
              if known.any() else np.zeros(1))
    result = {
        "simulation_behind_max_s": float(behind.max()),
        "simulation_behind_final_s": float(behind[-1]),
        "rate_hz": sent / elapsed,
        "periods": periods,
        "sent": sent,
        "skipped": skipped,
        "deadline_misses": float(1.0 - answered_in_time.mean()) if periods else 0.0,
        "lost": int(periods - skipped - measured.size),
        "latency_p50_ms": _ms(measured, 50),
        "latency_p99_ms": _ms(measured, 99),
        "latency_p999_ms": _ms(measured, 99.9),
        "latency_max_ms": float(measured.max() * 1e3) if measured.size else None,
        "passivity_min_j": float(min(0.0, work.min())) if periods else 0.0,
        "passivity_final_j": float(work[-1]) if periods else 0.0,
        "server_dropped": dict(zip(("invalid", "stale", "flood", "busy"), last_force.dropped)) if last_force else None,
        "phases": [],
        "trace": {"send_s": send_times, "latency_s": latencies, "answered_in_time": answered_in_time},
    }
    for number, entry in enumerate(motion.phases):
        rows = np.flatnonzero(phase_of == number)
        if rows.size == 0:
            continue
        before = work[rows[0] - 1] if rows[0] > 0 else 0.0
        summary = {"kind": entry["kind"], "duration_s": entry["end"] - entry["begin"],
                   "work_j": float(work[rows[-1]] - before),  # the hand's net energy into the coupling
                   "deadline_misses": float(1.0 - answered_in_time[rows].mean())}
        if entry["kind"] == "hold":
            last = rows[rows >= rows[-1] - int(HOLD_WINDOW_S * rate_hz)]
            summary["tools"] = {}
            for j, i in enumerate(indices):
                c, t = coupling[last, j], np.linalg.norm(tissue[last, j], axis=1)
                summary["tools"][names[i]] = {
                    "coupling_mean": [float(v) for v in c.mean(axis=0)],
                    "coupling_peak_to_peak": [float(v) for v in np.ptp(c, axis=0)],
                    "coupling_oscillation": [float(v) for v in np.ptp(_detrended(c), axis=0)],
                    "tissue_force_mean_n": float(t.mean()),
                    "tissue_force_peak_to_peak_n": float(np.ptp(t)),
                    "tissue_force_oscillation_n": float(np.ptp(_detrended(t)))}
        result["phases"].append(summary)
    return result


def _detrended(values: np.ndarray) -> np.ndarray:
    """`values` (rows in time) less their straight-line fit: a slow drift (the bowel settling
    under a held tool) removed, an oscillation left."""
    t = np.arange(len(values), dtype=float)
    fit = np.polynomial.polynomial.polyfit(t, values, 1)
    return values - np.polynomial.polynomial.polyval(t, fit).T.reshape(values.shape)


def _ms(values: np.ndarray, percentile: float) -> float | None:
    return float(np.percentile(values, percentile) * 1e3) if values.size else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera.teleop.haptic_client",
                                     description="Drive viscera's socket device like a haptic device, and measure it.")
    parser.add_argument("--host", default="127.0.0.1", help="the server's address (default 127.0.0.1)")
    parser.add_argument("--port", type=cli.port, default=protocol.PORT, help=f"the server's UDP port (default {protocol.PORT})")
    parser.add_argument("--rate", type=cli.positive_float_up_to(1e5, "POSEs per s"), default=1000.0,
                        help="POSEs per second (default 1000)")
    parser.add_argument("--duration", type=cli.duration, default=60.0, help="s, of the --sweep (default 60)")
    parser.add_argument("--sweep", choices=("vigorous", "hold"), default="vigorous",
                        help="vigorous: every coordinate of every tool in sines; hold: the handle held still")
    parser.add_argument("--plan", help="a plan JSON file (a list of phases), instead of --sweep")
    parser.add_argument("--json", help="write the measurements here")
    parser.add_argument("--trace", help="write each period's send time and latency here (.npz)")
    parser.add_argument("--spin", action="store_true", help="busy-wait the whole period (a core of its own)")
    parser.add_argument("--no-realtime", action="store_true", help="leave this process's scheduling alone")
    parser.add_argument("--cpu", type=int, help="run on this core only (0 is the first)")
    args = parser.parse_args(argv)
    if not args.rate > 0 or not args.duration > 0:
        print("haptic_client: --rate and --duration must be positive", file=sys.stderr)
        return 2
    cores = os.cpu_count() or 1
    if args.cpu is not None and not (hasattr(os, "sched_setaffinity") and 0 <= args.cpu < cores):
        print(f"haptic_client: --cpu {args.cpu}: this machine has cores 0 to {cores - 1}"
              if hasattr(os, "sched_setaffinity") else "haptic_client: --cpu: this system cannot pin a process",
              file=sys.stderr)
        return 2
    plan = None
    if args.plan:
        try:
            with open(args.plan) as f:
                plan = json.load(f)
        except (OSError, ValueError) as error:
            print(f"haptic_client: --plan {args.plan}: {error}", file=sys.stderr)
            return 2
    try:
        result = run(args.host, args.port, args.rate, plan, args.sweep, args.duration,
                     realtime=not args.no_realtime, spin=args.spin, cpu=args.cpu)
    except (TimeoutError, RuntimeError, ValueError) as error:
        print(f"haptic_client: {error}", file=sys.stderr)
        return 1
    trace = result.pop("trace")
    if args.trace:
        np.savez(args.trace, **trace)
    text = json.dumps(result, indent=2)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")
    print(f"rate {result['rate_hz']:.1f} Hz, deadline misses {100 * result['deadline_misses']:.3f} %, "
          f"latency p50 {result['latency_p50_ms']} ms p99 {result['latency_p99_ms']} ms, "
          f"passivity min {result['passivity_min_j']:.3g} J")
    return 0


if __name__ == "__main__":
    sys.exit(main())
