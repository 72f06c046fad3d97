"""A meshcat 0.3.2 server bound to one address (loopback by default).

meshcat's own server binds its web port on every interface (0.0.0.0 and
[::]): a surgeon's laptop on a hospital network must not expose the view.
This runs the same bridge, but its web server listens on `--host` only.

    python -m viscera.meshcat_server [--host 127.0.0.1]

prints ``zmq_url=...`` and ``web_url=...`` lines like meshcat-server does.
"""

from __future__ import annotations

import argparse

from meshcat.servers.zmqserver import ZMQWebSocketBridge


class BoundBridge(ZMQWebSocketBridge):
    """meshcat's ZMQ-to-websocket bridge whose web server binds `host` only."""

    def make_app(self):
        app = super().make_app()
        listen, host = app.listen, self.host  # __init__ sets host before make_app

        def listen_on_host(port, address=None, **kwargs):
            return listen(port, address=host, **kwargs)

        app.listen = listen_on_host
        return app


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--host", default="127.0.0.1", help="address to serve on (default: loopback only)")
    args = parser.parse_args(argv)
    bridge = BoundBridge(host=args.host)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
