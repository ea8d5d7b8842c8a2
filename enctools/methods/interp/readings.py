"""The interpolation error of the heads of a readings stream against a reference.

The readings are streamed through one :class:`~.fit.InterpolationFit` per device (a
head, or heads of one encoder averaged) in batches, in constant memory, the devices
alike fed as one (:class:`~.bank.FitBank`); each device's fit then gives its
:class:`~.curve.Curve`. The error is a function of
the phase the head *reads* (its counts modulo the interpolation factor), which is
what a correction table indexed by the counts needs. The grating's true phase
differs from it by the error itself (periods_per_rev * psi), so the curve is
psi(phi_true) seen through phi_read = phi_true + P psi: the same values, abscissae
moved by up to psi (a shape change of about psi' psi, 0.01" for a 0.2" error over a
25" period). The mean of the error is not observable (it is one with the
reference's zero) and is removed.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.readings import HeadInfo, head_angle, head_info, signal_step
from enctools.data.schemas import columns_with_role
from enctools.data.statistics import median
from enctools.errors import DataError
from enctools.methods.interp.bank import FitBank
from enctools.methods.interp.batches import Chunk, Preparer, ready_batches
from enctools.methods.interp.curve import Curve, harmonics_meta
from enctools.methods.interp.fit import InterpolationFit, SharedGrouping
from enctools.methods.interp.reference import Reference, open_reference
from enctools.methods.interp.settings import Settings
from enctools.methods.interp.tables import column
from enctools.units import ARCSEC, TWO_PI


@dataclass
class Device:
    """One device checked: a head or heads of one encoder averaged, and its fit.

    ``fits_reference``: the reference's own harmonics are fitted alongside (its
    signal phase goes to the fit); ``warnings`` are said with the result.
    """

    heads: list[str]
    infos: list[HeadInfo]
    name: str
    fits_reference: bool
    warnings: list[str]
    fit: InterpolationFit


def device_reading(counts: Sequence[np.ndarray], infos: Sequence[HeadInfo]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(angle [rad], interpolation step [count]) of a head or a head average.

    The heads must be of one encoder: their average is periodic in that encoder's
    signal period as a function of the first head's phase (the heads sit at fixed
    phase offsets); the step is that phase in counts
    (:func:`enctools.data.readings.signal_step`).
    """
    if len(counts) == 1:  # one head: its angle (the mean of one is itself, bit for bit)
        angle = head_angle(counts[0], infos[0])
    else:
        angle = np.mean([head_angle(c, i) for c, i in zip(counts, infos, strict=True)], axis=0)
    return angle, signal_step(np.asarray(counts[0]), infos[0])


def check_readings(source: Any, settings: Settings, reference_table: pa.Table | None = None,
                   continuous: bool = False) -> list[Curve]:
    """Interpolation error of heads of a readings stream against a reference.

    ``source``: a readings table, or a stream (``.schema``, ``.batches()``) read batch
    by batch in constant memory. The heads, the reference and the model are those of
    ``settings``; the reference is taken from ``reference_table`` (the whole
    reference file, matched by time t) when given, else from the input. A
    ``continuous`` run (or any input with a window) has a trend per window of
    reference angle; a sweep one per run.
    """
    schema = source.schema
    reference = open_reference(schema, settings, reference_table)
    names = _device_heads(schema, settings, reference)
    window_arcsec = settings.trend_window_arcsec(continuous)
    # each batch made ready on the stream's reader thread while this one sums the last
    chunks = ready_batches(source, Preparer(
        schema, names, reference, window_arcsec * ARCSEC if window_arcsec is not None else None,
        settings.trend_degree))
    first = next(chunks, None)
    strobe = _stroboscopic(first, schema, names, reference) \
        if window_arcsec is not None and first is not None and reference.in_stream else {}
    devices, skipped = _plan(schema, names, settings, reference, strobe, window_arcsec)
    banks = FitBank.of([d.fit for d in devices])
    _stream(itertools.chain([first] if first is not None else [], chunks),
            [(b, [next(d for d in devices if d.fit is f) for f in b.fits]) for b in banks])
    for b in banks:
        b.close()
    reference.finish()
    grid = np.linspace(0.0, TWO_PI, settings.points, endpoint=False)
    curves = [_curve(d, grid, reference.meta, window_arcsec) for d in devices]
    if curves:
        curves[0].warnings[:0] = skipped
    return curves


def _device_heads(schema: pa.Schema, settings: Settings, reference: Reference) -> list[str]:
    """The heads to check: those asked, else every head but a reference head of the input."""
    names = list(settings.heads) if settings.heads else [
        h for h in columns_with_role(schema, "head")
        if not (reference.in_stream and h == settings.reference)]
    if not names:
        msg = "input: no head to check"
        raise DataError(msg)
    return names


def _stroboscopic(first: Chunk, schema: pa.Schema, names: Sequence[str],
                  reference: Reference) -> dict[str, float]:
    """Heads (devices and reference) sampled nearly synchronously with their signal period.

    The angle between samples is the median step of the reference over the ``first``
    chunk; :func:`enctools.methods.stroboscopic.stroboscopic_heads` judges. Returns
    {head: signal periods per sample}.
    """
    from enctools.methods.stroboscopic import stroboscopic_heads

    if first.batch.num_rows < 3:
        return {}
    d = np.abs(np.diff(first.ref.angle_rad))
    d = d[np.isfinite(d)]
    if not d.size:
        return {}
    seen = [head_info(schema, n) for n in names if n in schema.names]
    if reference.head is not None:
        seen.append(reference.head)
    return dict(stroboscopic_heads(median(d), tuple(seen)))


def _plan(schema: pa.Schema, names: list[str], settings: Settings, reference: Reference,
          strobe: dict[str, float], window_arcsec: float | None
          ) -> tuple[list[Device], list[str]]:
    """The devices to fit, and the warnings of heads left out (sampled synchronously)."""
    devices, skipped = [], []
    shared = SharedGrouping()  # every device's trend windows are the reference's
    for heads in [names] if settings.average else [[n] for n in names]:
        infos = [head_info(schema, n) for n in heads]
        name = heads[0] if len(heads) == 1 else "mean(" + ",".join(heads) + ")"
        if reference.in_stream and reference.head is not None \
                and reference.head.name == infos[0].name:
            msg = (f"`reference` {settings.reference} is the device itself; choose another head "
                   "or probes")
            raise DataError(msg)
        synchronous = [n for n in heads if n in strobe]
        if synchronous:
            h = synchronous[0]
            what = (f"{h}: sampling is nearly synchronous with its signal period "
                    f"({strobe[h]:.3f} periods per sample): its phase barely moves within a "
                    f"window, so its interpolation error goes into the trend")
            if settings.heads:
                msg = f"{what}; record with another sample interval (`interval_s`)"
                raise DataError(msg)
            skipped.append(f"{what}: not checked (record with another sample interval: "
                               "`interval_s`)")
            continue
        if len({i.periods_per_rev for i in infos}) > 1:
            msg = (f"heads {', '.join(heads)} have different signal periods: "
                   "average heads of one encoder")
            raise DataError(msg)
        devices.append(_device(heads, infos, name, settings, reference, strobe, window_arcsec,
                               shared))
    if not devices:
        msg = skipped[0].replace(": not checked", "") if skipped else "input: no head to check"
        raise DataError(msg)
    return devices, skipped


def _device(heads: list[str], infos: list[HeadInfo], name: str, settings: Settings,
            reference: Reference, strobe: dict[str, float],
            window_arcsec: float | None, shared: SharedGrouping) -> Device:
    """The fit of one device: harmonics fitted and kept, the reference's own, the trends."""
    ppr = infos[0].periods_per_rev
    other_period = reference.other_period(ppr)
    keep = list(settings.keep) if settings.keep is not None else ([1, 2] if other_period else None)
    harmonics = settings.harmonics if settings.harmonics is not None \
        else (max(keep) if other_period and keep is not None else 4)
    fits_reference = other_period and reference.name not in strobe
    warnings = []
    if other_period and not fits_reference:
        warnings.append(f"{name}: sampling is nearly synchronous with the signal period of "
                        f"the reference {reference.name} ({strobe[reference.name]:.3f} periods "
                        f"per sample): its interpolation error goes into the trend and its "
                        f"harmonics are not fitted")
    if reference.head is not None and not other_period:
        warnings.append(f"{name}: the reference {reference.head.name} has the same signal "
                        f"period; the result is the difference of both heads' interpolation "
                        f"errors")
    fit = InterpolationFit(
        ppr, harmonics=harmonics, keep=keep, trend_degree=settings.trend_degree,
        reference_orders=range(1, settings.reference_harmonics + 1) if fits_reference else (),
        reference_periods_per_rev=reference.periods_per_rev,
        window=window_arcsec * ARCSEC if window_arcsec is not None else None,
        shared=shared)
    return Device(heads, infos, name, fits_reference, warnings, fit)


def _stream(chunks: Iterable[Chunk], banks: list[tuple[FitBank, list[Device]]]) -> None:
    """Feed every chunk's readings of every device, with the reference, to the fits: the
    devices of a bank at once (by the compiled kernel from the counts where it can)."""
    fits_reference = any(devices[0].fits_reference for _, devices in banks)
    for c in chunks:
        if c.batch.num_rows == 0:
            continue
        ref_phase = None
        for bank, devices in banks:
            if c.targets is None and all(len(d.heads) == 1 for d in devices) \
                    and _fused(bank, devices, c):
                continue      # summed by the compiled kernel
            if ref_phase is None and fits_reference:
                ref_phase = c.ref.phase()
                ref_phase = ref_phase[c.sel] if ref_phase is not None and c.sel is not None \
                    else ref_phase
            _numpy(bank, devices, c, ref_phase)


def _fused(bank: FitBank, devices: list[Device], c: Chunk) -> bool:
    """One chunk of a bank's devices (a head each) by the compiled kernel; False, and
    nothing added, when it cannot take it."""
    w = c.windows
    ahead = None if w is None else \
        (w.grouping, w.origin, [w.first_y.get(d.heads[0]) for d in devices])
    return bank.add_counts([c.counts[d.heads[0]] for d in devices],
                           [d.infos[0] for d in devices], c.ref_rad, c.ref_step,
                           c.ref.steps if c.ref_step is not None else 0, c.groups,
                           finite=c.finite, windows=ahead)


def _numpy(bank: FitBank, devices: list[Device], c: Chunk, ref_phase: np.ndarray | None) -> None:
    """One chunk of a bank's devices by the numpy passes."""
    angles, steps, finite = [], [], []
    for d in devices:
        counts = [column(c.batch, n) for n in d.heads]
        finite.append(all(x.dtype.kind in "iu" for x in counts))  # no null count
        dev_rad, dev_step = device_reading(counts, d.infos)
        if c.sel is not None:
            dev_rad, dev_step = dev_rad[c.sel], dev_step[c.sel]
        # the phase is 2 pi dev_step / interpolation: the fit takes it from the steps
        angles.append(dev_rad)
        steps.append((dev_step, d.infos[0].interpolation, c.ref_step,
                      c.ref.steps if c.ref_step is not None else 0))
    bank.add(angles, c.ref_rad, steps, c.groups,
             ref_phase if devices[0].fits_reference else None, c.targets, finite)


def _curve(device: Device, grid: np.ndarray, reference_meta: dict[str, Any],
           window_arcsec: float | None) -> Curve:
    """The device's fitted error on the phase ``grid`` [rad], with its metadata."""
    info, name = device.infos[0], device.name
    try:
        r = device.fit.result()
    except DataError as exc:
        raise DataError(f"{name}: {exc.template}") from None
    device.warnings += [f"{name}: {w}" for w in r.warnings]
    meta = {"encoder": info.encoder, "heads": device.heads,
            "periods_per_rev": info.periods_per_rev,
            "period_arcsec": r.period / ARCSEC, "periods_swept": r.periods,
            "samples": r.samples, "residual_rms_arcsec": r.residual_rms,
            "kept": [int(n) for n in r.error.orders],
            "harmonics": harmonics_meta(r.fitted), "figures": r.figures()} | reference_meta
    if r.windows is not None:
        meta |= {"windows": r.windows, "window_arcsec": window_arcsec}
    if r.ratio is not None:
        meta["period_ratio"] = r.ratio
    if r.reference is not None:
        meta["reference_harmonics"] = harmonics_meta(r.reference)
    return Curve(name, info.encoder, info.periods_per_rev, grid, r.error(grid),
                 r.error.uncertainty(grid), r.fitted, meta, device.warnings)
