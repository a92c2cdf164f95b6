"""One long-lived Blender process per Cycles scene, spoken to in JSON lines.

``bpy`` (Blender as a Python module) pins numpy below 2 and bnerr needs numpy 2, so Blender runs
in a Python of its own (:func:`bpy_python`: ``$BNERR_BPY_PYTHON``, else ``.venv-cycles`` beside
the checkout, which ``make cycles`` builds) as :mod:`renderers.cycles.worker`, a file that imports
only the standard library and ``bpy``. Scene set-up (a factory reset, building, opening a
``.blend``) costs more than a small frame, so a :class:`CyclesSession` holds its scene for every
frame it renders; :func:`session` keeps one per scene and process (a Ray worker has its own).

Blender's progress lines go to a private log file, never to bnerr's output; its last lines end
the error when the process dies.
"""

from __future__ import annotations

import atexit
import json
import os
import subprocess
import tempfile
from pathlib import Path

from bnerr.errors import ExternalProcessError, MissingExtraError

__all__ = ["CyclesSession", "bpy_python", "close_sessions", "session"]

_WORKER = Path(__file__).with_name("worker.py")
_CHECKOUT = Path(__file__).resolve().parents[2]
_SESSIONS: dict[str, CyclesSession] = {}


def bpy_python() -> Path:
    """The Python that has ``bpy``: ``$BNERR_BPY_PYTHON``, else ``.venv-cycles/bin/python`` in
    the checkout (``make cycles``).

    Raises:
        MissingExtraError: neither exists.
    """
    named = os.environ.get("BNERR_BPY_PYTHON")
    path = Path(named) if named else _CHECKOUT / ".venv-cycles" / "bin" / "python"
    if not path.exists():
        where = f"BNERR_BPY_PYTHON={named}" if named else str(path)
        raise MissingExtraError(
            "Cycles scenes", "cycles", "bpy (Blender as a Python module)", f"no Python at {where}"
        )
    return path


def _tail(log: Path, lines: int = 3) -> str:
    try:
        text = log.read_text(errors="replace").strip().splitlines()
    except OSError:
        return ""
    kept = [line.strip() for line in text if line.strip() and not line.startswith("Fra:")]
    return " | ".join(kept[-lines:])


class CyclesSession:
    """A Blender process holding one scene: ``source`` is ``{"op": "open", "blend": PATH}`` or
    ``{"op": "build", "recipe": {...}}``; :attr:`info` is what the worker found in it (Blender's
    version, the camera, the frame range, the patterns, the settings bnerr overrides).

    Raises:
        MissingExtraError: no Python with ``bpy``, or one where ``bpy`` does not import.
        ExternalProcessError: Blender refused the scene (its one-line reason).
    """

    def __init__(self, source: dict, label: str) -> None:
        self.label = label
        handle, name = tempfile.mkstemp(prefix="bnerr-cycles-", suffix=".log")
        os.close(handle)
        self.log = Path(name)
        python = bpy_python()
        with open(self.log, "w") as err:
            self.process = subprocess.Popen(
                [str(python), str(_WORKER)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=err,
                text=True,
                env={**os.environ, "PYTHONNOUSERSITE": "1"},
            )
        ready = self._read()
        if ready is None:
            got = _tail(self.log) or "a process that exited"
            self.close()
            raise MissingExtraError("Cycles scenes", "cycles", f"bpy under {python}", got)
        self.blender = str(ready.get("ready", ""))
        self.info: dict = self.ask(source)["info"]

    def _read(self) -> dict | None:
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        return json.loads(line) if line else None

    def ask(self, request: dict) -> dict:
        """Send one request; the worker's answer, or :class:`ExternalProcessError`."""
        if self.process.poll() is not None or self.process.stdin is None:
            raise ExternalProcessError(
                f"{self.label}: expected a running Blender, got one that exited ({_tail(self.log)})"
            )
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        answer = self._read()
        if answer is None:
            raise ExternalProcessError(
                f"{self.label}: expected Blender to answer {request['op']}, got a process that "
                f"exited with status {self.process.wait()} ({_tail(self.log)})"
            )
        if not answer.get("ok"):
            raise ExternalProcessError(f"{self.label}: Cycles: {answer.get('error')}")
        return answer

    def close(self) -> None:
        """End the process (politely, then by force) and remove its log."""
        if self.process.poll() is None:
            try:
                assert self.process.stdin is not None
                self.process.stdin.write('{"op": "quit"}\n')
                self.process.stdin.close()
                self.process.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                self.process.kill()
                self.process.wait()
        self.log.unlink(missing_ok=True)


def session(key: str, source: dict, label: str) -> CyclesSession:
    """The process holding scene ``key`` in this Python process, started on first use."""
    found = _SESSIONS.get(key)
    if found is None or found.process.poll() is not None:
        found = _SESSIONS[key] = CyclesSession(source, label)
    return found


def close_sessions() -> None:
    """End every Blender process this Python started (also at exit)."""
    while _SESSIONS:
        _SESSIONS.popitem()[1].close()


atexit.register(close_sessions)
