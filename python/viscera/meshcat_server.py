"""The meshcat server behind viscera's viewer: meshcat 0.3.2's page, our own bridge.

    python -m viscera.meshcat_server [--host 127.0.0.1] [--port 7000] [--parent PID]

prints zmq_url=... and web_url=... lines like meshcat-server does, then serves
meshcat's bundled page on `--host` only (loopback by default: meshcat's own server
listens on every interface) and takes drawing commands on a loopback zmq ROUTER socket.

Why not meshcat's bridge: it answers every command (REQ/REP), so the simulation waits
for the server on each one; it writes to websockets as they close and leaves the
failed writes' tracebacks on stderr, and once those fill the pipe nobody reads, the
server blocks and the simulation dies on its request timeout (issue 18). Here:

- commands arrive one way (the viewer never waits for an answer, except `sync`);
- the scene keeps the latest command per (kind, path, property), in order, so a
  browser that connects gets the current state, not the history;
- each browser has its own pending set with the same rule and is sent a batch only
  when its previous batch has left: a slow browser sees fewer frames (latest state
  wins), never holds up the others or the simulation, and costs bounded memory;
- after start-up nothing is printed (stdout and stderr go to /dev/null): an unread
  pipe can never block the server again;
- with `--parent PID` the server exits when that process ends, even by SIGKILL: at
  end of file on stdin (the viewer holds the pipe's other end) or when its parent
  process changes (the pipe may have been inherited by a fork).
"""

from __future__ import annotations

import argparse
import asyncio
import errno
import json
import os
import signal

import tornado.web
import tornado.websocket
import zmq
from zmq.eventloop.zmqstream import ZMQStream

VIEWER_ROOT = os.path.join(os.path.dirname(__import__("meshcat").__file__), "viewer", "dist")
FIRST_PORT = 7000  # meshcat's default, then upwards


class Scene:
    """Drawing commands, the latest per (kind, path, property) kept, in the order last set.

    A delete drops what it removes; with `keep_deletes` the delete itself is kept (a
    browser that already shows the path must be told), otherwise it is forgotten (a
    new browser never had the path).
    """

    def __init__(self, keep_deletes: bool, commands: dict | None = None):
        self.keep_deletes = keep_deletes
        self.commands: dict[tuple[bytes, bytes, bytes], bytes] = dict(commands or {})

    def add(self, kind: bytes, path: bytes, prop: bytes, data: bytes) -> None:
        if kind == b"delete":
            below = path.rstrip(b"/") + b"/"
            for key in [k for k in self.commands if k[1] == path or k[1].startswith(below)]:
                del self.commands[key]
            if not self.keep_deletes:
                return
        key = (kind, path, prop)
        self.commands.pop(key, None)  # re-inserted last: it now comes after what it follows
        self.commands[key] = data

    def copy(self, keep_deletes: bool) -> "Scene":
        return Scene(keep_deletes, self.commands)

    def take(self) -> list[bytes]:
        messages = list(self.commands.values())
        self.commands.clear()
        return messages

    def __len__(self) -> int:
        return len(self.commands)


class NoCacheStaticFiles(tornado.web.StaticFileHandler):
    def set_extra_headers(self, path):
        self.set_header("Cache-Control", "no-store, no-cache, must-revalidate, max-age=0")


class Browser(tornado.websocket.WebSocketHandler):
    """One browser tab: sent the scene on connect, then batches of what changed."""

    def initialize(self, server: "Server") -> None:
        self.server = server
        self.pending = Scene(keep_deletes=True)
        self.sending = False

    def open(self) -> None:
        self.pending = self.server.scene.copy(keep_deletes=True)
        self.server.browsers.add(self)
        self.server.connections += 1
        self.kick()

    def on_message(self, message) -> None:
        pass  # meshcat's page answers capture_image requests only; we send none

    def on_close(self) -> None:
        self.server.browsers.discard(self)
        self.pending = Scene(keep_deletes=True)

    def kick(self) -> None:
        if not self.sending and self.pending:
            self.sending = True
            self.server.tasks.add(task := asyncio.ensure_future(self._send()))
            task.add_done_callback(self.server.tasks.discard)

    async def _send(self) -> None:
        try:
            while self.pending and self in self.server.browsers:
                writes = [self.write_message(message, binary=True) for message in self.pending.take()]
                # waits until the batch has left for the browser; meanwhile new commands
                # replace older ones in `pending` (return_exceptions: a closed socket's
                # failures are retrieved here, not logged)
                results = await asyncio.gather(*writes, return_exceptions=True)
                if any(isinstance(result, Exception) for result in results):
                    break
        except tornado.websocket.WebSocketClosedError:
            pass  # closing: on_close forgets this browser
        finally:
            self.sending = False


class Server:
    def __init__(self, host: str, port: int | None):
        self.scene = Scene(keep_deletes=False)
        self.browsers: set[Browser] = set()
        self.tasks: set[asyncio.Task] = set()
        self.connections = 0
        self.commands = 0
        self.dropped = 0  # malformed messages, not handled
        self.stopped = asyncio.Event()
        app = tornado.web.Application([
            (r"/static/(.*)", NoCacheStaticFiles, {"path": VIEWER_ROOT, "default_filename": "index.html"}),
            (r"/", Browser, {"server": self}),
        ])
        self.http = self._listen(app, host, port)
        netloc = f"[{host}]" if ":" in host else host  # an IPv6 literal needs brackets in a URL
        self.web_url = f"http://{netloc}:{self.web_port}/static/"
        self.context = zmq.Context()
        self.socket = self.context.socket(zmq.ROUTER)
        self.socket.setsockopt(zmq.LINGER, 0)
        zmq_port = self.socket.bind_to_random_port("tcp://127.0.0.1")  # the simulation is local
        self.zmq_url = f"tcp://127.0.0.1:{zmq_port}"
        self.stream = ZMQStream(self.socket)
        self.stream.on_recv(self._on_command)

    def _listen(self, app, host: str, port: int | None):
        for candidate in [port] if port else range(FIRST_PORT, FIRST_PORT + 1000):
            try:
                http = app.listen(candidate, address=host)
            except OSError as error:
                if port or error.errno != errno.EADDRINUSE:  # a bad address fails on every port
                    raise
                continue
            self.web_port = candidate
            return http
        raise OSError(f"no free port in {FIRST_PORT}-{FIRST_PORT + 999} on {host}")

    def _on_command(self, frames: list[bytes]) -> None:
        """One message from a viewer: [identity, b"sync", token] or [identity, kind, path, property, data].

        A malformed message is dropped, and so is one whose handling fails: an exception
        escaping here would stop the stream, and the server with it, for good."""
        try:
            self._handle(frames)
        except Exception:  # noqa: BLE001 - nobody reads stderr: drop the message, keep serving
            self.dropped += 1

    def _handle(self, frames: list[bytes]) -> None:
        if len(frames) == 3 and frames[1] == b"sync":
            # everything sent before it is in the scene: say so, with the browser counts
            identity, _, token = frames
            status = {"browsers": len(self.browsers), "connections": self.connections, "commands": self.commands,
                      "dropped": self.dropped}
            self.socket.send_multipart([identity, b"sync", token, json.dumps(status).encode()])
            return
        if len(frames) != 5 or frames[1] == b"sync":
            self.dropped += 1
            return
        _, kind, path, prop, data = frames
        self.commands += 1
        self.scene.add(kind, path, prop, data)
        for browser in self.browsers:
            browser.pending.add(kind, path, prop, data)
            browser.kick()

    def close(self) -> None:
        self.http.stop()
        self.stream.close()
        self.context.term()


def _quiet_after_start() -> None:
    """Send stdout and stderr to /dev/null: nobody reads them after the URLs."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    os.close(devnull)


def _watch_parent(server: Server, parent: int) -> None:
    loop = asyncio.get_running_loop()

    def on_stdin() -> None:
        try:
            chunk = os.read(0, 4096)
        except OSError:
            chunk = b""
        if not chunk:  # end of file: every holder of the pipe's other end is gone
            loop.remove_reader(0)
            server.stopped.set()

    loop.add_reader(0, on_stdin)

    def check() -> None:
        if os.getppid() != parent:  # reparented: the parent died
            server.stopped.set()
        else:
            loop.call_later(0.5, check)

    check()


async def serve(args: argparse.Namespace) -> None:
    server = Server(args.host, args.port)
    print(f"zmq_url={server.zmq_url}", flush=True)
    print(f"web_url={server.web_url}", flush=True)
    _quiet_after_start()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(signum, server.stopped.set)
    if args.parent is not None:
        _watch_parent(server, args.parent)
    try:
        await server.stopped.wait()
    finally:
        server.close()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m viscera.meshcat_server", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--host", default="127.0.0.1", help="address to serve the page on (default: loopback only)")
    parser.add_argument("--port", type=int, help=f"web port (default: the first free from {FIRST_PORT})")
    parser.add_argument("--parent", type=int, metavar="PID",
                        help="exit when process PID ends or stdin closes (MeshcatViewer passes its own pid)")
    asyncio.run(serve(parser.parse_args(argv)))


if __name__ == "__main__":
    main()
