"""The test worker's side of zygote.py: start it once, hand it a case, get a pid back."""

from __future__ import annotations

import atexit
import json
import os
import socket
import subprocess
import sys
from pathlib import Path

ZYGOTE = Path(__file__).with_name("zygote.py")
_state: dict[str, object] = {}


def _connection() -> socket.socket:
    """The socket to this worker's zygote, started on first use (again if it died)."""
    proc = _state.get("proc")
    if isinstance(proc, subprocess.Popen) and proc.poll() is None:
        sock = _state["sock"]
        assert isinstance(sock, socket.socket)
        return sock
    ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    tests = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([tests, os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, str(ZYGOTE), str(theirs.fileno())],
                            pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL, env=env)
    theirs.close()
    _state.update(proc=proc, sock=ours)
    atexit.register(_stop)
    return ours


def _stop() -> None:
    sock, proc = _state.pop("sock", None), _state.pop("proc", None)
    if isinstance(sock, socket.socket):
        sock.close()  # the zygote reads an empty message and ends
    if isinstance(proc, subprocess.Popen):
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()


def start(argv: list[str], cwd: Path, env: dict[str, str], limits: dict[str, int],
          fds: list[int]) -> int:
    """Fork ``argv`` (an ``enc`` command) in ``cwd`` with ``env`` and resource ``limits``,
    its stdin, stdout, stderr and report pipe ``fds``; the pid of its minder (a session
    leader: ``os.killpg`` ends it and the command)."""
    sock = _connection()
    msg = json.dumps({"argv": argv, "cwd": str(cwd), "env": env, "limits": limits})
    socket.send_fds(sock, [msg.encode()], fds)
    return int(sock.recv(64))
