"""What every command shares: logging on stderr, progress, errors as one line.

``main()`` of :mod:`enctools.cli.main` calls :func:`run`, which turns every way a
command can end into the documented exit status:

0 done; 1 a check failed; 2 bad usage or bad input; 3 device fault;
130 interrupted (SIGINT), 143 terminated (SIGTERM). A closed downstream pipe ends
the command quietly with 0.
"""

from __future__ import annotations

import contextlib
import errno
import os
import sys
import time
from collections.abc import Callable
from typing import Any, NoReturn

import click

from enctools.errors import EncError, Interrupted

#: errors of this machine's files and resources, not of a device: exit 2 (a missing or
#: unreadable file, a full disk, a file-size limit, a quota, too many open files, a name
#: too long)
LOCAL_ERRORS = frozenset({
    errno.ENOENT, errno.EACCES, errno.EPERM, errno.EISDIR, errno.ENOTDIR, errno.EROFS,
    errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EMFILE, errno.ENFILE,
    errno.ENAMETOOLONG, errno.ELOOP, errno.ETXTBSY, errno.EEXIST,
})


def __getattr__(name: str) -> Any:
    """``runner.log``: the "enctools" logger, imported on first use (not by ``--help``)."""
    if name == "log":
        import logging
        return logging.getLogger("enctools")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def setup_logging(verbose: int = 0, quiet: int = 0) -> None:
    """Log to stderr: WARNING by default, -v INFO, -vv DEBUG, -q ERROR."""
    import logging

    level = logging.WARNING - 10 * verbose + 10 * quiet
    handler = logging.StreamHandler(sys.stderr)
    name = command_name()
    handler.setFormatter(_fields_formatter()(f"{name}: %(levelname)s: %(message)s"))
    root = logging.getLogger("enctools")
    root.handlers[:] = [handler]
    root.setLevel(max(logging.DEBUG, min(logging.CRITICAL, level)))
    root.propagate = False
    logging.raiseExceptions = False  # a message stderr cannot take (full) is dropped, not a failure
    # the libraries' own loggers (matplotlib, ...), which have no handler: the same
    # one-line form, warnings and errors only (errors only with -q)
    others = logging.StreamHandler(sys.stderr)
    others.setFormatter(handler.formatter)
    others.setLevel(logging.ERROR if quiet > 0 else logging.WARNING)
    logging.lastResort = others
    import warnings
    warnings.showwarning = _warning_line
    _state["quiet"] = quiet > 0


def _fields_formatter() -> type[Any]:
    import logging

    class Fields(logging.Formatter):
        """A log line whose settings, named by their fields between backticks as the
        library names them in errors, are shown as the command's options, and whose text
        from files (names, descriptions) is shown escaped, never obeyed
        (:func:`enctools.data.text.printable`, line by line)."""

        def format(self, record: logging.LogRecord) -> str:
            from enctools.data.text import printable

            text = super().format(record)
            text = _text(EncError(text)) if "`" in text else text
            return "\n".join(printable(line) for line in text.split("\n"))

    return Fields


def _warning_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """A Python warning (numpy's RuntimeWarning, a library's deprecation) as one line of
    the command's log, ``enc CMD: WARNING: message``, without the file and the source
    line; silenced by -q like every warning."""
    from enctools.data.text import printable

    log_warning(printable(" ".join(str(message).split())) or category.__name__)


_state: dict[str, Any] = {"command": "enc", "quiet": False}


def set_command(name: str, command: click.Command | None = None) -> None:
    """Name the command running (``name``: ``make-rom``), whose options name the settings
    of its errors (:func:`enctools.cli.usage.message`)."""
    _state["command"] = f"enc {name}"
    _state["name"], _state["click"] = name, command


def set_program(name: str, command: click.Command | None = None) -> None:
    """Name a command that is its own executable (``enc-nightly``) in its messages."""
    _state["command"] = name
    _state["name"], _state["click"] = name, command


def command_name() -> str:
    return str(_state["command"])


class Progress:
    """A progress line on stderr, only when stderr is a terminal and not quiet."""

    def __init__(self, what: str, unit: str = "") -> None:
        self.what = what
        self.unit = unit
        self.enabled = sys.stderr.isatty() and not _state["quiet"]
        self._last = 0.0
        self._start = time.monotonic()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self._last < 0.2 and done < total:
            return
        self._last = now
        unit = f" {self.unit}" if self.unit else ""
        if total <= 0:  # the total is not known: the count so far
            sys.stderr.write(f"\r{command_name()}: {self.what} {done}{unit} "
                             f"({now - self._start:.1f} s)")
            _state["progress_open"] = True
        else:
            pct = 100.0 * done / total
            sys.stderr.write(f"\r{command_name()}: {self.what} {pct:5.1f}% "
                             f"({done}/{total}{unit}, {now - self._start:.1f} s)")
            _state["progress_open"] = done < total
            if done >= total:
                sys.stderr.write("\n")
        sys.stderr.flush()

    def every(self, total: int) -> Callable[[int], None]:
        """A progress callback of one argument (done) out of ``total`` expected (a method
        that counts what it has done but not what is to come; 0: not known)."""
        return lambda done: self(done, max(total, done) if total > 0 else 0)


def expected_rows(meta: dict[str, Any]) -> int:
    """The rows a continuous run's settings promise (revolutions, speed [r/min],
    interval [s]); 0 when they do not say."""
    s = meta.get("settings") or {}
    try:
        seconds = float(s["revolutions"]) * 60.0 / abs(float(s["speed_rpm"]))
        return max(int(seconds / float(s["interval_s"])), 0)
    except (KeyError, TypeError, ValueError, ZeroDivisionError, OverflowError):
        return 0


class RowsRead:
    """A stream whose ``batches()`` report the rows read to a progress line; everything
    else is the stream's own."""

    def __init__(self, source: Any, what: str = "rows read") -> None:
        self._source = source
        self._progress = Progress(what, "rows").every(expected_rows(source.meta))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._source, name)

    def batches(self, *args: Any, **kwargs: Any) -> Any:
        rows = 0
        for b in self._source.batches(*args, **kwargs):
            rows += b.num_rows
            self._progress(rows)
            yield b


def end_progress() -> None:
    """End a progress line left open (the work stopped short of its total), so that
    what is written next on stderr starts a line of its own."""
    if _state.get("progress_open"):
        _state["progress_open"] = False
        sys.stderr.write("\n")
        sys.stderr.flush()


def _terminate(signum: int, frame: Any) -> NoReturn:
    raise Interrupted.by_signal(signum)


def is_quiet() -> bool:
    """True when the command was given -q (summaries on stderr are left out)."""
    return bool(_state["quiet"])


def prologue(verbose: int = 0, quiet: int = 0) -> None:
    """What every command does first: logging (-v/-q) with the warnings found while the
    options were parsed, streaming tuning, the ending signals (SIGTERM -> 143, ...)."""
    from enctools.cli.tuning import tune_for_streaming
    from enctools.cli.usage import take_deferred

    setup_logging(verbose, quiet)
    for text in take_deferred():
        log_warning(text)
    tune_for_streaming()  # before numpy: one BLAS thread; malloc keeps its memory
    install_sigterm()


def log_warning(text: str) -> None:
    """``text`` as one warning line of the command's log."""
    import logging

    logging.getLogger("enctools").warning("%s", text)


def install_sigterm() -> None:
    """Turn SIGTERM (exit 143) and the other signals that end a process by default
    (``errors.ending_signals``: SIGHUP, SIGQUIT, SIGUSR1, SIGUSR2, SIGALRM, SIGXCPU, ...,
    the real-time ones; exit 128 + the number) into an Interrupted exception, so that
    outputs end whole or not at all. A signal the command was started with ignored
    (nohup, a background job) stays ignored."""
    import signal

    from enctools.errors import ending_signals

    for sig in ending_signals(sigint=False):
        signal.signal(sig, _terminate)


def _quiet_stdout() -> None:
    # Python flushes stdout at exit; point it at /dev/null so that raises nothing.
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def standard_streams() -> None:
    """Make the process safe when it was started with stdin, stdout or stderr closed
    (``<&-``, ``>&-``, ``2>&-``): each closed descriptor gets /dev/null, so no file the
    command opens takes its number. A closed stdin or stdout stays None as Python set it
    (reading or writing a stream there is refused in one line); a closed stderr becomes
    /dev/null, so a command that succeeds still succeeds, its messages unread."""
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
    if sys.stderr is None:
        sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115 - the process's own


def exit_now(status: int) -> NoReturn:
    """End the process with ``status`` once stdout and stderr are flushed, without the
    interpreter's teardown: every output is closed when a command returns, and tearing
    down numpy, pyarrow and the rest module by module costs a short command a third of
    its CPU. The functions registered with :mod:`atexit` run (a private folder of
    matplotlib's removed, enctools.report.plots.matplotlib_ready)."""
    import atexit

    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed pipe downstream, a full stderr
            pass
    os._exit(status)


def error(message: str) -> None:
    """Print one line: ``enc CMD: error: message``, its control characters escaped.

    A message may quote a file name, a column or a device's reply: none of them may
    clear the screen, set the title or start a line of its own.
    """
    from enctools.data.text import printable

    first = printable(" ".join(str(message).split())) or "error"
    end_progress()
    with contextlib.suppress(OSError, ValueError):  # stderr full (2>/dev/full): the status says it
        sys.stderr.write(f"{command_name()}: error: {first}\n")
        sys.stderr.flush()


def _interruption(exc: BaseException) -> BaseException | None:
    """The SIGINT or SIGTERM in ``exc``'s chain of causes, if one is there.

    A signal lands wherever the interpreter is: inside an import, Python reports the
    exception a class body raised as ``RuntimeError: Error calling __set_name__``
    with the interruption as its cause.
    """
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, (Interrupted, KeyboardInterrupt)):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__  # type: ignore[assignment]
    return None


def _text(exc: EncError) -> str:
    """An error's line, the settings it names as the command's options."""
    if not exc.fields:
        return str(exc)
    from enctools.cli.usage import message

    return message(exc, _state.get("click"), _state.get("name"))


def run(invoke: Callable[[], Any], debug: bool) -> int:
    """Run a command; map its ending to an exit status with one line on stderr."""
    try:
        invoke()
        return 0
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.UsageError as exc:
        if type(exc).__name__ == "NoArgsIsHelpError" and exc.ctx is not None:
            sys.stderr.write(exc.ctx.get_help() + "\n")
            return 2
        if exc.ctx is not None:
            _state["command"] = exc.ctx.command_path
        hint = f" (see '{command_name()} --help')"
        error(exc.format_message() + hint)
        return 2
    except click.Abort:
        error("interrupted")
        return 130
    except KeyboardInterrupt:
        error("interrupted")
        return 130
    except EncError as exc:
        if debug:
            import traceback
            traceback.print_exc()
        error(_text(exc))
        return exc.exit_code
    except BrokenPipeError:
        _quiet_stdout()
        return 0
    except OSError as exc:
        if exc.errno == errno.EPIPE:
            _quiet_stdout()
            return 0
        if debug:
            import traceback
            traceback.print_exc()
        where = f" ({exc.filename})" if exc.filename else ""
        error(f"{exc.strerror or exc}{where}")
        return 2 if exc.errno in LOCAL_ERRORS else 3
    except Exception as exc:  # noqa: BLE001 - a bug: one line unless --debug
        stop = _interruption(exc)
        if stop is not None:  # SIGINT/SIGTERM wrapped by the code it landed in
            error(str(stop) if isinstance(stop, Interrupted) else "interrupted")
            return stop.exit_code if isinstance(stop, Interrupted) else 130
        if debug:
            import traceback
            traceback.print_exc()
        error(f"internal error: {type(exc).__name__}: {exc} (run with --debug for a traceback)")
        return 2
