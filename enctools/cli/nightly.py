"""The nightly recheck: re-run a campaign on a rig, compare with the stored calibration,
append the run to the history dataset, exit 1 on drift beyond tolerance.

Run as ``bin/enc-nightly`` (``python -m enctools.report.nightly``). Steps:

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
5. Exit 0 (within tolerance), 1 (drift > tolerance), 2 (bad usage or input), 3 (the
   campaign reported a device fault) or the campaign's own failing status.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click
import numpy as np

DEFAULT_CAMPAIGN = 'enc acquire --rig "$RIG" --mode steps | enc points -o "$OUT/result.parquet"'


@dataclass
class Drift:
    """Current minus stored calibration [arcsec], mean offset removed."""

    angle_deg: np.ndarray
    drift: np.ndarray
    offset: float

    @property
    def max_abs(self) -> float:
        """Largest |drift| [arcsec]."""
        return float(np.max(np.abs(self.drift)))

    @property
    def pp(self) -> float:
        """Peak-to-peak of the drift [arcsec]."""
        return float(np.ptp(self.drift))


def main_curve(section: Any) -> Any:
    """The curve a nightly run tracks: the first deviation curve [arcsec] of a section."""
    for c in section.curves:
        if c.unit == "arcsec" and c.role in ("deviation", "points", "positioning") \
                and c.domain == "revolution":
            return c
    from enctools.errors import DataError
    msg = f"{section.source}: no deviation curve [arcsec] to compare ({section.kind} stream)"
    raise DataError(msg)


def drift(current: Any, stored: Any) -> Drift:
    """Drift [arcsec] of a curve against the stored one (both :class:`~.sections.Curve`,
    angles [rad]), on the current curve's angles [deg], the mean offset removed."""
    x = np.mod(np.degrees(current.angle), 360.0)
    xs = np.mod(np.degrees(stored.angle), 360.0)
    order = np.argsort(xs)
    ref = np.interp(x, xs[order], stored.values[order], period=360.0)
    d = current.values - ref
    offset = float(d.mean())
    return Drift(x, d - offset, offset)


def _section(path: str) -> Any:
    from enctools.data.streams import open_input
    from enctools.report.sections import build_section
    with open_input(path) as s:
        return build_section(s)


def run_nightly(rig: str, history_dir: str, calibration: str, campaign: str, tolerance: float,
                init: bool = False, keep: str | None = None, html: str | None = None) -> int:
    """One nightly run; returns the exit status (and always appends to the history)."""
    from enctools.errors import EncError
    from enctools.report.history import append_run, new_run_id

    run_id = new_run_id()
    record: dict[str, Any] = {"run_id": run_id, "rig": rig, "tolerance": tolerance,
                              "campaign": campaign}
    work = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="enc-nightly-"))
    work.mkdir(parents=True, exist_ok=True)
    status, code = "error", 2
    try:
        env = dict(os.environ, RIG=rig, OUT=str(work), ENC_NIGHTLY_RUN=run_id)
        proc = subprocess.run(["/bin/bash", "-o", "pipefail", "-c", campaign], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        result = work / "result.parquet"
        if proc.returncode != 0 or not result.exists():
            last = (proc.stderr.decode(errors="replace").strip().splitlines() or ["-"])[-1]
            why = (f"campaign failed with exit {proc.returncode}: {last}" if proc.returncode
                   else f"campaign left no {result}")
            _err(why)
            code = proc.returncode if proc.returncode in (1, 3) else 2
            record["summary_json"] = json.dumps({"error": why})
            return code
        section = _section(str(result))
        cur = main_curve(section)
        f = cur.figures
        record |= {"pp": f.pp, "std": f.std, "mean": f.mean,
                   "max_abs": max(abs(f.minimum), abs(f.maximum))}
        if not Path(calibration).exists():
            if not init:
                _err(f"--calibration {calibration}: no such file (use --init to store this "
                     "run as the calibration)")
                record["summary_json"] = json.dumps({"error": "no stored calibration"})
                return 2
            Path(calibration).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(result, calibration + ".tmp")
            os.replace(calibration + ".tmp", calibration)
            _info(f"stored this run as the calibration {calibration}")
        stored = main_curve(_section(calibration))
        d = drift(cur, stored)
        record |= {"drift_max": d.max_abs, "drift_pp": d.pp}
        status = "ok" if d.max_abs <= tolerance else "drift"
        code = 0 if status == "ok" else 1
        from enctools.report.jsonout import report_dict
        from enctools.report.summary import Report
        rep = Report(sections=[section], settings={"top_harmonics": 5})
        summary = report_dict(rep)
        summary["drift"] = {"max_abs": d.max_abs, "pp": d.pp, "offset": d.offset,
                            "tolerance": tolerance, "calibration": calibration}
        record["summary_json"] = json.dumps(summary)
        line = (f"{run_id}: {status}: p-p {f.pp:.3f}\", s {f.std:.3f}\", drift max "
                f"{d.max_abs:.3f}\" (tolerance {tolerance:g}\")")
        print(line)
        if status != "ok":
            _err(f"drift {d.max_abs:.3f} arcsec > --max-drift {tolerance:g} against {calibration}")
        record |= {"status": status, "exit_code": code}
        append_run(history_dir, record)
        record = {}                      # landed: nothing left for the finally clause
        if html:
            from enctools.data.files import write_atomic
            from enctools.report.history import read_history
            from enctools.report.html import to_html
            rep.history = read_history(history_dir)
            rep.settings["thresholds"] = {"drift tolerance": tolerance}
            fails = [] if status == "ok" else [f"drift {d.max_abs:.3f} arcsec > {tolerance:g}"]
            write_atomic(html, to_html(rep, fails, f"Nightly recheck — {rig}").encode())
        return code
    except EncError as exc:
        _err(str(exc))
        code = exc.exit_code
        record["summary_json"] = json.dumps({"error": str(exc)})
        return code
    except OSError as exc:  # a folder that cannot be made, a full disk: one line, exit 2
        why = f"{exc.strerror or exc}" + (f" ({exc.filename})" if exc.filename else "")
        _err(why)
        code = 2
        record["summary_json"] = json.dumps({"error": why})
        return code
    finally:  # a run that failed early is recorded too
        if record:
            record |= {"status": status if code in (0, 1) else "error", "exit_code": code}
            append_run(history_dir, record)
        if not keep:
            shutil.rmtree(work, ignore_errors=True)


def _err(msg: str) -> None:
    sys.stderr.write(f"enc-nightly: error: {' '.join(msg.split())}\n")


def _info(msg: str) -> None:
    sys.stderr.write(f"enc-nightly: {msg}\n")


@click.command("enc-nightly", context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--rig", envvar="ENC_RIG", required=True, metavar="NAME|PATH",
              help="Rig to re-acquire on (passed to the campaign as $RIG).")
@click.option("--history", "history_dir", envvar="ENC_NIGHTLY_HISTORY", required=True,
              metavar="DIR", type=click.Path(file_okay=False),
              help="History folder: one Parquet file per run is added.")
@click.option("--calibration", required=True, metavar="FILE", type=click.Path(dir_okay=False),
              help="The stored calibration (points or deviations stream) to compare with.")
@click.option("--init", is_flag=True, default=False,
              help="When FILE does not exist, store this run as the calibration.")
@click.option("--campaign", envvar="ENC_NIGHTLY_CAMPAIGN", default=DEFAULT_CAMPAIGN,
              show_default=True, metavar="CMD",
              help="Shell command writing $OUT/result.parquet.")
@click.option("--max-drift", "--tolerance", "tolerance", type=float, default=0.5, show_default=True,
              metavar="ARCSEC",
              help="Largest allowed |drift| against the calibration.")
@click.option("--keep", default=None, metavar="DIR", type=click.Path(file_okay=False),
              help="Keep the campaign's outputs in DIR (default: a removed temporary folder).")
@click.option("--html", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Also write this run's HTML report with the history.")
def command(rig: str, history_dir: str, calibration: str, init: bool, campaign: str,
            tolerance: float, keep: str | None, html: str | None) -> None:
    """Nightly recheck: re-acquire, run the campaign, compare, append to the history.

    Exit status: 0 within tolerance, 1 drift beyond it, 2 bad usage or input, 3 device
    fault in the campaign.
    """
    if not (tolerance >= 0 and np.isfinite(tolerance)):
        _err(f"--max-drift must be >= 0, not {tolerance}")
        sys.exit(2)
    sys.exit(run_nightly(rig, history_dir, calibration, campaign, tolerance, init, keep, html))


def main() -> None:
    try:
        command.main(standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.UsageError as exc:
        _err(exc.format_message() + " (see 'enc-nightly --help')")
        sys.exit(2)
    except click.Abort:
        _err("interrupted")
        sys.exit(130)


if __name__ == "__main__":
    main()
