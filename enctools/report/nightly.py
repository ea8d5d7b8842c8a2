"""The nightly recheck: re-run a campaign on a rig, compare with the stored calibration,
append the run to the history dataset; the command is ``enc-nightly``
(:mod:`enctools.cli.nightly`).

1. Run the campaign (:class:`Campaign`): a callable given the rig, a fresh folder and
   the run's id that leaves its result stream in ``result.parquet`` of that folder
   (the command's default runs the polygon check of seed 001 through the library, a
   step run and its points, in-process: :mod:`enctools.cli.campaign`; a user's script
   runs as a process of its own).
2. Report on the result (figures of its first deviation curve [arcsec]).
3. Compare with the stored calibration (a points or deviations stream): drift =
   current - stored at the current positions (the stored curve interpolated
   periodically), mean offset removed (an encoder's zero is arbitrary);
   ``drift_max`` = max |drift|, ``drift_pp`` = its peak-to-peak.
4. Append one row to the history table (:mod:`.history`), in the partition of the rig's
   name (a rig file's ``name``), whatever happened: one transaction, a retry of the same
   run id adding nothing.
5. The exit status: 0 (within tolerance), 1 (drift > tolerance), 2 (bad usage or
   input), 3 (the campaign reported a device fault) or the campaign's own failing
   status.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from enctools.errors import DataError, EncError, Interrupted, SettingsError, signals_held

if TYPE_CHECKING:  # numpy, pyarrow and the report are imported when a night runs
    import numpy as np

    from enctools.report.sections import Curve, Section
    from enctools.report.summary import Report

RESULT = "result.parquet"
"""The name of the result stream a campaign leaves in its folder."""


class CampaignFailed(EncError):
    """A campaign that ended with a failing exit status of its own (1, 3, or another:
    exit 2); ``status``: the night's in the history (``error``, or ``timeout`` for one
    stopped at its time limit)."""

    def __init__(self, message: str, exit_code: int = 2, status: str = "error") -> None:
        super().__init__(message)
        self.exit_code = exit_code
        self.status = status


@dataclass(frozen=True)
class Campaign:
    """What a night measures: ``run(rig, folder, run_id)`` leaves the result stream in
    ``folder / RESULT`` (a points or deviations stream) or raises an
    :class:`~enctools.errors.EncError` (:class:`CampaignFailed` with its exit status);
    ``text``: how the history records it."""

    run: Callable[[str, Path, str], object]
    text: str


@dataclass(frozen=True)
class Settings:
    """One nightly recheck.

    ``rig``: the rig the campaign measures (a name or rig file); ``history_dir``: the
    history (a folder or an object-store URI); ``calibration``: the stored calibration
    stream; ``campaign``: what is run (:class:`Campaign`); ``tolerance``: largest allowed
    |drift| [arcsec]; ``init``: store this run as the calibration when there is none;
    ``keep``: folder in which each night's outputs are kept, in a new subfolder named by
    its run id (default: a removed temporary folder); ``html``: also write the HTML
    report here.
    """

    rig: str
    history_dir: str
    calibration: str
    campaign: Campaign | None = None
    tolerance: float = 0.5
    init: bool = False
    keep: str | None = None
    html: str | None = None

    def __post_init__(self) -> None:
        if not (self.tolerance >= 0 and math.isfinite(self.tolerance)):
            msg = f"`tolerance` must be >= 0, not {self.tolerance}"
            raise SettingsError(msg)
        from enctools.report.partitions import rig_folder

        try:  # the rig names the history's partition folder
            rig_folder(self.rig)
        except ValueError as exc:
            msg = f"`rig`: {exc}"
            raise SettingsError(msg) from None


@dataclass
class Night:
    """What one run did: exit status, the summary line (stdout) and the messages
    (stderr) in the order they arose, each ``("error" | "info", text)``; a setting named
    in them (a field between backticks) is said in ``words`` (None: the field)."""

    code: int = 2
    status: str = "error"          # ok, drift, error, interrupted (a signal) or timeout
    summary: str | None = None
    messages: list[tuple[str, str]] = field(default_factory=list)
    words: Callable[[str], str] | None = None

    def say(self, text: str) -> str:
        """``text`` with each setting it names (```field```) in this night's words."""
        return EncError(text).render(self.words or (lambda name: name))

    def fail(self, why: str, code: int, record: dict[str, Any],
             summary: str | None = None, status: str = "error") -> None:
        """End the run with an error: say why, keep it (or ``summary``) and ``status`` for
        the history."""
        why = self.say(why)
        self.messages.append(("error", why))
        self.code, self.status = code, status
        if record:  # else the row is written already
            record["summary_json"] = json.dumps({"error": summary or why})


@dataclass
class Drift:
    """Current minus stored calibration [arcsec], mean offset removed."""

    angle_deg: np.ndarray
    drift: np.ndarray
    offset: float

    @property
    def max_abs(self) -> float:
        """Largest |drift| [arcsec]."""
        return float(abs(self.drift).max())

    @property
    def pp(self) -> float:
        """Peak-to-peak of the drift [arcsec]."""
        return float(self.drift.max() - self.drift.min())


def main_curve(section: Section) -> Curve:
    """The curve a nightly run tracks: the first deviation curve [arcsec] of a section."""
    for c in section.curves:
        if c.unit == "arcsec" and c.role in ("deviation", "points", "positioning") \
                and c.domain == "revolution":
            return c
    msg = f"{section.source}: no deviation curve [arcsec] to compare ({section.kind} stream)"
    raise DataError(msg)


def drift(current: Curve, stored: Curve) -> Drift:
    """Drift [arcsec] of a curve against the stored one (angles [rad]), on the current
    curve's angles [deg], the mean offset removed."""
    import numpy as np

    from enctools.units import DEG

    x = np.mod(np.asarray(current.angle) / DEG, 360.0)
    xs = np.mod(np.asarray(stored.angle) / DEG, 360.0)
    order = np.argsort(xs)
    ref = np.interp(x, xs[order], stored.values[order], period=360.0)
    d = current.values - ref
    offset = float(d.mean())
    return Drift(x, d - offset, offset)


def run_nightly(s: Settings, words: Callable[[str], str] | None = None) -> Night:
    """One nightly run (steps 1-4 above); the history gets its row whatever happens.
    ``words``: a setting's field -> the words that name it in the night's messages (a
    command: its option).

    SIGINT, SIGTERM and the other signals that end a process (``errors.ENDING_SIGNALS``,
    once the command has turned them into :class:`~enctools.errors.Interrupted`) end the
    night as a failure (exit 128 + the signal's number) recorded with the status
    ``interrupted``; they wait while the row is written and the work folder removed, so
    a signal never leaves half of either. An OS error (a full disk, no permission, a
    read-only file system) is one message naming the file, exit 2.
    """
    night = Night(words=words)
    # the rig file's stem until its name is read (a file that cannot be read: the row's)
    record: dict[str, Any] = {"run_id": "", "tolerance": s.tolerance,
                              "rig": Path(s.rig).stem if s.rig.endswith(".toml") else s.rig,
                              "campaign": s.campaign.text if s.campaign else ""}
    work: Path | None = None
    lock: int | None = None
    try:
        with signals_held():  # a signal inside an import would leave numpy unusable for the row
            import deltalake  # noqa: F401 - what append_run needs, imported whole
            import pyarrow.dataset  # noqa: F401

            from enctools.report.history import new_run_id

            record["run_id"] = new_run_id()
            record["rig"] = history_rig(s.rig)
            work, lock = _work_folder(s, record["run_id"])
        _recheck(s, work, record, night)
    except Interrupted as exc:  # SIGTERM (exit 143), SIGHUP (129)...
        night.fail(exc.template, exc.exit_code, record, status="interrupted")
    except EncError as exc:
        night.fail(exc.template, exc.exit_code, record)
    except KeyboardInterrupt:
        night.fail("interrupted", 130, record, status="interrupted")
    except OSError as exc:  # a folder that cannot be made, a full disk: one line, exit 2
        night.fail(os_message(exc), 2, record)
    finally:  # a run that failed early is recorded too
        with signals_held():
            if record:
                record |= {"status": night.status, "exit_code": night.code}
                _record_row(s, record, night)
            if work is not None and not s.keep:
                shutil.rmtree(work, ignore_errors=True)
            if lock is not None:
                os.close(lock)
    return night


def os_message(exc: OSError, what: str | None = None) -> str:
    """An OS error as one line naming its file (or ``what``)."""
    where = exc.filename or what
    return f"{where}: {exc.strerror or exc}" if where else str(exc.strerror or exc)


def _record_row(s: Settings, record: dict[str, Any], night: Night) -> bool:
    """Append ``record`` to the history (then empty it); False, told, when it cannot be."""
    from enctools.report.history import append_run

    with signals_held():
        try:
            append_run(s.history_dir, record)
            return True
        except (OSError, EncError) as exc:
            why = "this run cannot be added to the history: " + (
                os_message(exc, s.history_dir) if isinstance(exc, OSError)
                else night.say(exc.template))
            errors = [i for i, (level, _) in enumerate(night.messages) if level == "error"]
            if night.code in (0, 1) or not errors:
                night.messages.append(("error", why))
                night.code = 2 if night.code in (0, 1) else night.code
            else:  # the night failed already: one line still
                night.messages[errors[-1]] = ("error", f"{night.messages[errors[-1]][1]}; "
                                              f"{why}")
            return False
        finally:
            record.clear()


WORK_PREFIX = "enc-nightly-"
#: the lock file in a night's folder: held (flock) by the night while it runs
WORK_LOCK = ".enc-nightly.lock"


def history_rig(rig: str) -> str:
    """The rig's name as the history records it (its partition): a rig file's ``name``,
    never its path (hosts keeping their rigs at one path would share a partition); a
    bundled rig's name as given."""
    if not (rig.endswith(".toml") or os.sep in rig or (os.altsep or os.sep) in rig):
        return rig
    from enctools.data.rig import load_rig

    return load_rig(rig).name


def _work_folder(s: Settings, run_id: str) -> tuple[Path, int | None]:
    """The campaign's folder: a new subfolder ``run_id`` of ``keep`` (a night never finds
    an older night's result there), or a new temporary folder named after this
    process (``enc-nightly-PID@HOST-RANDOM``) in :func:`temporary_root`, once those of
    killed runs are removed; with the descriptor of its lock, held until it is closed
    (None for ``keep``)."""
    if s.keep:
        work = Path(s.keep) / run_id
        work.mkdir(parents=True, exist_ok=False)
        return work, None
    from enctools.data.files import writer_tag

    root = temporary_root()
    remove_stale_work_folders(root)
    work = Path(tempfile.mkdtemp(prefix=f"{WORK_PREFIX}{writer_tag()}-", dir=root))
    try:
        return work, _hold_lock(work)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise


def _hold_lock(work: Path) -> int:
    """Take the lock of the folder ``work`` (:data:`WORK_LOCK`, ``PID@HOST`` in it): made
    under another name, locked, then renamed, so that no lock file is ever seen unheld
    while its night runs. The kernel lets it go when the process ends, ``kill -9`` too."""
    import fcntl

    from enctools.data.files import writer_tag

    new = work / f"{WORK_LOCK}.new"
    fd = os.open(new, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC,
                 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with contextlib.suppress(OSError):  # for whoever looks; a full disk leaves it empty
            os.write(fd, f"{writer_tag()}\n".encode())
        os.rename(new, work / WORK_LOCK)
    except BaseException:
        os.close(fd)
        raise
    return fd


def temporary_root() -> str:
    """The folder the campaign's folder is made in: ``$TMPDIR`` (or ``$TEMP``, ``$TMP``) as
    set, else /tmp; never another in its place. (``tempfile.gettempdir()`` takes the next
    of /tmp, /var/tmp and the current folder when the one set cannot be written: a night
    whose TMPDIR is full or missing ran elsewhere and was recorded ok.)"""
    for name in ("TMPDIR", "TEMP", "TMP"):
        folder = os.environ.get(name)
        if folder:
            return folder
    return "/tmp"


def remove_stale_work_folders(folder: str | None = None) -> list[str]:
    """Remove the temporary folders of nightly runs killed without a chance to clean up
    (``kill -9``, a power cut): those of this user and host whose night no longer runs
    (:func:`_night_over`)."""
    from enctools.data.files import writer_tag

    pattern = re.compile(rf"{WORK_PREFIX}(\d+)@([A-Za-z0-9._-]+)-[A-Za-z0-9_]+")
    host = writer_tag().split("@", 1)[1]
    removed: list[str] = []
    try:
        entries = list(os.scandir(folder or temporary_root()))
    except OSError:
        return removed
    for entry in entries:
        m = pattern.fullmatch(entry.name)
        try:
            if m is None or m.group(2) != host or not entry.is_dir(follow_symlinks=False) \
                    or entry.stat(follow_symlinks=False).st_uid != os.geteuid() \
                    or not _night_over(entry.path, int(m.group(1)), host):
                continue
        except OSError:
            continue
        stop_left_campaign(entry.path)
        shutil.rmtree(entry.path, ignore_errors=True)
        removed.append(entry.path)
    return removed


def process_start(pid: int) -> str | None:
    """When process ``pid`` started (clock ticks since boot, /proc/PID/stat), None when
    there is no such process or no /proc: with the id, who a process is (an id is
    reused, not both)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rfind(")") + 2:].split()  # after the command's name, which may hold spaces
    return fields[19] if len(fields) > 19 else None


def record_campaign(lock: Path, pgid: int) -> None:
    """Add the campaign's process group to the night's lock file ``lock``: its id and its
    leader's start, for :func:`stop_left_campaign` after a ``kill -9`` of the night."""
    start = process_start(pgid)
    if start is not None:
        with contextlib.suppress(OSError), open(lock, "a", encoding="ascii") as f:
            f.write(f"campaign {pgid} {start}\n")


def stop_left_campaign(folder: str, grace_s: float = 5.0) -> None:
    """Stop the campaign a killed night left running (its lock file says which group),
    when the group's leader is still that process (same id, same start): SIGTERM, then
    SIGKILL after ``grace_s`` [s]. A group whose leader has gone is left alone (its id
    can no longer be told from another's)."""
    import signal
    import time

    try:
        lines = Path(folder, WORK_LOCK).read_text(encoding="ascii").splitlines()
    except (OSError, UnicodeDecodeError):
        return
    for line in lines:
        words = line.split()
        if len(words) != 3 or words[0] != "campaign" or not words[1].isdigit() \
                or int(words[1]) <= 1 or process_start(int(words[1])) != words[2]:
            continue
        pgid = int(words[1])
        with contextlib.suppress(OSError):
            os.killpg(pgid, signal.SIGTERM)
            deadline = time.monotonic() + grace_s
            while time.monotonic() < deadline and process_start(pgid) == words[2]:
                time.sleep(0.05)
            os.killpg(pgid, signal.SIGKILL)


def _night_over(path: str, pid: int, host: str) -> bool:
    """Whether the night of the folder ``path`` (made by process ``pid`` of ``host``) is
    over: its lock is free, whatever process now has that id (a reused one, another pid
    namespace's). A folder without its lock (made by an older version, or killed before
    the lock was in place) or on a file system without locks: over once no process has
    ``pid`` on this host."""
    import fcntl

    from enctools.data.files import process_gone

    try:
        fd = os.open(os.path.join(path, WORK_LOCK), os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except FileNotFoundError:
        return process_gone(pid, host)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:  # held: its night runs
        return False
    except OSError:
        return process_gone(pid, host)
    finally:
        os.close(fd)
    return True


def _recheck(s: Settings, work: Path, record: dict[str, Any], night: Night) -> None:
    """Campaign, figures, drift against the calibration; the history row once it is whole
    (``record`` is then emptied: nothing is left for the caller to append)."""
    result = _run_campaign(s, work, record, night)
    if result is None:
        return
    section = _section(str(result))
    current = main_curve(section)
    f = current.figures
    record |= {"pp": f.pp, "std": f.std, "mean": f.mean,
               "max_abs": max(abs(f.minimum), abs(f.maximum))}
    if not _calibration_ready(s, result, record, night):
        return
    d = drift(current, main_curve(_section(s.calibration)))
    record |= {"drift_max": d.max_abs, "drift_pp": d.pp}
    status = "ok" if d.max_abs <= s.tolerance else "drift"
    from enctools.report.jsonout import report_dict
    from enctools.report.summary import Report

    rep = Report(sections=[section], settings={"top_harmonics": 5})
    summary = report_dict(rep)
    summary["drift"] = {"max_abs_arcsec": d.max_abs, "pp_arcsec": d.pp,
                        "offset_arcsec": d.offset, "tolerance_arcsec": s.tolerance,
                        "calibration": s.calibration}
    record |= {"status": status, "exit_code": 0 if status == "ok" else 1,
               "summary_json": json.dumps(summary)}
    night.status, night.code = status, record["exit_code"]
    night_id = record["run_id"]
    if not _record_row(s, record, night):
        return
    if s.html:
        _write_html(s.html, s, rep, d, night.status)
    from enctools.report.numbers import fmt_each

    pp, std, most = fmt_each([f.pp, f.std, d.max_abs])  # enc-report(1) NUMBERS
    night.summary = (f"{night_id}: {status}: p-p {pp}\", s {std}\", drift max {most}\" "
                     f"(tolerance {s.tolerance:g}\")")
    if status != "ok":
        night.messages.append(("error", night.say(f"drift {most} arcsec > "
                                                  f"`tolerance` {s.tolerance:g} against "
                                                  f"{s.calibration}")))


def _run_campaign(s: Settings, work: Path, record: dict[str, Any], night: Night) -> Path | None:
    """Run the campaign in ``work``; its result stream, or None (the failure is told)."""
    if s.campaign is None:
        night.fail("no campaign to run", 2, record)
        return None
    result = work / RESULT
    try:
        s.campaign.run(s.rig, work, record["run_id"])
    except Interrupted:
        raise
    except CampaignFailed as exc:
        night.fail(exc.template, exc.exit_code if exc.exit_code in (1, 3) else 2, record,
                   status=exc.status)
        return None
    except EncError as exc:  # the library's, in this process
        code = exc.exit_code
        night.fail(f"campaign failed with exit {code}: {exc.template}",
                   code if code in (1, 3) else 2, record)
        return None
    if result.exists():
        return result
    night.fail(f"campaign left no {result}", 2, record)
    return None


def _calibration_ready(s: Settings, result: Path, record: dict[str, Any], night: Night) -> bool:
    """True once the stored calibration exists: with ``init``, this run's result becomes it."""
    if Path(s.calibration).exists():
        return True
    if not s.init:
        night.fail(f"`calibration` {s.calibration}: no such file (use `init` to store this "
                   "run as the calibration)", 2, record, summary="no stored calibration")
        return False
    if store_first(s.calibration, result, record["run_id"]):
        night.messages.append(("info", f"stored this run as the calibration {s.calibration}"))
    else:
        night.messages.append(("info", f"compared with the calibration {s.calibration} "
                               "another night stored meanwhile"))
    return True


def store_first(path: str, result: Path, run_id: str) -> bool:
    """Store ``result`` as ``path`` unless a file is there: written whole beside it, then
    linked into place, which fails when another night stored its own first (two
    ``init`` nights at once: one calibration, the other night compared with it).
    True when this night's was stored."""
    from enctools.data.files import write_atomic

    final = Path(path)
    with _naming(path):
        final.parent.mkdir(parents=True, exist_ok=True)
        mine = final.with_name(f".{final.name}.{run_id}.init")
        write_atomic(mine, result.read_bytes(), durable=True)
        try:
            os.link(mine, final)
        except FileExistsError:
            return False
        finally:
            mine.unlink(missing_ok=True)
    return True


def _write_html(path: str, s: Settings, rep: Report, d: Drift, status: str) -> None:
    """This run's HTML report with the history plotted, at ``path``."""
    from enctools.data.files import write_atomic
    from enctools.report.history import read_history
    from enctools.report.html import to_html
    from enctools.report.numbers import fmt_each

    rep.history = read_history(s.history_dir, rig=history_rig(s.rig))
    rep.settings["thresholds"] = {"drift tolerance": s.tolerance}
    fails = [] if status == "ok" else [f"drift {fmt_each([d.max_abs])[0]} arcsec > "
                                       f"{s.tolerance:g}"]
    # SIGTERM's Interrupted raised inside matplotlib's drawing may be swallowed there and
    # leave a half-drawn figure that fails later ("Invalid bounding box", exit 2 for 143):
    # a signal is acted on once the page is made
    with signals_held():
        page = to_html(rep, fails, f"Nightly recheck — {s.rig}").encode()
    with _naming(path):
        write_atomic(path, page)


@contextlib.contextmanager
def _naming(path: str) -> Iterator[None]:
    """An OS error of the block names ``path`` (not a temporary file beside it)."""
    try:
        yield
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), path) from None


def _section(path: str) -> Section:
    from enctools.data.streams import open_input
    from enctools.report.sections import build_section

    with open_input(path) as stream:
        return build_section(stream)
