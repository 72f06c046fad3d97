"""The socket device's protocol: an external haptic device drives the tools over UDP on loopback.

A haptic driver (Geomagic Touch, Force Dimension, a dVRK master: usually C or C++) sends the pose
of its handle as tool coordinates, at 1 kHz or faster, and gets back, for each pose, the force to
render on the person's hand. The server is `viscera.teleop.socket_device.SocketDevice`
(`python -m viscera teleop TASK --device socket`); the reference clients are
`viscera.teleop.haptic_client` (Python) and `docs/haptics/haptic_client.c` (C).

Transport: UDP datagrams to 127.0.0.1, port 47000 by default; the server answers to the
datagram's source address. Every message is one datagram of at most 512 bytes, little-endian,
packed (no padding between fields), and starts with the same 8-byte header:

| offset | field | type | value |
|---|---|---|---|
| 0 | magic | 4 bytes | `VSCR` |
| 4 | version | u16 | 1 (`VERSION`) |
| 6 | type | u16 | 1 HELLO, 2 INFO, 3 POSE, 4 FORCE, 5 BYE |

**HELLO** (client to server, 20 bytes): asks what the server drives. Answered with one INFO per
tool, whatever the HELLO's version field, so that a client learns the server's version.

| offset | field | type | unit |
|---|---|---|---|
| 8 | sequence | u32 | echoed in INFO |
| 12 | client_time | f64 | s, the client's clock (for the client's logs) |

**INFO** (server to client, 16 bytes + JSON): a compact UTF-8 JSON object, one tool per INFO
(so that each fits in 512 bytes whatever the tools).

| offset | field | type | unit |
|---|---|---|---|
| 8 | sequence | u32 | the HELLO's |
| 12 | length | u32 | bytes of JSON that follow |
| 16 | json | length bytes | see below |

The JSON: `{"version": 1, "period_s": 0.01, "silence_s": 0.5,
"coordinates": "pitch deg,yaw deg,depth m,roll deg,jaw deg",
"tool_count": 2, "tool": {"index": 0, "name": "grasper", "kp": [20, 20, 400, 2, 0.5],
"lower": [...], "upper": [...], "initial": [...]}}`: `period_s` is the server's control period T
(s: the tool state the forces come from is this old at most, and the coupling's damping is
B = kp T), `silence_s` how long the server waits for a silent client before the tools hold
still, `tool_count` how many INFOs answer a HELLO, `kp` each coordinate's coupling stiffness in
SI (N m/rad for the angles, N/m for depth; 0 where the tool has no such joint), `lower`/`upper`
the control range and `initial` the tool's pose at the start, in the coordinates' units.

**POSE** (client to server, 24 + 44 n bytes, n the count of tools, at most 6): the handle's pose
as each tool's absolute target. Tools left out hold their target.

| offset | field | type | unit |
|---|---|---|---|
| 8 | sequence | u32 | increases by at least 1 per POSE (wraps at 2^32; any start after a silence) |
| 12 | client_time | f64 | s, the client's monotonic clock when sent |
| 20 | count | u32 | n, tools that follow |
| 24 + 44 i | tool | u32 | the tool's index (INFO) |
| 28 + 44 i | pitch | f64 | deg |
| 36 + 44 i | yaw | f64 | deg |
| 44 + 44 i | depth | f64 | m |
| 52 + 44 i | roll | f64 | deg |
| 60 + 44 i | jaw | f64 | deg (ignored by a tool without jaws) |

**FORCE** (server to client, 48 + 72 n bytes): the answer to each accepted POSE, sent as soon as
it arrives, one tool entry per tool of the POSE, in its order.

| offset | field | type | unit |
|---|---|---|---|
| 8 | sequence | u32 | the POSE's |
| 12 | client_time | f64 | s, the POSE's (round-trip latency = now - client_time) |
| 20 | sim_time | f64 | s, simulated time of the tool state the forces come from |
| 28 | count | u32 | n |
| 32 | dropped_invalid | u32 | messages dropped so far: malformed, oversized, NaN, out of range, unknown tool |
| 36 | dropped_stale | u32 | POSEs dropped so far: sequence not newer than the newest accepted |
| 40 | dropped_flood | u32 | POSEs dropped so far: more than 8 in one millisecond |
| 44 | dropped_busy | u32 | POSEs dropped so far: another client drives the tools |
| 48 + 72 i | tool | u32 | the tool's index |
| 52 + 72 i | flags | u32 | bit 0: the jaws hold tissue; bit 1: a tissue force threshold is crossed |
| 56 + 72 i | coupling pitch | f64 | N m, to render on the hand |
| 64 + 72 i | coupling yaw | f64 | N m |
| 72 + 72 i | coupling depth | f64 | N (positive pushes deeper) |
| 80 + 72 i | coupling roll | f64 | N m |
| 88 + 72 i | coupling jaw | f64 | N m (positive opens) |
| 96 + 72 i | tissue x, y, z | 3 f64 | N, world frame: the intestine's force on the tool (its `<tool>_force` sensor) |

**BYE** (client to server, 12 bytes: sequence u32 at offset 8): the client is done; the tools
hold and another client may drive them at once (otherwise after `silence_s` of silence).

The coupling force is a virtual coupling (Colgate, Stanley and Brown 1995; Adams and Hannaford,
IEEE Trans. Robot. Autom. 15(3) 1999), a spring-damper between the handle and the simulated
tool, per coordinate: F = -kp (q_device - q_tool) - kp T qdot_device, q in rad or m. See
`viscera.teleop.socket_device` for why the damping is kp T.

What the server drops (counted, never answered): datagrams over 512 bytes or too short for their
count, a wrong magic or type, a version other than 1 (except in HELLO), a non-finite value, a
value beyond 360 deg or 1 m, a tool index the server does not have (or twice in one POSE), a
sequence not newer than the newest accepted, more than 8 POSEs in a millisecond, and POSEs from
a second client while the first is not silent. Values inside those bounds but outside the tool's
control range are accepted; the tool stops at its limit and the coupling pulls the hand back,
a virtual wall.
"""

from __future__ import annotations

import dataclasses
import json
import math
import struct

MAGIC = b"VSCR"
VERSION = 1
PORT = 47000                 # the server's default UDP port
MAX_MESSAGE_BYTES = 512      # every datagram; a larger one is dropped
MAX_TOOLS = 6                # per POSE or FORCE: 48 + 72 * 6 = 480 bytes
ANGLE_LIMIT_DEG = 360.0      # |angle| beyond this is not a pose but garbage: dropped
DEPTH_LIMIT_M = 1.0          # |depth| beyond this: dropped

HELLO, INFO, POSE, FORCE, BYE = 1, 2, 3, 4, 5
TYPES = {HELLO: "HELLO", INFO: "INFO", POSE: "POSE", FORCE: "FORCE", BYE: "BYE"}

FLAG_HOLDING = 1   # bit 0: the tool's jaws hold tissue
FLAG_WARNING = 2   # bit 1: a tissue force threshold is crossed

HEADER = struct.Struct("<4sHH")          # magic, version, type
HELLO_MSG = struct.Struct("<4sHHId")     # + sequence, client_time s
INFO_HEAD = struct.Struct("<4sHHII")     # + sequence, JSON length
POSE_HEAD = struct.Struct("<4sHHIdI")    # + sequence, client_time s, count
POSE_TOOL = struct.Struct("<I5d")        # tool, pitch deg, yaw deg, depth m, roll deg, jaw deg
FORCE_HEAD = struct.Struct("<4sHHIddIIIII")  # + sequence, client_time s, sim_time s, count, 4 drop counters
FORCE_TOOL = struct.Struct("<II8d")      # tool, flags, coupling (5: N m, N m, N, N m, N m), tissue (3: N)
BYE_MSG = struct.Struct("<4sHHI")        # + sequence
# the sizes the docstring's tables give
assert (HELLO_MSG.size, INFO_HEAD.size, POSE_HEAD.size, POSE_TOOL.size, FORCE_HEAD.size, FORCE_TOOL.size,
        BYE_MSG.size) == (20, 16, 24, 44, 48, 72, 12)
# what a value may be before it is garbage, per coordinate (pitch, yaw, depth, roll, jaw)
VALUE_LIMITS = (ANGLE_LIMIT_DEG, ANGLE_LIMIT_DEG, DEPTH_LIMIT_M, ANGLE_LIMIT_DEG, ANGLE_LIMIT_DEG)


class ProtocolError(ValueError):
    """A datagram that is not a valid message; `kind` names what is wrong (the server counts by it)."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind


@dataclasses.dataclass(frozen=True)
class Hello:
    sequence: int
    client_time_s: float


@dataclasses.dataclass(frozen=True)
class Info:
    sequence: int
    info: dict


@dataclasses.dataclass(frozen=True)
class Pose:
    sequence: int
    client_time_s: float
    # (index, (pitch deg, yaw deg, depth m, roll deg, jaw deg)) per tool
    tools: tuple[tuple[int, tuple[float, float, float, float, float]], ...]


@dataclasses.dataclass(frozen=True)
class ToolForce:
    tool: int
    flags: int
    coupling: tuple[float, float, float, float, float]  # N m, N m, N, N m, N m: render on the hand
    tissue: tuple[float, float, float]                  # N, world frame


@dataclasses.dataclass(frozen=True)
class Force:
    sequence: int
    client_time_s: float
    sim_time_s: float
    tools: tuple[ToolForce, ...]
    dropped: tuple[int, int, int, int]  # invalid, stale, flood, busy


@dataclasses.dataclass(frozen=True)
class Bye:
    sequence: int


Message = Hello | Info | Pose | Force | Bye


def _u32(value: int) -> int:
    return int(value) & 0xFFFFFFFF


def pack_hello(sequence: int, client_time_s: float) -> bytes:
    return HELLO_MSG.pack(MAGIC, VERSION, HELLO, _u32(sequence), float(client_time_s))


def pack_info(sequence: int, info: dict) -> bytes:
    """INFO with `info` as compact JSON; ValueError if it does not fit in one message."""
    payload = json.dumps(info, separators=(",", ":"), allow_nan=False).encode()
    message = INFO_HEAD.pack(MAGIC, VERSION, INFO, _u32(sequence), len(payload)) + payload
    if len(message) > MAX_MESSAGE_BYTES:
        raise ValueError(f"INFO is {len(message)} bytes, over the protocol's {MAX_MESSAGE_BYTES}")
    return message


def pack_pose(sequence: int, client_time_s: float, tools) -> bytes:
    """POSE of `tools`: (index, (pitch deg, yaw deg, depth m, roll deg, jaw deg)) pairs."""
    tools = list(tools)
    if len(tools) > MAX_TOOLS:
        raise ValueError(f"a POSE carries at most {MAX_TOOLS} tools, not {len(tools)}")
    parts = [POSE_HEAD.pack(MAGIC, VERSION, POSE, _u32(sequence), float(client_time_s), len(tools))]
    parts += [POSE_TOOL.pack(int(index), *map(float, values)) for index, values in tools]
    return b"".join(parts)


def pack_force(sequence: int, client_time_s: float, sim_time_s: float, tools, dropped=(0, 0, 0, 0)) -> bytes:
    """FORCE of `tools`: ToolForce or (tool, flags, coupling (5), tissue (3)) tuples."""
    tools = list(tools)
    if len(tools) > MAX_TOOLS:
        raise ValueError(f"a FORCE carries at most {MAX_TOOLS} tools, not {len(tools)}")
    fields = [MAGIC, VERSION, FORCE, _u32(sequence), float(client_time_s), float(sim_time_s), len(tools),
              *(_u32(d) for d in dropped)]
    for tool, flags, coupling, tissue in (dataclasses.astuple(t) if isinstance(t, ToolForce) else t for t in tools):
        fields += (int(tool), int(flags), *coupling, *tissue)
    return FORCE_ALL[len(tools)].pack(*fields)


def pack_bye(sequence: int) -> bytes:
    return BYE_MSG.pack(MAGIC, VERSION, BYE, _u32(sequence))


def check_values(values) -> str | None:
    """Why a tool's five values are not a pose (non-finite or garbage-large), or None."""
    for value, limit in zip(values, VALUE_LIMITS):
        if not math.isfinite(value):
            return "nan"
        if abs(value) > limit:
            return "range"
    return None


# one struct per tool count: a POSE's or FORCE's tools in one unpack or pack call (the server's hot path)
POSE_TOOLS = [struct.Struct("<" + "I5d" * n) for n in range(MAX_TOOLS + 1)]
FORCE_ALL = [struct.Struct(FORCE_HEAD.format + "II8d" * n) for n in range(MAX_TOOLS + 1)]
A, D = ANGLE_LIMIT_DEG, DEPTH_LIMIT_M


def unpack(data, size: int | None = None, accept=tuple(TYPES)) -> Message:
    """The message in the first `size` bytes of `data` (bytes, bytearray or memoryview); a
    ProtocolError (with its `kind`: oversized, short, magic, version, type, count, length, json,
    nan, range) when it is not one, or not of a type in `accept`. Values are checked here
    (finite, in bounds); whether a tool index exists is the server's to check."""
    size = len(data) if size is None else int(size)
    if size > MAX_MESSAGE_BYTES:
        raise ProtocolError("oversized", f"{size} bytes, over {MAX_MESSAGE_BYTES}")
    if size < HEADER.size:
        raise ProtocolError("short", f"{size} bytes, shorter than the header")
    magic, version, kind = HEADER.unpack_from(data, 0)
    if magic != MAGIC:
        raise ProtocolError("magic", f"magic {bytes(magic)!r}, not {MAGIC!r}")
    if kind not in accept:
        raise ProtocolError("type", f"type {kind} {'unknown' if kind not in TYPES else 'not expected here'}")
    if version != VERSION and kind != HELLO:
        raise ProtocolError("version", f"version {version}, this end speaks {VERSION}")
    if kind == POSE:
        if size < POSE_HEAD.size:
            raise ProtocolError("short", f"POSE of {size} bytes")
        _, _, _, sequence, client_time, count = POSE_HEAD.unpack_from(data, 0)
        if count > MAX_TOOLS:
            raise ProtocolError("count", f"POSE of {count} tools, over {MAX_TOOLS}")
        if size != POSE_HEAD.size + count * POSE_TOOL.size:
            raise ProtocolError("length", f"POSE of {count} tools in {size} bytes")
        if not math.isfinite(client_time):
            raise ProtocolError("nan", "POSE client_time is not finite")
        flat = POSE_TOOLS[count].unpack_from(data, POSE_HEAD.size)
        tools = []
        for i in range(0, 6 * count, 6):
            index, pitch, yaw, depth, roll, jaw = flat[i:i + 6]
            # abs(NaN) <= x is False: one comparison chain rejects NaN, inf and garbage
            if not (abs(pitch) <= A and abs(yaw) <= A and abs(depth) <= D and abs(roll) <= A and abs(jaw) <= A):
                why = check_values(flat[i + 1:i + 6])
                what = "not finite" if why == "nan" else "beyond bounds"
                raise ProtocolError(why, f"POSE tool {index}: {flat[i + 1:i + 6]} {what}")
            tools.append((index, (pitch, yaw, depth, roll, jaw)))
        return Pose(sequence, client_time, tuple(tools))
    if kind == HELLO:
        if size != HELLO_MSG.size:
            raise ProtocolError("length", f"HELLO of {size} bytes, not {HELLO_MSG.size}")
        _, _, _, sequence, client_time = HELLO_MSG.unpack_from(data, 0)
        return Hello(sequence, client_time)
    if kind == BYE:
        if size != BYE_MSG.size:
            raise ProtocolError("length", f"BYE of {size} bytes, not {BYE_MSG.size}")
        return Bye(BYE_MSG.unpack_from(data, 0)[3])
    if kind == INFO:
        if size < INFO_HEAD.size:
            raise ProtocolError("short", f"INFO of {size} bytes")
        _, _, _, sequence, length = INFO_HEAD.unpack_from(data, 0)
        if size != INFO_HEAD.size + length:
            raise ProtocolError("length", f"INFO of {length} JSON bytes in {size} bytes")
        try:
            info = json.loads(bytes(data[INFO_HEAD.size:size]).decode())
        except (UnicodeDecodeError, ValueError) as error:
            raise ProtocolError("json", f"INFO JSON: {error}") from None
        if not isinstance(info, dict):
            raise ProtocolError("json", "INFO JSON is not an object")
        return Info(sequence, info)
    # FORCE
    if size < FORCE_HEAD.size:
        raise ProtocolError("short", f"FORCE of {size} bytes")
    _, _, _, sequence, client_time, sim_time, count, *dropped = FORCE_HEAD.unpack_from(data, 0)
    if count > MAX_TOOLS:
        raise ProtocolError("count", f"FORCE of {count} tools, over {MAX_TOOLS}")
    if size != FORCE_HEAD.size + count * FORCE_TOOL.size:
        raise ProtocolError("length", f"FORCE of {count} tools in {size} bytes")
    tools = []
    for i in range(count):
        tool, flags, *values = FORCE_TOOL.unpack_from(data, FORCE_HEAD.size + i * FORCE_TOOL.size)
        tools.append(ToolForce(tool, flags, tuple(values[:5]), tuple(values[5:])))
    return Force(sequence, client_time, sim_time, tuple(tools), tuple(dropped))


def newer(sequence: int, than: int) -> bool:
    """Whether u32 `sequence` comes after `than`, wrapping at 2^32 (serial number arithmetic,
    RFC 1982): a client may run for 50 days at 1 kHz."""
    return 0 < ((sequence - than) & 0xFFFFFFFF) < 0x80000000
