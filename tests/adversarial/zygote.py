"""A process that has imported ``enc`` once and forks a fresh command for each case.

Started by runner.py (one per test worker), it waits on a Unix socket for a case: its
argv, folder, environment and resource limits, and its stdin, stdout, stderr and report
pipe as file descriptors. For each it forks a *minder* in a new session, which forks the
*command*: the command sets up its descriptors, folder, environment, limits and signal
dispositions as exec would have left them, and runs ``enctools.cli.main.main()`` as the
``enc`` script does (which ends the process itself). The minder forwards the signals a
case sends, waits for the command with ``wait4`` and writes "maxrss_kib cpu_s status" to
the report pipe, as peak.py does for a command it execs.

What a fork skips is the interpreter's start and the imports (~0.2 s of CPU a case);
what it keeps is the state of a process that has imported enctools and run nothing.
``enc``'s own start (tuning.one_blas_thread before numpy) is done here first, the same
way. The environment a command sees is the case's: nothing enctools reads from it is
read at import.
"""

from __future__ import annotations

import atexit
import json
import os
import resource
import signal
import socket
import sys

from enctools.errors import ending_signal_numbers

#: every signal a command catches as its ending: passed on by the minder, at its default
#: in the command as exec leaves it
FORWARDED = ending_signal_numbers()
LIMITS = {"as": resource.RLIMIT_AS, "fsize": resource.RLIMIT_FSIZE,
          "nofile": resource.RLIMIT_NOFILE, "cpu": resource.RLIMIT_CPU}
CPU_GRACE = 10  # as runner.CPU_GRACE: SIGXCPU at the case's limit, SIGKILL this much later


def _command(req: dict, fds: list[int]) -> None:
    """The case's command, in the forked child: never returns."""
    code = 70
    try:
        stdin, out, err, _report = fds
        for fd, to in ((stdin, 0), (out, 1), (err, 2)):
            os.dup2(fd, to)
        for fd in fds:
            os.close(fd)
        os.chdir(req["cwd"])
        os.environ.clear()
        os.environ.update(req["env"])
        for key, value in req["limits"].items():
            hard = value + CPU_GRACE if key == "cpu" else value
            resource.setrlimit(LIMITS[key], (value, hard))
        for sig in FORWARDED:
            signal.signal(sig, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)  # as Python starts
        sys.argv = list(req["argv"])
        # what the libraries registered with atexit when the zygote imported them belongs
        # to threads the fork did not copy (pyarrow 14's S3 finalizer joins an event loop
        # thread: every command hung at its exit); the command's own functions are kept
        atexit._clear()
        from enctools.cli.main import main

        main()  # ends the process (runner.exit_now) once the command has run
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:  # noqa: BLE001 - as the interpreter would: a traceback, status 1
        import traceback

        traceback.print_exc()
        code = 1
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # noqa: BLE001 - a closed stream: nothing to flush
                pass
        os._exit(code)


def _minder(req: dict, fds: list[int]) -> None:
    """Fork the command, pass signals on, report its peak memory, CPU and status."""
    os.setsid()
    signal.signal(signal.SIGCHLD, signal.SIG_DFL)
    pid = os.fork()
    if pid == 0:
        _command(req, fds)
    report = fds[3]
    for fd in fds[:3]:
        os.close(fd)
    for sig in FORWARDED:
        signal.signal(sig, lambda s, _frame: os.kill(pid, s))
    _, status, usage = os.wait4(pid, 0)
    os.write(report, f"{usage.ru_maxrss} {usage.ru_utime + usage.ru_stime} {status}".encode())
    os.close(report)
    os._exit(0)


def serve(sock: socket.socket) -> None:
    signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # minders are reaped by the kernel
    while True:
        msg, fds, _, _ = socket.recv_fds(sock, 1 << 20, 4)
        if not msg:
            return
        req = json.loads(msg)
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            sock.close()
            try:
                _minder(req, fds)
            finally:
                os._exit(70)
        for fd in fds:
            os.close(fd)
        sock.send(str(pid).encode())


def main() -> None:
    from enctools.cli.tuning import one_blas_thread

    one_blas_thread()  # before numpy, as enc does
    import h5py  # noqa: F401
    import numpy  # noqa: F401
    import pyarrow  # noqa: F401  (not pyarrow.parquet: with pyarrow 14 it starts S3's thread)

    import enctools.cli.main  # noqa: F401

    serve(socket.socket(fileno=int(sys.argv[1])))


if __name__ == "__main__":
    main()
