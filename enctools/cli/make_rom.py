"""enc make-rom: evaluate an error model at every address of a code into a correction table."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from enctools.cli import options, runner, usage

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy as np

    from enctools.data.header import Header
    from enctools.data.streams import InputStream
    from enctools.data.tablemap import Mapping
    from enctools.models.rom import Rom, Settings
    from enctools.models.romformats.controls import ControlSettings



def targets() -> tuple[str, ...]:
    """The table formats of the registry, and ``stream``."""
    from enctools.models.romformats import registry

    return (*registry.names(), "stream")


#: the options of one kind of table, under its heading in --help (the formats that take
#: each are their records'; given for another format, refused by _check_applies)
MODES = {"Memories' and controllers' tables (addressed by the code)":
         ("code_bits", "address_bits", "width", "lsb", "sample", "endian", "zone", "array_name",
          "resolution_deg"),
         "Controls' tables (a grid over the turn)":
         ("bidirectional", "backlash", "points", "comp_type", "detection_unit",
          "increment_system", "home_point", "tnc"),
         "Rom streams (--target stream)": ("fmt",)}


@usage.renamed({"--ref-point": "--home-point"})
@click.command("make-rom", cls=usage.ModeCommand, modes=MODES)
@options.input_arg
@click.option("--bits", "code_bits", type=int, default=None,
              help="Bits n of the encoder code (default: from the model's rig, e.g. 23).")
@click.option("--address-bits", type=int, default=None,
              help="Address the table by the code's top m bits (default: all n).")
@click.option("--width", type=int, default=16, show_default=True,
              help="Word width [bit] of the signed correction (2..32).")
@click.option("--lsb", type=float, default=1.0, show_default=True,
              help="Counts of the n-bit code per LSB of the stored correction.")
@click.option("--sample", type=click.Choice(["centre", "start"]), default=None,
              help="Evaluate at the centre or the start of each address's codes "
                   "(default: centre; start for acs and siemens tables).")
@click.option("--target", type=options.LazyChoice(targets), default=None,
              help="Table format (default: from -o's extension; no -o: a rom stream on "
                   "stdout); the formats registered (enc-make-rom(1), Formats).")
@click.option("--endian", type=click.Choice(["little", "big"]), default="little", show_default=True,
              help="bin and ihex: byte order of the words.")
@click.option("--curve", default=None, metavar="NAME",
              help="A deviations stream as the model: the curve to use.")
@click.option("--axis", default=None, metavar="NAME",
              help="acs: axis number (default 0); siemens: machine axis (default AX1).")
@click.option("--zone", type=int, default=0, show_default=True, callback=options.non_negative,
              help="acs: error-map zone; siemens: measuring system index.")
@click.option("--array", "array_name", default="ENC_COMP", show_default=True,
              help="acs: name of the REAL array holding the map.")
@click.option("--max-entries", type=int, default=None, callback=options.positive,
              help="acs/siemens: table points the control is configured for "
                   "(defaults 100000/5000).")
@click.option("--bidirectional", is_flag=True, default=False,
              help="linuxcnc, twincat: one table per direction (default: one table of the mean "
                   "of both directions).")
@click.option("--backlash", is_flag=True, default=False,
              help="fanuc, fanuc-param, siemens: write the step run's mean reversal as the "
                   "backlash (1851; MD32450 in a machine data file beside the table) and the "
                   "positive direction's table (default: the mean of both).")
@click.option("--sign", type=click.Choice(["correction", "error"]), default=None,
              help="acs, fanuc, fanuc-param, heidenhain, twincat-nc: whether the control "
                   "stores the correction or the error.")
@click.option("--resolution", "resolution_deg", type=float, default=None,
              help="acs, siemens: the control's resolution [deg], a power of ten.")
@click.option("--comp-type", type=click.IntRange(0, 1), default=0, show_default=True,
              help="linuxcnc: COMP_FILE_TYPE (0 positions, 1 trims).")
@click.option("--points", type=int, default=None, metavar="M",
              help="Controls: points of the table over the turn, both ends included.")
@click.option("--detection-unit", type=float, default=1e-3, show_default=True,
              help="fanuc: the axis's detection unit [deg].")
@click.option("--increment-system", type=options.LazyChoice(lambda: _increment_systems()),
              default=None,
              help="fanuc: the axis's increment system, which sets the detection unit "
                   "(IS-A 0.01, IS-B 0.001, IS-C 0.0001 deg).")
@click.option("--home-point", type=int, default=0, show_default=True,
              help="fanuc: compensation point number of the reference (home) position.")
@click.option("--tnc", type=options.LazyChoice(lambda: _generations()), default=None,
              help="heidenhain: the control's generation, whose rules the table follows "
                   "(407: TNC 407/415/425; 620: MANUALplus 620 and its generation).")
@click.option("--outside", type=click.Choice(["zero", "hold"]), default=None,
              help="Where the source's targets do not cover the turn: zero correction, or "
                   "hold the nearer end's (default: refused).")
@click.option("--verify", is_flag=True, default=False,
              help="Read the written table back and check it equals the table built.")
@click.option("--allow-no-gain", is_flag=True, default=False,
              help="Write a model that does not beat no correction (enc fit-rbf's gain), "
                   "with a warning.")
@click.option("--allow-coarse", is_flag=True, default=False,
              help="Write a table whose LSB or resolution leaves an RMS error over 1/4 of "
                   "the correction's (or rounds it all to 0), with a warning.")
@options.table_columns
@options.output
@options.force
@click.option("--format", "fmt", type=click.Choice(options.FORMATS), default=None,
              help="With --target stream: the stream's format.")
@options.json_summary
@options.unit
@options.verbosity
def command(input: str | None, code_bits: int | None, address_bits: int | None, width: int,
            lsb: float, sample: str | None, target: str | None, endian: str, curve: str | None,
            axis: str | None, zone: int, array_name: str, max_entries: int | None,
            bidirectional: bool, backlash: bool, sign: str | None, resolution_deg: float | None,
            comp_type: int, points: int | None, detection_unit: float,
            increment_system: str | None, home_point: int, tnc: str | None,
            outside: str | None, verify: bool, allow_no_gain: bool, allow_coarse: bool, output:
            str | None, force: bool, fmt: str | None, as_json: bool, unit: str, mapping: Mapping,
            ) -> None:
    """Evaluate a model at every address of an n-bit code into a correction table.

    MODEL is a model stream (enc fit-rbf) or a deviations stream (--curve). Each
    entry is the correction to add to the code, -deviation in LSBs of --lsb counts,
    rounded (quantisation error <= 1/2 LSB), in a format of --target (enc-make-rom(1),
    Formats). A summary (entries, range, largest quantisation error, CRC-32, size) goes
    to stderr. What a target cannot hold is refused.

    A control's table is also built from a points stream (a step run, per target and
    direction) or a table, its columns mapped as by `enc points`: a grid over the turn
    at the control's resolution, with the interpolation error it costs in the summary.
    """
    import time

    from enctools.cli.summary import check_json, emit
    from enctools.data.streams import with_history
    from enctools.models import rom, romformats, romsource

    target, path = _target(target, output, force, fmt)
    check_json(as_json, output, "-o FILE (a table file or a stream file)")
    family = _check_applies(target)
    if family == romformats.registry.CONTROL:
        control = _control_settings(
            target=target, bidirectional=bidirectional, backlash=backlash, sign=sign,
            comp_type=comp_type, points=points, max_entries=max_entries, axis=axis, tnc=tnc,
            detection_unit=detection_unit, home_point=home_point, increment_system=increment_system)
        _control(input, curve, control, str(path), (force, verify, outside), as_json, unit,
                 (allow_no_gain, allow_coarse), mapping)
        return
    src, (evaluate, reversal), extent = _measured_model(input, family, curve, outside,
                                                        mapping, backlash)
    settings = rom.Settings(
        _bits_from_rig(src.header.meta) if code_bits is None else code_bits,
        address_bits=address_bits, width=width, lsb=lsb, sample=sample, target=target,
        endian=endian, axis=axis, zone=zone, array_name=array_name, max_entries=max_entries,
        resolution_deg=resolution_deg, sign=sign, backlash=backlash)
    _before_work(path, force, src.header.meta, allow_no_gain)
    t0 = time.monotonic()
    table = rom.scan_rom(evaluate, settings.spec, runner.Progress("evaluating", "entries"))
    _guard("rom", table, allow_coarse)
    summary = _rom_summary(table, src.header, curve, evaluate, settings) | extent
    if reversal is not None and settings.resolution_deg is not None:
        summary |= romsource.backlash_figures(reversal, settings.resolution_deg)
    size = None
    if path is None:
        header = src.header.derive("rom", rom.stream_schema(), rom=summary,
                                   settings=settings.to_meta())
        rom.write_stream(output, with_history(header, output=output), table.values, force, fmt)
    else:
        size = _write_file(path, table, settings, summary, (force, verify))
    emit(_summary(summary, size, output, time.monotonic() - t0, verify), as_json, unit)


def _write_file(path: str, table: Rom, settings: Settings, summary: dict[str, Any],
                flags: tuple[bool, bool]) -> int:
    """A memory's or controller's table file written (``flags``: --force, --verify) with
    its backlash machine datum file where the summary has one (its name then added to
    the summary), verified: the file's size [byte]."""
    from enctools.models import romformats

    force, verify = flags
    lash = summary.get("backlash_steps")
    size = romformats.write_table(path, table.values, settings.table, force,
                                  table.file_comment(path) + _range_line(summary), lash)
    if verify:
        romformats.verify_table(path, table.values, settings.table)
    if lash is not None:
        summary["machine_data"] = romformats.backlash_path(path, settings.target)
        if verify:
            # the datum is in the deviation's sign, ISO 230-2's B_mean negated
            romformats.verify_backlash(path, settings.target, -summary["reversal_mean_arcsec"],
                                       summary["backlash_unit_deg"])
    return size


def _measured_model(input: str | None, family: str | None, curve: str | None,
                    outside: str | None, mapping: Mapping, backlash: bool
                    ) -> tuple[InputStream, tuple[Callable[[np.ndarray], np.ndarray],
                                                  np.ndarray | None], dict[str, Any]]:
    """The input opened (a controller's table is built from a step run too), the deviation
    [arcsec] at angles [deg] a memory table is built from, restricted to the range its
    source measured (refused over a partial one without ``outside``), the step run's
    reversal per target [arcsec] with ``backlash`` (the deviation then its positive
    direction's), and what the summary says of that range."""
    from enctools.methods.points import open_points
    from enctools.models import domain, romsource
    from enctools.models.romformats import registry

    kinds = ("model", "deviations") + (("points",) if family == registry.CONTROLLER else ())
    src = open_points(input, kinds, mapping)

    rows = src.read_all()
    measured = domain.measured_of(src.header, rows, src.source)
    model, reversal = romsource.deviation_model(src.header, rows, src.source, curve, backlash)
    evaluate = domain.restrict(model, measured, outside, src.source)
    return src, (evaluate, reversal), domain.summary(measured, outside)


def _rom_summary(table: Rom, header: Header, curve: str | None,
                 evaluate: Callable[[np.ndarray], np.ndarray], settings: Settings
                 ) -> dict[str, Any]:
    """The table's summary, the model it came from and, for a controller's table, what
    the control's interpolation between its points costs [arcsec]."""
    from enctools.models import romsource

    summary: dict[str, Any] = table.summary()
    summary["model"] = header.meta.get("model", {"kind": header.kind, "curve": curve})
    if settings.controller:
        summary["interpolation_error_arcsec"] = romsource.interpolation_error(evaluate,
                                                                              settings.spec)
    return summary


def _before_work(path: str | None, force: bool, meta: dict, allow_no_gain: bool) -> None:
    """Refuse an existing table file without --force, then a model without gain."""
    from pathlib import Path

    from enctools.cli.usage import UsageError

    if path is not None and not force and Path(path).exists():
        msg = f"output {path} exists; use --force to replace it"
        raise UsageError(msg)
    _guard("gain", meta, allow_no_gain)


def _guard(what: str, subject: Any, allowed: bool) -> None:
    """A guard of models/tableguards.py (``gain`` of a stream's metadata; ``rom`` or
    ``control`` of a built table): refused in one line, or warned when ``allowed``."""
    from enctools.models import tableguards as g

    check = {"gain": g.gain_problem, "rom": g.rom_problem, "control": g.control_problem}[what]
    option = g.ALLOW_NO_GAIN if what == "gain" else g.ALLOW_COARSE
    warning = g.enforce(check(subject), allowed, option)
    if warning is not None:
        runner.log.warning("%s", _words(warning))


def _check_applies(target: str) -> str | None:
    """Refuse (one line) an option of one kind of table (:data:`MODES`) given for a format
    whose record does not take it; the target's family (None: a rom stream)."""
    from enctools.cli.usage import UsageError
    from enctools.models.romformats import registry

    ctx = click.get_current_context()
    fmt = None if target == "stream" else registry.get(target)
    takes = registry.ADDRESSED_SETTINGS | {"lsb"} if fmt is None else fmt.accepts
    for name in (n for names in MODES.values() for n in names if n != "fmt"):
        if name in takes or \
                ctx.get_parameter_source(name) != click.core.ParameterSource.COMMANDLINE:
            continue
        opt = next(p for p in ctx.command.params if p.name == name).opts[0]
        msg = f"{opt} applies to {_formats_taking(name)}, not --target {target}"
        raise UsageError(msg)
    return None if fmt is None else fmt.family


def _formats_taking(name: str) -> str:
    """The formats whose records take the setting ``name``, as a message names them."""
    from enctools.models.romformats import registry

    if name in registry.ADDRESSED_SETTINGS:
        return "the memories' tables, " + " and ".join(registry.names(registry.CONTROLLER))
    return ", ".join([r.name for r in registry.records() if name in r.accepts]
                     + (["stream"] if name == "lsb" else []))


def _increment_systems() -> tuple[str, ...]:
    """The increment systems the controls' records name (Fanuc's IS-A, IS-B, IS-C)."""
    from enctools.models.romformats import registry

    return tuple(dict.fromkeys(name for r in registry.records(registry.CONTROL)
                               if r.control is not None
                               for name, _ in r.control.increment_systems))


def _generations() -> tuple[str, ...]:
    """The HEIDENHAIN generations whose rules the heidenhain format knows."""
    from enctools.models.romformats.catalogue.heidenhain import GENERATIONS

    return tuple(GENERATIONS)


def _one_unit(increment_system: str | None) -> str | None:
    """--increment-system, refused beside --detection-unit (each sets the detection unit)."""
    from enctools.cli.usage import UsageError

    ctx = click.get_current_context()
    if increment_system is not None and \
            ctx.get_parameter_source("detection_unit") == click.core.ParameterSource.COMMANDLINE:
        msg = "give --increment-system or --detection-unit, not both (each sets the unit)"
        raise UsageError(msg)
    return increment_system


def _control_settings(**settings: Any) -> ControlSettings:
    """A control's table settings, --increment-system checked beside --detection-unit (the
    controls' modules imported here: a memory table never needs them)."""
    from enctools.models.romformats.controls import ControlSettings

    settings["increment_system"] = _one_unit(settings["increment_system"])
    return ControlSettings(detection_unit_deg=settings.pop("detection_unit"), **settings)


def _control(input: str | None, curve: str | None, settings: ControlSettings, path: str,
             flags: tuple[bool, bool, str | None], as_json: bool, unit: str,
             allow: tuple[bool, bool], mapping: Mapping) -> None:
    """Build a control's point table from a step run (a points stream or a table mapped
    by ``mapping``) or a model, write it, verify it (``flags``: --force, --verify,
    --outside; ``allow``: --allow-no-gain, --allow-coarse)."""
    import time

    from enctools.cli.summary import emit
    from enctools.data.header import history_line
    from enctools.methods.points import open_points
    from enctools.models import domain, romformats, romsource
    from enctools.models.romformats import controls

    force, verify, outside = flags
    t0 = time.monotonic()
    src = open_points(input, ("points", "model", "deviations"), mapping)
    rows = src.read_all()
    source = romsource.control_source(src.header, rows, src.source, curve)
    measured = source.measured or domain.measured_of(src.header, rows, src.source)
    source = domain.restrict_source(source, measured, outside, src.source)
    table = controls.build(settings, source)
    # what cannot be written is refused first, then what should not be (GUARDS)
    _guard("gain", src.header.meta, allow[0])
    _guard("control", table, allow[1])
    extent = domain.summary(measured, outside)
    comment = [f"enctools make-rom: {table.grid_deg.size} points 0..360 deg, "
               f"resolution {table.resolution_deg!r} deg; " + history_line(output=path)]
    size = romformats.write_control_table(path, table, force, comment + _range_line(extent))
    if verify:
        romformats.verify_control_table(path, table)
    companion = romformats.companion_path(path, settings.target)
    emit(table.summary | extent | {"output": path, "file_bytes": size, "verified": verify}
         | ({} if companion is None else {"assignment": companion})
         | {"elapsed_s": round(time.monotonic() - t0, 3)}, as_json, unit)


def _range_line(summary: dict[str, Any]) -> list[str]:
    """The comment line a table file gives its measured range, if the source has one."""
    if "measured_range" not in summary:
        return []
    outside = f"; outside it {summary['outside']}" if "outside" in summary else ""
    return [f"measured range {summary['measured_range']}{outside}"]


def _target(target: str | None, output: str | None, force: bool, fmt: str | None
            ) -> tuple[str, str | None]:
    """The table format (from --target or -o's extension) or ``stream``, and the table
    file's path (None for a stream), with -o and --format checked."""
    from enctools.cli.usage import UsageError
    from enctools.data import streams
    from enctools.models import romformats

    if target is None:
        target = "stream" if output is None or output == "-" or _is_stream_path(output) \
            else romformats.format_for(output, None)
    if target == "stream":
        streams.check_output(output, force, fmt)
        return target, None
    if output is None or output == "-":
        msg = f"--target {target}: give the table file with -o PATH"
        raise UsageError(msg)
    if fmt is not None:
        msg = "--format applies to --target stream only"
        raise UsageError(msg)
    return target, output


def _is_stream_path(path: str) -> bool:
    from pathlib import Path

    from enctools.data.streams import EXTENSIONS
    from enctools.models.romformats import registry
    ext = Path(path).suffix.lower()  # .csv is a table format's (address,correction)
    return ext in EXTENSIONS and registry.by_extension(ext) is None


def _bits_from_rig(meta: dict) -> int:
    from enctools.cli.usage import UsageError
    from enctools.data.readings import rig_encoders
    for e in rig_encoders(meta):
        cpr = e.counts_per_rev
        if cpr > 0 and cpr & (cpr - 1) == 0:
            return cpr.bit_length() - 1
    msg = "the model names no rig with a 2^n-count encoder; give --bits"
    raise UsageError(msg)


def _summary(s: dict, size: int | None, output: str | None, seconds: float,
             verified: bool) -> dict:
    """The table's layout, its corrections [LSB, arcsec], CRC-32 and file (enc-streams(5)),
    and a backlash machine datum written beside it (its file, steps, unit and value)."""
    from enctools.models import romsource

    corrections = {k: s[k] for k in ("min_lsb", "max_lsb", "max_quantisation_error_lsb",
                                     "max_quantisation_error_arcsec", "interpolation_error_arcsec")
                   if k in s}
    out = {"table": {k: s[k] for k in ("entries", "code_bits", "address_bits", "width_bits",
                                       "lsb_arcsec")},
           "corrections": corrections,
           "crc32": {"value": s["crc32"], "of": s["crc32_of"], "image_bytes": s["image_bytes"]},
           "output": output or "-", "elapsed_s": round(seconds, 3)}
    out |= {k: s[k] for k in ("measured_range", "outside", *romsource.BACKLASH_KEYS) if k in s}
    if size is not None:  # a table file, verified or not (a stream is not)
        out |= {"file_bytes": size, "verified": verified}
    return out


def _words(text: str) -> str:
    """A library's line naming settings by their fields, as this command's options."""
    from enctools.cli import usage
    from enctools.errors import EncError

    return usage.message(EncError(text), click.get_current_context().command, "make-rom")
