"""The nightly recheck: re-run a campaign on a rig, compare with the stored calibration,
append the run to the history dataset; the command is ``enc-nightly``
(:mod:`enctools.cli.nightly`).

1. Run the campaign: a shell command with ``RIG`` and ``OUT`` (a fresh folder) in its
   environment that leaves its result stream in ``$OUT/result.parquet`` (default:
   ``enc acquire --rig "$RIG" --mode steps | enc points -o "$OUT/result.parquet"``,
   the polygon check of seed 001).
2. Report on the result (figures of its first deviation curve [arcsec]).
3. Compare with the stored calibration (a points or deviations stream): drift =
   current - stored at the current positions (the stored curve interpolated
   periodically), mean offset removed (an encoder's zero is arbitrary);
   ``drift_max`` = max |drift|, ``drift_pp`` = its peak-to-peak.
4. Append one row to the history folder (:mod:`.history`), whatever happened.
5. The exit status: 0 (within tolerance), 1 (drift > tolerance), 2 (bad usage or
   input), 3 (the campaign reported a device fault) or the campaign's own failing
   status.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from enctools.errors import DataError, EncError, UsageError

if TYPE_CHECKING:  # numpy, pyarrow and the report are imported when a night runs
    import numpy as np

    from enctools.report.sections import Curve, Section
    from enctools.report.summary import Report

DEFAULT_CAMPAIGN = 'enc acquire --rig "$RIG" --mode steps | enc points -o "$OUT/result.parquet"'


@dataclass(frozen=True)
class Settings:
    """One nightly recheck.

    ``rig``: passed to the campaign as ``$RIG``; ``history_dir``: the history folder;
    ``calibration``: the stored calibration stream; ``campaign``: the shell command;
    ``tolerance``: largest allowed |drift| [arcsec]; ``init``: store this run as the
    calibration when there is none; ``keep``: folder for the campaign's outputs
    (default: a removed temporary folder); ``html``: also write the HTML report here.
    """

    rig: str
    history_dir: str
    calibration: str
    campaign: str = DEFAULT_CAMPAIGN
    tolerance: float = 0.5
    init: bool = False
    keep: str | None = None
    html: str | None = None

    def __post_init__(self) -> None:
        if not (self.tolerance >= 0 and math.isfinite(self.tolerance)):
            msg = f"--max-drift must be >= 0, not {self.tolerance}"
            raise UsageError(msg)


@dataclass
class Night:
    """What one run did: exit status, the summary line (stdout) and the messages
    (stderr) in the order they arose, each ``("error" | "info", text)``."""

    code: int = 2
    status: str = "error"          # ok, drift or error
    summary: str | None = None
    messages: list[tuple[str, str]] = field(default_factory=list)

    def fail(self, why: str, code: int, record: dict[str, Any],
             summary: str | None = None) -> None:
        """End the run with an error: say why, keep it (or ``summary``) for the history."""
        self.messages.append(("error", why))
        self.code = code
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

    x = np.mod(np.degrees(current.angle), 360.0)
    xs = np.mod(np.degrees(stored.angle), 360.0)
    order = np.argsort(xs)
    ref = np.interp(x, xs[order], stored.values[order], period=360.0)
    d = current.values - ref
    offset = float(d.mean())
    return Drift(x, d - offset, offset)


def run_nightly(s: Settings) -> Night:
    """One nightly run (steps 1-4 above); the history gets its row whatever happens."""
    from enctools.report.history import append_run, new_run_id

    night = Night()
    record: dict[str, Any] = {"run_id": new_run_id(), "rig": s.rig, "tolerance": s.tolerance,
                              "campaign": s.campaign}
    work = Path(s.keep) if s.keep else Path(tempfile.mkdtemp(prefix="enc-nightly-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        _recheck(s, work, record, night)
    except EncError as exc:
        night.fail(str(exc), exc.exit_code, record)
    except OSError as exc:  # a folder that cannot be made, a full disk: one line, exit 2
        night.fail(f"{exc.strerror or exc}" + (f" ({exc.filename})" if exc.filename else ""),
                   2, record)
    finally:  # a run that failed early is recorded too
        if record:
            record |= {"status": night.status if night.code in (0, 1) else "error",
                       "exit_code": night.code}
            append_run(s.history_dir, record)
        if not s.keep:
            shutil.rmtree(work, ignore_errors=True)
    return night


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
    night.status = "ok" if d.max_abs <= s.tolerance else "drift"
    night.code = 0 if night.status == "ok" else 1
    from enctools.report.history import append_run
    from enctools.report.jsonout import report_dict
    from enctools.report.summary import Report

    rep = Report(sections=[section], settings={"top_harmonics": 5})
    summary = report_dict(rep)
    summary["drift"] = {"max_abs": d.max_abs, "pp": d.pp, "offset": d.offset,
                        "tolerance": s.tolerance, "calibration": s.calibration}
    record["summary_json"] = json.dumps(summary)
    night.summary = (f"{record['run_id']}: {night.status}: p-p {f.pp:.3f}\", s {f.std:.3f}\", "
                     f"drift max {d.max_abs:.3f}\" (tolerance {s.tolerance:g}\")")
    if night.status != "ok":
        night.messages.append(("error", f"drift {d.max_abs:.3f} arcsec > --max-drift "
                                        f"{s.tolerance:g} against {s.calibration}"))
    record |= {"status": night.status, "exit_code": night.code}
    append_run(s.history_dir, record)
    record.clear()
    if s.html:
        _write_html(s.html, s, rep, d, night.status)


def _run_campaign(s: Settings, work: Path, record: dict[str, Any], night: Night) -> Path | None:
    """Run the campaign in ``work``; its result stream, or None (the failure is told)."""
    env = dict(os.environ, RIG=s.rig, OUT=str(work), ENC_NIGHTLY_RUN=record["run_id"])
    proc = subprocess.run(["/bin/bash", "-o", "pipefail", "-c", s.campaign], env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    result = work / "result.parquet"
    if proc.returncode == 0 and result.exists():
        return result
    last = (proc.stderr.decode(errors="replace").strip().splitlines() or ["-"])[-1]
    why = (f"campaign failed with exit {proc.returncode}: {last}" if proc.returncode
           else f"campaign left no {result}")
    night.fail(why, proc.returncode if proc.returncode in (1, 3) else 2, record)
    return None


def _calibration_ready(s: Settings, result: Path, record: dict[str, Any], night: Night) -> bool:
    """True once the stored calibration exists: with ``init``, this run's result becomes it."""
    if Path(s.calibration).exists():
        return True
    if not s.init:
        night.fail(f"--calibration {s.calibration}: no such file (use --init to store this "
                   "run as the calibration)", 2, record, summary="no stored calibration")
        return False
    from enctools.data.files import write_atomic

    Path(s.calibration).parent.mkdir(parents=True, exist_ok=True)
    write_atomic(s.calibration, result.read_bytes(), durable=True)
    night.messages.append(("info", f"stored this run as the calibration {s.calibration}"))
    return True


def _write_html(path: str, s: Settings, rep: Report, d: Drift, status: str) -> None:
    """This run's HTML report with the history plotted, at ``path``."""
    from enctools.data.files import write_atomic
    from enctools.report.history import read_history
    from enctools.report.html import to_html

    rep.history = read_history(s.history_dir)
    rep.settings["thresholds"] = {"drift tolerance": s.tolerance}
    fails = [] if status == "ok" else [f"drift {d.max_abs:.3f} arcsec > {s.tolerance:g}"]
    write_atomic(path, to_html(rep, fails, f"Nightly recheck — {s.rig}").encode())


def _section(path: str) -> Section:
    from enctools.data.streams import open_input
    from enctools.report.sections import build_section

    with open_input(path) as stream:
        return build_section(stream)
