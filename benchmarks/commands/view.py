"""``bnerr view [DIR]``: serve a results folder on localhost and print its address.

bnerr view                      # results/, at http://127.0.0.1:8000/
bnerr view out --port 0         # any free port

A plain standard-library server (:mod:`http.server`), read-only, for a results folder written by
``bnerr bench`` (its ``index.html`` and every suite's page). From a remote machine, forward the
port (``ssh -L 8000:localhost:8000 host``) and open the printed address. Ctrl-C stops it.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import signal
from pathlib import Path

from benchmarks.commands._args import port_int
from bnerr.errors import ValueRangeError

__all__ = ["make_server", "register", "run"]


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:  # `format`: the base's name
        pass  # one line per request would bury the address


def make_server(
    folder: str | Path, host: str = "127.0.0.1", port: int = 8000
) -> http.server.ThreadingHTTPServer:
    """A :class:`http.server.ThreadingHTTPServer` serving ``folder`` (not started).

    Raises:
        ValueRangeError: ``folder`` is not a folder holding an ``index.html``.
        OSError: the port cannot be bound.
    """
    root = Path(folder)
    if not root.is_dir():
        raise ValueRangeError(f"{root}: expected a results folder, got no folder there")
    if not (root / "index.html").is_file():
        raise ValueRangeError(
            f"{root}: expected a results folder with index.html (written by bnerr bench), got none"
        )
    handler = functools.partial(_QuietHandler, directory=str(root))
    return http.server.ThreadingHTTPServer((host, port), handler)


def _stop(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    # Ctrl-C and SIGTERM stop the server even where the parent started bnerr with SIGINT ignored
    # (a background job of a non-interactive shell, some test runners): Python then leaves it
    # ignored, and serve_forever would never return.
    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    server = make_server(args.dir, args.host, args.port)
    host, port = str(server.server_address[0]), server.server_address[1]
    print(f"serving {args.dir} at http://{host}:{port}/ (Ctrl-C stops)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "view",
        help="serve a results folder on localhost",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("dir", nargs="?", type=Path, default=Path("results"), metavar="DIR")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    p.add_argument("--port", type=port_int, default=8000, help="port (default 8000; 0: any free)")
    p.set_defaults(func=run)
