"""The ``nidaq`` counter: NI-DAQmx angular-encoder counter channels, one per head.

Each head's A/B (and optional Z) lines go to one counter of an NI X-Series/M-Series
device; the counter decodes them (X1, X2 or X4) and counts ticks. A continuous run is
hardware-timed: every head's counter is latched by one shared sample clock, either an
external/internal terminal (``sample_clock = "/Dev1/PFI8"``, ``"/Dev1/ai/SampleClock"``)
or a spare counter generating pulses at 1/interval (``clock_counter = "Dev1/ctr3"``).
A steps run reads each counter on demand.

The rig's encoder must match the decoding: ``interpolation`` = 4 for X4 (2 for X2,
1 for X1) and ``periods_per_rev`` = the encoder's lines per revolution, so
counts_per_rev = 4 x lines. Counter values arrive as ticks since the task started (or
since the Z mark with ``z_index = true``) and wrap at ``counter_bits`` (32 on NI).

Rig file::

    [backend]
    kind = "nidaq"

    [backend.counter]
    kind = "nidaq"
    decoding = "X4"                  # X1, X2, X4
    sample_clock = ""                # empty: use clock_counter
    clock_counter = "Dev1/ctr3"      # generates the sample clock at 1/interval_s
    buffer_s = 10.0                  # on-board buffer, seconds of samples
    timeout_s = 2.0

    [[encoder.head]]
    name = "H1"
    angle_deg = 0.0
    backend = { channel = "Dev1/ctr0", z_index = false }

Only ``import nidaqmx`` needs the package; it is imported when a nidaq rig is opened.
Without the Python package: exit 2 (``pip install 'enctools[nidaq]'``); without the
NI-DAQmx driver (the runtime from ni.com) or the device: exit 3. Both are one line.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from enctools.data.rig import Rig
from enctools.errors import DataError, DeviceError, SettingsError
from enctools.hw.base import Clock, Counter

log = logging.getLogger("enctools.hw")

COUNTER_KEYS = {"kind", "decoding", "sample_clock", "clock_counter", "buffer_s", "timeout_s"}
HEAD_KEYS = {"channel", "z_index"}
DECODING = {"X1": 1, "X2": 2, "X4": 4}
TIMEOUT_CODE = -200284  # DAQmx: some or all requested samples have not yet been acquired


def import_nidaqmx() -> Any:
    """The nidaqmx package, or a one-line SettingsError (exit 2) naming what to install."""
    try:
        import nidaqmx
        import nidaqmx.constants
        import nidaqmx.errors
    except ImportError:
        from enctools.hw.backends import get

        raise get("nidaq").missing() from None
    return nidaqmx


def daq_error(nidaqmx: Any, exc: BaseException, doing: str) -> DeviceError:
    """A one-line DeviceError for a DAQmx failure; names the driver when it is missing."""
    errors = nidaqmx.errors
    not_found = getattr(errors, "DaqNotFoundError", None)
    text = " ".join(str(exc).split())
    if (not_found is not None and isinstance(exc, not_found)) or "not installed" in text.lower() \
            or isinstance(exc, OSError):
        return DeviceError(f"NI-DAQmx driver not found while {doing}: install the NI-DAQmx "
                           "runtime from ni.com (the nidaqmx package is only its Python API)")
    code = getattr(exc, "error_code", None)
    first = text.split(" Task Name:")[0][:240]
    return DeviceError(f"NI-DAQmx error{f' {code}' if code else ''} while {doing}: {first}")


class NidaqCounter(Counter):
    """One DAQmx counter-input task per head, sharing a sample clock when running."""

    def __init__(self, rig: Rig, cfg: dict[str, Any], clock: Clock, t0: float) -> None:
        from enctools.hw.config import check_keys, need

        self.nidaqmx = import_nidaqmx()
        check_keys(cfg, COUNTER_KEYS, rig, "backend.counter")
        self.rig = rig
        self.clock = clock
        self.t0 = t0
        dec = str(cfg.get("decoding", "X4")).upper()
        if dec not in DECODING:
            msg = (f"rig file {rig.source}: backend.counter.decoding must be X1, X2 or X4, "
                   f"not {dec!r}")
            raise DataError(msg)
        self.decoding = dec
        self.sample_clock = str(cfg.get("sample_clock", ""))
        self.clock_counter = str(cfg.get("clock_counter", ""))
        self.buffer_s = float(need(cfg, "buffer_s", (int, float), rig, "backend.counter", 10.0))
        self.timeout_s = float(need(cfg, "timeout_s", (int, float), rig, "backend.counter", 2.0))
        self.heads = tuple(rig.head_names)
        self.counter_bits = {h.name: e.counter_bits for e, h in rig.heads}
        self.channels: dict[str, dict[str, Any]] = {}
        for e, h in rig.heads:
            where = f"encoder {e.name} head {h.name} backend"
            check_keys(h.backend, HEAD_KEYS, rig, where)
            if "channel" not in h.backend:
                msg = (f"rig file {rig.source}: head {h.name}: the nidaq backend needs "
                       "backend = { channel = \"Dev1/ctrN\" }")
                raise DataError(msg)
            if e.interpolation != DECODING[dec]:
                msg = (f"rig file {rig.source}: encoder {e.name}: {dec} decoding gives "
                       f"{DECODING[dec]} counts per line, but interpolation = {e.interpolation}")
                raise DataError(msg)
            self.channels[h.name] = dict(h.backend) | {"lines": e.periods_per_rev}
        self.tasks: dict[str, Any] = {}
        self.clock_task: Any = None
        self._timed = False
        self._open_tasks(timed=False, interval_s=0.0)

    def _open_tasks(self, timed: bool, interval_s: float) -> None:
        nx = self.nidaqmx
        c = nx.constants
        self._close_tasks()
        self._timed = timed
        doing = "creating the counter tasks"
        try:
            for name, ch in self.channels.items():
                task = nx.Task(f"enc-{name}")
                self.tasks[name] = task
                task.ci_channels.add_ci_ang_encoder_chan(
                    counter=str(ch["channel"]), name_to_assign_to_channel=name,
                    decoding_type=getattr(c.EncoderType, f"X_{self.decoding[1]}"),
                    zidx_enable=bool(ch.get("z_index", False)), zidx_val=0,
                    units=c.AngleUnits.TICKS, pulses_per_rev=int(ch["lines"]),
                    initial_angle=0.0)
                if timed:
                    source = self.sample_clock or f"/{self.clock_counter}InternalOutput"
                    rate = 1.0 / interval_s
                    task.timing.cfg_samp_clk_timing(
                        rate, source=source, sample_mode=c.AcquisitionType.CONTINUOUS,
                        samps_per_chan=max(1000, int(self.buffer_s * rate)))
                    task.start()
            if timed and not self.sample_clock:
                if not self.clock_counter:
                    msg = ("[backend.counter] needs sample_clock or clock_counter for a "
                           "hardware-timed (continuous) run")
                    raise DataError(msg)
                doing = f"starting the sample clock on {self.clock_counter}"
                self.clock_task = nx.Task("enc-clock")
                self.clock_task.co_channels.add_co_pulse_chan_freq(
                    self.clock_counter, freq=1.0 / interval_s, duty_cycle=0.5)
                self.clock_task.timing.cfg_implicit_timing(
                    sample_mode=c.AcquisitionType.CONTINUOUS)
                self.clock_task.start()
        except (SettingsError, DataError):
            self._close_tasks()
            raise
        except Exception as exc:  # noqa: BLE001 - every DAQmx failure becomes one line
            self._close_tasks()
            raise daq_error(nx, exc, doing) from None

    def _close_tasks(self) -> None:
        tasks = list(self.tasks.values()) + ([self.clock_task] if self.clock_task else [])
        self.tasks, self.clock_task = {}, None
        for t in tasks:
            try:
                t.close()
            except Exception as exc:  # noqa: BLE001 - closing must not hide the first error
                log.debug("closing a DAQmx task: %s", exc)

    def read_now(self) -> dict[str, np.ndarray]:
        if self._timed or not self.tasks:
            self._open_tasks(timed=False, interval_s=0.0)
        out: dict[str, np.ndarray] = {"t": np.array([self.clock.now() - self.t0])}
        try:
            for name, task in self.tasks.items():
                out[name] = np.array([round(float(task.read()))], dtype=np.int64)
        except Exception as exc:  # noqa: BLE001 - every DAQmx failure becomes one line
            raise daq_error(self.nidaqmx, exc, "reading the counters") from None
        return out

    def start(self, interval_s: float) -> None:
        self.interval = interval_s
        self._k = 0
        self._open_tasks(timed=True, interval_s=interval_s)

    def read_block(self, max_samples: int) -> dict[str, np.ndarray]:
        nx = self.nidaqmx
        try:
            avail = min(t.in_stream.avail_samp_per_chan for t in self.tasks.values())
            n = int(min(max_samples, max(1, avail)))
            cols = {name: np.rint(np.asarray(task.read(number_of_samples_per_channel=n,
                                                       timeout=self.timeout_s),
                                             dtype=np.float64)).astype(np.int64)
                    for name, task in self.tasks.items()}
        except Exception as exc:  # noqa: BLE001 - every DAQmx failure becomes one line
            if getattr(exc, "error_code", None) == TIMEOUT_CODE:
                msg = (f"NI-DAQmx: no samples within {self.timeout_s:g} s: is the sample clock "
                       f"{self.sample_clock or self.clock_counter} running?")
                raise DeviceError(msg) from None
            raise daq_error(nx, exc, "reading the counters") from None
        t = (np.arange(self._k, self._k + n)) * self.interval
        self._k += n
        return {"t": t, **cols}

    def stop(self) -> None:
        """Stop the clock and the timed tasks; on-demand tasks reopen at the next read_now."""
        self._timed = False
        self._close_tasks()

    def close(self) -> None:
        self._close_tasks()
