"""enc make-rom: evaluate an error model at every address of a code into a correction table."""

from __future__ import annotations

import click

from enctools.cli import options, runner

TARGETS = ("bin", "ihex", "mif", "coe", "mem", "csv", "acs", "siemens", "stream")


@click.command("make-rom")
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
@click.option("--target", type=click.Choice(TARGETS), default=None,
              help="Table format (default: from -o's extension; no -o: a rom stream on stdout).")
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
              help="acs/siemens: table points the control is configured for (defaults 100000/5000).")
@click.option("--verify", is_flag=True, default=False,
              help="Read the written table back and check it equals the table built.")
@options.output
@options.force
@click.option("--format", "fmt", type=click.Choice(options.FORMATS), default=None,
              help="With --target stream: the stream's format.")
@options.verbosity
def command(input: str | None, code_bits: int | None, address_bits: int | None, width: int,
            lsb: float, sample: str | None, target: str | None, endian: str, curve: str | None,
            axis: str | None, zone: int, array_name: str, max_entries: int | None, verify: bool,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Evaluate a model at every address of an n-bit code into a correction table.

    MODEL is a model stream (enc fit-rbf) or a deviations stream (--curve). Each
    entry is the correction to add to the code, -deviation in LSBs of --lsb counts,
    rounded (quantisation error <= 1/2 LSB). Formats: raw binary, Intel HEX, Altera
    MIF, Xilinx COE, Verilog $readmemh, CSV, an ACS SPiiPlus ERRORMAP1D program, a
    SINUMERIK $AA_ENC_COMP table. A summary (entries, range, largest quantisation
    error, CRC-32, size) goes to stderr. What a target cannot hold is refused.
    """
    import time

    import numpy as np

    from enctools.data import streams
    from enctools.data.header import history_line
    from enctools.errors import CheckFailed, UsageError
    from enctools.models import curve_model as models
    from enctools.models import rom, romformats

    if target is None:
        target = "stream" if output in (None, "-") or _is_stream_path(output) \
            else romformats.format_for(output, None)
    if target == "stream":
        streams.check_output(output, force, fmt)
    elif output in (None, "-"):
        raise UsageError(f"--target {target}: give the table file with -o PATH")
    elif fmt is not None:
        raise UsageError("--format applies to --target stream only")
    src = streams.open_input(input, ("model", "deviations"))
    table = src.read_all()
    evaluate = models.from_stream(src.header, table, src.source, curve)
    if code_bits is None:
        code_bits = _bits_from_rig(src.header.meta)
    controller = target in romformats.CONTROLLER
    spec = rom.RomSpec(code_bits, address_bits, width, lsb,
                       sample or ("start" if controller else "centre"))
    spec.check()
    tgt = None
    if target != "stream":
        tgt = romformats.Target(target, width, endian, count_deg=spec.lsb_arcsec / 3600.0,
                                axis=axis or ("0" if target == "acs" else "AX1"), zone=zone,
                                name=array_name, max_entries=max_entries)
        romformats.check_capacity(tgt, spec.entries)
        if output is not None and not force:
            from pathlib import Path
            if Path(output).exists():
                raise UsageError(f"output {output} exists; use --force to replace it")
    t0 = time.monotonic()
    table_ = rom.build_rom(evaluate, spec, runner.Progress("evaluating", "entries"))
    summary = table_.summary()
    summary["model"] = src.header.meta.get("model", {"kind": "deviations", "curve": curve})
    settings = {"code_bits": code_bits, "address_bits": spec.m, "width": width, "lsb": lsb,
                "sample": spec.sample, "target": target, "endian": endian}
    if tgt is None:
        import pyarrow as pa

        from enctools.data.schemas import make_field
        schema = pa.schema([make_field("address", pa.int64(), ""),
                            make_field("correction", pa.int64(), "count")])
        header = src.header.derive("rom", schema, rom=summary, settings=settings)
        with streams.OutputStream(output, streams.with_history(header), force, fmt) as out:
            for start in range(0, spec.entries, streams.BATCH_ROWS * 16):
                v = table_.values[start:start + streams.BATCH_ROWS * 16]
                out.write(pa.record_batch([pa.array(np.arange(start, start + v.size)),
                                           pa.array(v.astype(np.int64))], schema=schema))
        size = None
    else:
        comment = [f"enctools make-rom: {spec.entries} entries, {width}-bit signed corrections "
                   f"to add to a {code_bits}-bit code, LSB {spec.lsb_arcsec!r} arcsec",
                   f"CRC-32 {summary['crc32']} ({summary['crc32_of']}); "
                   + history_line()]
        size = romformats.write_table(output, table_.values, tgt, force, comment)
        if verify:
            back = romformats.read_table(output, tgt)
            if not np.array_equal(back, table_.values):
                raise CheckFailed(f"{output}: the table read back differs from the table built")
    _report(summary, size, output, time.monotonic() - t0, verify and tgt is not None)


def _is_stream_path(path: str) -> bool:
    from pathlib import Path

    from enctools.data.streams import EXTENSIONS
    return Path(path).suffix.lower() in EXTENSIONS


def _bits_from_rig(meta: dict) -> int:
    from enctools.data.readings import rig_encoders
    from enctools.errors import UsageError
    for e in rig_encoders(meta):
        cpr = e.counts_per_rev
        if cpr > 0 and cpr & (cpr - 1) == 0:
            return cpr.bit_length() - 1
    raise UsageError("the model names no rig with a 2^n-count encoder; give --bits")


def _report(s: dict, size: int | None, output: str | None, seconds: float, verified: bool) -> None:
    if runner.is_quiet():
        return
    import sys
    lines = [f"{s['entries']} entries (top {s['address_bits']} of {s['code_bits']} bits), "
             f"{s['width_bits']}-bit signed, LSB {s['lsb_arcsec']:.6g} arcsec",
             f"corrections {s['min_lsb']}..{s['max_lsb']} LSB; largest quantisation error "
             f"{s['max_quantisation_error_lsb']:.4f} LSB = {s['max_quantisation_error_arcsec']:.4g} arcsec",
             f"CRC-32 {s['crc32']} of the {s['crc32_of']} ({s['image_bytes']} bytes)"]
    if size is not None:
        lines.append(f"wrote {output}: {size} bytes in {seconds:.2f} s"
                     + ("; read back equal" if verified else ""))
    for ln in lines:
        sys.stderr.write(f"enc make-rom: {ln}\n")
