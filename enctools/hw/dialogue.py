"""A rig served by line-oriented instruments: the dialogue of each role, from the rig file.

The rig file declares the instruments (``[backend.instrument.NAME]``: a VISA resource or
a serial line, see :mod:`enctools.hw.visa` and :mod:`enctools.hw.serialline`) and, per
role, which instrument serves it and what to say to it:

- ``[backend.counter]``: one query returning every head's raw counter value
  (``read = "COUN:ALL?"``, values in the order of ``heads``); or ``kind = "nidaq"``
  for NI-DAQmx counter channels (:mod:`enctools.hw.nidaq`);
- ``[[probe]] backend`` / ``[autocollimator.backend]``: a query returning one reading
  (``read``; omitted: the instrument sends lines by itself and the next full line is
  taken), the ``field`` of a multi-value reply, a ``scale`` to the channel's unit
  (probe m, autocollimator arcsec) and an ``offset``;
- ``[motion.backend]``: ``move`` (a template with ``{deg}``, ``{rad}``, ``{arcsec}``,
  ``{counts}`` of the feedback encoder), ``in_position`` polled until it answers
  ``in_position_reply``, ``rotate`` (``{rpm}``, ``{deg_s}``, ``{rad_s}``) and ``stop``.

Every instrument may name ``init`` commands, an ``ack`` line it answers every command
with, and an ``error_query`` (SCPI ``SYST:ERR?``) read after opening, after every move,
on every fault and at the end. The format is documented in enc-rig(5), BACKENDS.

Counter values are raw (they wrap at the encoder's ``counter_bits``);
:mod:`enctools.acquire` unwraps them. Continuous mode polls the counter query every
``interval_s`` on the host clock (software-timed): use a counter box's own buffer or the
``nidaq`` counter for hardware-timed sampling.
"""

from __future__ import annotations

import logging
import math
import sys
from typing import Any

import numpy as np

from enctools.data.rig import Rig
from enctools.errors import DataError, DeviceError
from enctools.hw import backends, retry
from enctools.hw.base import Axis, Channel, Clock, Counter, Sensor, Session, carry_partial
from enctools.hw.config import check_keys, check_template, need
from enctools.units import ARCSEC, DEG, TWO_PI

log = logging.getLogger("enctools.hw")

# Keys of the backend tables this module reads (the rig loader leaves them open); a
# backend's own keys are in its record (enctools.hw.backends).
BACKEND_KEYS = {"kind", "timeout_s", "retries", "instrument", "counter"}
INSTRUMENT_KEYS = {"kind", "timeout_s", "retries", "init", "ack", "error_query", "no_error",
                   "idn"}
COUNTER_KEYS = {"kind", "instrument", "read", "heads", "separator"}
SENSOR_KEYS = {"instrument", "read", "field", "scale", "offset"}
MOTION_KEYS = {"instrument", "move", "in_position", "in_position_reply", "poll_s",
               "move_timeout_s", "rotate", "stop"}
# The fields of [motion.backend]'s command templates, with a sample value each.
TEMPLATE_FIELDS: dict[str, dict[str, Any]] = {
    "move": {"deg": 0.0, "rad": 0.0, "arcsec": 0.0, "counts": 0},
    "rotate": {"rpm": 0.0, "deg_s": 0.0, "rad_s": 0.0},
}
_BLOCK_S = 0.25  # continuous mode: a block at least every this many seconds


def backend_keys() -> set[str]:
    """The keys of ``[backend]`` in a rig of instruments: the dialogue's and its backends'."""
    return BACKEND_KEYS.union(*(b.backend_keys for b in backends.records() if b.session is None))


def instrument_keys() -> set[str]:
    """The keys of ``[backend.instrument.NAME]``: the dialogue's and every transport's."""
    return INSTRUMENT_KEYS.union(*(b.keys for b in backends.records() if b.port is not None))


class Link:
    """One instrument: its port, retry policy, acknowledgement and error queue."""

    def __init__(self, port: retry.Port, policy: retry.Policy, ack: str | None,
                 error_query: str | None, no_error: tuple[str, ...]) -> None:
        self.port = port
        self.policy = policy
        self.ack = ack
        self.error_query = error_query
        self.no_error = no_error
        self.name = port.name
        self.idn: str | None = None  # the instrument's identification, when asked

    def query(self, text: str) -> str:
        """Send a query; its reply line (timeouts retried, then DeviceError with the errors)."""
        try:
            return retry.query(self.port, text, self.policy)
        except DeviceError as exc:
            raise DeviceError(str(exc) + self._errors_suffix()) from None

    def command(self, text: str) -> None:
        """Send a command; read and check its acknowledgement when the instrument sends one."""
        if self.ack is None:
            self.port.write(text)
            return
        reply = self.query(text).strip()
        if reply != self.ack:
            msg = (f"{retry.where(self.port)}: answered {reply!r} to {text!r} "
                   f"(expected {self.ack!r}){self._errors_suffix()}")
            raise DeviceError(msg)

    def numbers(self, text: str, count: int | None = None, integer: bool = False,
                separator: str | None = None) -> list:
        raw = self.query(text)
        try:
            return retry.numbers(raw, self.port, text, count, integer, separator)
        except DeviceError as exc:
            raise DeviceError(str(exc) + self._errors_suffix()) from None

    def errors(self) -> list[str]:
        """The instrument's pending errors (empty without an ``error_query``)."""
        if not self.error_query:
            return []
        return retry.error_queue(self.port, self.error_query, self.policy, self.no_error)

    def check_errors(self, after: str) -> None:
        """DeviceError when the instrument reports errors after ``after``."""
        errs = self.errors()
        if errs:
            msg = f"{retry.where(self.port)} reports after {after!r}: {'; '.join(errs)}"
            raise DeviceError(msg)

    def _errors_suffix(self) -> str:
        if not self.error_query:
            return ""
        try:
            errs = retry.error_queue(self.port, self.error_query,
                                     retry.Policy(self.policy.timeout_s, 0), self.no_error)
        except DeviceError:
            return ""
        return f"; instrument errors: {'; '.join(errs)}" if errs else ""

    def close(self) -> None:
        try:
            errs = self.errors()
            for e in errs:
                log.warning("%s: error queue: %s", retry.where(self.port), e)
        except DeviceError as exc:
            log.debug("%s", exc)
        finally:
            self.port.close()


def open_link(name: str, cfg: dict[str, Any], rig: Rig, default_kind: str,
              policy: retry.Policy) -> Link:
    """Open the instrument ``name`` of ``[backend.instrument.NAME]``."""
    where = f"backend.instrument.{name}"
    check_keys(cfg, instrument_keys(), rig, where)
    kind = need(cfg, "kind", str, rig, where, default_kind)
    pol = retry.Policy(float(need(cfg, "timeout_s", (int, float), rig, where, policy.timeout_s)),
                       int(need(cfg, "retries", int, rig, where, policy.retries)))
    backend = backends.find(kind) if isinstance(kind, str) else None
    if backend is None or backend.port is None:
        msg = (f"rig file {rig.source}: {where}.kind must be one of "
               f"{', '.join(backends.kinds('port'))}, not {kind!r}")
        raise DataError(msg)
    port = backend.port(name, cfg, rig, pol)
    no_error = need(cfg, "no_error", (str, list), rig, where, ["0", "+0"])
    link = Link(port, pol, cfg.get("ack"), cfg.get("error_query"),
                tuple([no_error] if isinstance(no_error, str) else no_error))
    try:
        for text in need(cfg, "init", list, rig, where, []):
            link.command(str(text))
        if cfg.get("idn"):
            link.idn = link.query(str(cfg["idn"])).strip()
            log.info("%s: %s", retry.where(port), link.idn)
        for e in link.errors():
            log.warning("%s: error queue at start: %s", retry.where(port), e)
    except BaseException:
        port.close()
        raise
    return link


class PolledCounter(Counter):
    """Head counters read by one query; continuous mode polls it every interval (host clock)."""

    def __init__(self, link: Link, text: str, order: list[str], bits: dict[str, int],
                 clock: Clock, t0: float, separator: str | None) -> None:
        self.link = link
        self.text = text
        self.order = order
        self.heads = tuple(order)
        self.counter_bits = bits
        self.clock = clock
        self.t0 = t0
        self.separator = separator
        self.interval = 0.0
        self._next = 0.0

    def _sample(self) -> tuple[float, list[int]]:
        values = self.link.numbers(self.text, len(self.order), integer=True,
                                   separator=self.separator)
        return self.clock.now() - self.t0, values

    def read_now(self) -> dict[str, np.ndarray]:
        t, values = self._sample()
        out = {"t": np.array([t])}
        for name, v in zip(self.order, values, strict=True):
            out[name] = np.array([v], dtype=np.int64)
        return out

    def start(self, interval_s: float) -> None:
        self.interval = interval_s
        self._next = self.clock.now()

    def read_block(self, max_samples: int) -> dict[str, np.ndarray]:
        samples: list[tuple[float, list[int]]] = []  # one append a sample: never half of one
        began = self.clock.now()
        try:
            while len(samples) < max_samples:
                self.clock.sleep(self._next - self.clock.now())
                samples.append(self._sample())
                self._next += self.interval
                now = self.clock.now()
                if self._next < now - self.interval:  # fell behind: do not try to catch up
                    self._next = now
                if now - began >= _BLOCK_S:
                    break
        except BaseException as exc:  # a fault or a signal: the samples polled are kept
            carry_partial(exc, self._block(samples))
            raise
        return self._block(samples)

    def _block(self, samples: list[tuple[float, list[int]]]) -> dict[str, np.ndarray]:
        arr = np.array([v for _, v in samples], dtype=np.int64).reshape(len(samples),
                                                                         len(self.order))
        out: dict[str, np.ndarray] = {"t": np.array([t for t, _ in samples], dtype=np.float64)}
        for i, name in enumerate(self.order):
            out[name] = arr[:, i]
        return out

    def stop(self) -> None:
        self.interval = 0.0


class LineSensor(Sensor):
    """A probe or autocollimator read by a query (or from the lines it sends by itself)."""

    def __init__(self, link: Link, channel: Channel, text: str | None, field: int,
                 scale: float, offset: float) -> None:
        self.link = link
        self.channel = channel
        self.text = text
        self.field = field
        self.scale = scale
        self.offset = offset

    def read(self) -> float:
        if self.text:
            values = self.link.numbers(self.text)
            sent = self.text
        else:
            port = self.link.port
            port.clear()
            # After clearing, the first line may be the tail of one in transit.
            retry.read_line(port, self.link.policy, "line")
            raw = retry.read_line(port, self.link.policy, "line")
            sent = "(streamed line)"
            values = retry.numbers(raw, port, sent)
        if self.field >= len(values):
            msg = (f"{retry.where(self.link.port)}: reply to {sent!r} has {len(values)} "
                   f"values, no field {self.field}")
            raise DeviceError(msg)
        return float(values[self.field]) * self.scale + self.offset


def check_templates(cfg: dict[str, Any], rig: Rig) -> None:
    """Check ``[motion.backend]``'s ``move`` and ``rotate`` templates (DataError, one line)."""
    for key, fields in TEMPLATE_FIELDS.items():
        tpl = need(cfg, key, str, rig, "motion.backend", "")
        check_template(tpl, fields, rig, f"motion.backend.{key}")


def check_rig(rig: Rig) -> None:
    """What can be checked before any instrument library is imported or loaded.

    Each backend the rig uses checks its keys (the VISA library string: never a path
    to a shared library), then the command templates; DataError with one line.
    """
    for backend in backends.used_by(rig):
        if backend.check is not None:
            backend.check(rig)
    mb = rig.motion.get("backend")
    if isinstance(mb, dict):
        check_templates(mb, rig)


class LineAxis(Axis):
    """A motion controller driven by command templates; waits for in-position."""

    def __init__(self, link: Link, cfg: dict[str, Any], counts_per_rev: int, clock: Clock,
                 rig: Rig) -> None:
        where = "motion.backend"
        self.link = link
        self.clock = clock
        self.cpr = counts_per_rev
        self.move_tpl = need(cfg, "move", str, rig, where, "")
        self.inpos = need(cfg, "in_position", str, rig, where, "")
        self.inpos_reply = str(need(cfg, "in_position_reply", (str, int), rig, where, "1"))
        self.poll_s = float(need(cfg, "poll_s", (int, float), rig, where, 0.05))
        self.move_timeout = float(need(cfg, "move_timeout_s", (int, float), rig, where, 120.0))
        self.rotate_tpl = need(cfg, "rotate", str, rig, where, "")
        self.stop_cmd = need(cfg, "stop", str, rig, where, "")
        check_templates(cfg, rig)

    def _need(self, what: str, value: str) -> str:
        if not value:
            msg = f"[motion.backend] has no {what!r} command: this run needs one"
            raise DataError(msg)
        return value

    def rotate(self, speed: float) -> None:
        if not self.rotate_tpl:
            log.info("[motion.backend] has no 'rotate': the table must be turned by its own drive")
            return
        tpl = self.rotate_tpl
        self.link.command(tpl.format(rpm=speed * 60.0 / TWO_PI, deg_s=speed / DEG, rad_s=speed))

    def stop(self) -> None:
        """Stop turning; while another fault is being handled, a failure is only logged."""
        if not self.stop_cmd:
            return
        unwinding = sys.exc_info()[0] is not None  # called from a finally during a fault
        try:
            self.link.command(self.stop_cmd)
        except DeviceError as exc:
            if not unwinding:
                raise
            log.error("could not stop the table: %s", exc)

    def move_to(self, angle: float) -> None:
        text = self._need("move", self.move_tpl).format(
            deg=angle / DEG, rad=angle, arcsec=angle / ARCSEC,
            counts=round(angle * self.cpr / TWO_PI))
        self.link.command(text)
        self.link.check_errors(text)
        if not self.inpos:
            return
        began = self.clock.now()
        while True:
            reply = self.link.query(self.inpos).strip()
            if reply == self.inpos_reply:
                return
            if self.clock.now() - began > self.move_timeout:
                msg = (f"{retry.where(self.link.port)}: not in position "
                       f"{self.move_timeout:g} s after {text!r} (last reply to "
                       f"{self.inpos!r}: {reply!r}){self.link._errors_suffix()}")
                raise DeviceError(msg)
            self.clock.sleep(self.poll_s)


class NoAxis(Axis):
    """A rig without a motion controller: turned by hand or by its own drive; no moves."""

    def rotate(self, speed: float) -> None:
        log.info("the rig has no [motion.backend]: the table must be turned by its own drive")

    def stop(self) -> None:
        pass

    def move_to(self, angle: float) -> None:
        raise DataError("the rig has no [motion.backend]: it cannot move the table")


class InstrumentSession(Session):
    """A rig whose roles are served by instruments named in the rig file."""

    def __init__(self, rig: Rig, timeout_s: float | None = None,
                 retries: int | None = None) -> None:
        self.rig = rig
        self.clock = Clock()
        self.links: dict[str, Link] = {}
        be = rig.backend
        check_keys(be, backend_keys(), rig, "backend")
        self.kind = str(be.get("kind", "visa"))
        check_rig(rig)
        self.policy = retry.Policy(
            float(timeout_s if timeout_s is not None else need(be, "timeout_s", (int, float),
                                                                rig, "backend", 1.0)),
            int(retries if retries is not None else need(be, "retries", int, rig, "backend", 2)))
        self._overrides = {k: v for k, v in (("timeout_s", timeout_s), ("retries", retries))
                           if v is not None}
        self.sensors: dict[str, Sensor] = {}
        self.axis: Axis = NoAxis()
        try:
            self._open()
        except BaseException:
            self.close()
            raise

    def _link(self, name: Any, where: str) -> Link:
        instruments = need(self.rig.backend, "instrument", dict, self.rig, "backend", {})
        if not isinstance(name, str) or name not in instruments:
            known = ", ".join(instruments) or "none declared"
            msg = (f"rig file {self.rig.source}: {where}.instrument names no instrument "
                   f"{name!r} of [backend.instrument.*] ({known})")
            raise DataError(msg)
        if name not in self.links:
            cfg = instruments[name]
            if not isinstance(cfg, dict):
                msg = f"rig file {self.rig.source}: backend.instrument.{name} must be a table"
                raise DataError(msg)
            cfg = dict(cfg) | self._overrides
            self.links[name] = open_link(name, cfg, self.rig, backends.default_port(self.kind),
                                         self.policy)
        return self.links[name]

    def _open(self) -> None:
        rig = self.rig
        self.t0 = self.clock.now()
        cfg = need(rig.backend, "counter", dict, rig, "backend", {})
        kind = cfg.get("kind", self.kind)
        backend = backends.find(kind) if isinstance(kind, str) else None
        if backend is not None and backend.counter is not None:
            self.counter: Counter = backend.counter(rig, cfg, self.clock, self.t0)
        else:
            self.counter = self._polled_counter(cfg)
        for p in rig.probes:
            self.sensors[p.name] = self._sensor(
                p.backend, f"probe {p.name} backend",
                Channel(p.name, "m", "probe", {"arm_m": p.arm_mm / 1000.0, "side": p.side}))
        if rig.autocollimator.get("backend") is not None:
            name = rig.autocollimator.get("name", "AC")
            self.sensors[name] = self._sensor(rig.autocollimator["backend"],
                                              "autocollimator.backend",
                                              Channel(name, "arcsec", "autocollimator"))
        mb = rig.motion.get("backend")
        if mb is not None:
            check_keys(mb, MOTION_KEYS, rig, "motion.backend")
            feedback = rig.motion.get("feedback")
            enc = next((e for e in rig.encoders if e.name == feedback), rig.encoders[0])
            self.axis = LineAxis(self._link(mb.get("instrument"), "motion.backend"), mb,
                                 enc.counts_per_rev, self.clock, rig)

    def _polled_counter(self, cfg: dict[str, Any]) -> Counter:
        rig = self.rig
        check_keys(cfg, COUNTER_KEYS, rig, "backend.counter")
        order = need(cfg, "heads", list, rig, "backend.counter", rig.head_names)
        missing = [h for h in rig.head_names if h not in order]
        unknown = [h for h in order if h not in rig.head_names]
        if missing or unknown:
            what = (f"lacks head {missing[0]!r}" if missing
                    else f"names unknown head {unknown[0]!r}")
            msg = (f"rig file {rig.source}: backend.counter.heads {what} "
                   f"(the rig's heads: {', '.join(rig.head_names)})")
            raise DataError(msg)
        link = self._link(cfg.get("instrument"), "backend.counter")
        bits = {h.name: e.counter_bits for e, h in rig.heads}
        return PolledCounter(link, need(cfg, "read", str, rig, "backend.counter"), list(order),
                             bits, self.clock, self.t0, cfg.get("separator"))

    def _sensor(self, cfg: Any, where: str, channel: Channel) -> Sensor:
        rig = self.rig
        if not cfg:
            msg = (f"rig file {rig.source}: {channel.role} {channel.name} has no backend table "
                   f"(the {self.kind} backend reads it from an instrument)")
            raise DataError(msg)
        check_keys(cfg, SENSOR_KEYS, rig, where)
        scale = float(need(cfg, "scale", (int, float), rig, where, 1.0))
        offset = float(need(cfg, "offset", (int, float), rig, where, 0.0))
        if not (math.isfinite(scale) and scale != 0):
            msg = f"rig file {rig.source}: {where}.scale must be a finite non-zero number"
            raise DataError(msg)
        return LineSensor(self._link(cfg.get("instrument"), where), channel,
                          need(cfg, "read", str, rig, where, "") or None,
                          int(need(cfg, "field", int, rig, where, 0)), scale, offset)

    def describe(self) -> dict[str, Any]:
        return {"backend": self.kind, "timeout_s": self.policy.timeout_s,
                "retries": self.policy.retries,
                "instruments": {n: {"address": lk.port.address} | ({"idn": lk.idn} if lk.idn
                                                                     else {})
                                for n, lk in self.links.items()}}

    def close(self) -> None:
        counter = getattr(self, "counter", None)
        if counter is not None and hasattr(counter, "close"):
            try:
                counter.close()
            except Exception as exc:  # noqa: BLE001 - closing must not hide the first error
                log.debug("closing the counter: %s", exc)
        links, self.links = self.links, {}
        for link in links.values():
            try:
                link.close()
            except Exception as exc:  # noqa: BLE001 - closing must not hide the first error
                log.debug("closing %s: %s", link.name, exc)
