"""Output files: the overwrite rule and a write that leaves nothing partial.

A command checks each file it will write with :func:`check_new_file` before doing any
work (so a refusal costs nothing), then writes it with :func:`write_atomic` (streams:
``streams.OutputStream``): into a temporary file ``.NAME.PID@HOST.RANDOM.tmp`` in the
same folder (:func:`new_temporary`), renamed over the target only once complete
(:func:`rename_into_place`), as NCO does. An interrupted or failed write leaves the old
file (or none) in place. A command with several outputs writes them as one
:class:`OutputGroup`: all are renamed into place once all are written, or none is (a
signal arriving during the renames is held until they are done:
``errors.signals_held``). A
temporary left by a killed run is removed by the next run that writes the same NAME
(:func:`remove_stale_temporaries`).

Only regular files are ever replaced. An existing output that is a device, a FIFO or a
socket (or a symbolic link to one) is refused, ``force`` or not: the rename would put a
regular file in its place (as root, writing /dev/null with ``force`` would replace it).
A symbolic link to a regular file, or a broken one, counts as an existing output: with
``force`` the link itself is replaced by the new file and the file it pointed to is
left as it was (what a rename does).
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import io
import logging
import os
import re
import socket
import stat
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import BinaryIO

from enctools.errors import DataError, OutputError, SettingsError, signals_held

STALE_AGE_S = 3600.0
"""A temporary of a dead writer is removed once its last write is this old [s]."""
LEGACY_AGE_S = 86400.0
"""A temporary that names no writer (older versions) is removed once this old [s]."""

_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def read_bytes(path: str | Path) -> bytes:
    """The whole of a small input file; DataError, one line naming the file, when it is
    missing or cannot be read."""
    with open_to_read(path) as f:
        return f.read()


def open_to_read(path: str | Path) -> io.BufferedReader:
    """An input file opened to read (binary); DataError, one line naming the file, when
    it is missing or cannot be opened."""
    try:
        return open(path, "rb")  # closed by its caller's with
    except FileNotFoundError:
        msg = f"{path}: no such file"
        raise DataError(msg) from None
    except OSError as exc:
        msg = f"{path}: cannot read: {exc.strerror or exc}"
        raise DataError(msg) from None


def read_small_text(path: str | Path, what: str, max_bytes: int, noun: str) -> str:
    """The UTF-8 text of a small input file (a rig file, a certificate file): a regular
    file of at most ``max_bytes``, checked before reading (a FIFO or a device is refused,
    never waited on). DataError, one line headed by ``what``, otherwise; ``noun`` names
    the kind of file in the size refusal ("a rig file")."""
    p = Path(path)
    try:  # O_NONBLOCK: opening a FIFO must not wait for a writer before it is refused
        with os.fdopen(os.open(p, os.O_RDONLY | os.O_NONBLOCK), "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                msg = f"{what}: not a regular file"
                raise DataError(msg)
            if st.st_size > max_bytes:
                msg = (f"{what}: {st.st_size} bytes, more than {noun} may have "
                       f"({max_bytes})")
                raise DataError(msg)
            data = f.read(max_bytes + 1)
    except FileNotFoundError:
        msg = f"{what}: no such file"
        raise DataError(msg) from None
    except OSError as exc:
        msg = f"{what}: cannot read: {exc.strerror or exc}"
        raise DataError(msg) from None
    if len(data) > max_bytes:
        msg = f"{what}: more than {max_bytes} bytes, more than {noun} may have"
        raise DataError(msg)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        msg = f"{what}: cannot read: {exc}"
        raise DataError(msg) from None


def check_new_file(path: str, force: bool) -> None:
    """OutputError naming ``path`` unless it can be written: a name of at most
    :data:`NAME_MAX` bytes, not a folder nor any other non-regular file, absent or
    ``force``, in a folder that exists and is writable."""
    p = Path(path)
    if len(os.fsencode(p.name)) > NAME_MAX:
        msg = (f"output {path}: its name is {len(os.fsencode(p.name))} bytes, over the "
               f"{NAME_MAX} a file name may have")
        raise OutputError(msg, path)
    if p.is_dir():
        msg = f"output {path}: is a directory; give a file name"
        raise OutputError(msg, path)
    check_replaceable(path)
    if os.path.lexists(p) and not force:
        raise exists(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        msg = f"output {path}: folder {parent} does not exist"
        raise OutputError(msg, path)
    if not os.access(parent, os.W_OK):
        msg = f"output {path}: folder {parent} is not writable"
        raise OutputError(msg, path)


def exists(path: str | Path) -> OutputError:
    """The refusal of an output that exists, ``force`` not given (the field named)."""
    return OutputError(f"output {path} exists; use `force` to replace it", str(path))


def check_replaceable(path: str | Path) -> None:
    """OutputError when ``path`` exists and is not a regular file (nor a link to one).

    Absent paths and broken links pass: a rename puts a new file there and loses nothing.
    """
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return
    except OSError as exc:
        msg = f"output {path}: {exc.strerror}; only regular files are replaced"
        raise OutputError(msg, str(path)) from None
    if stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode):
        return  # a folder is refused by check_new_file, and by the rename itself
    kind = next((name for test, name in _KINDS if test(st.st_mode)), "a special file")
    if os.path.islink(path):
        kind = f"a symbolic link to {kind}"
    msg = (f"output {path}: is {kind}, not a regular file; only regular files are replaced "
           "(write to stdout and redirect instead)")
    raise OutputError(msg, str(path))


def _host() -> str:
    return re.sub(r"[^A-Za-z0-9.-]", "_", socket.gethostname())[:64] or "host"


#: the longest file name [bytes] (POSIX NAME_MAX of Linux's file systems)
NAME_MAX = 255
#: the longest output name [bytes] a temporary's name holds whole; a longer one (up to
#: NAME_MAX) is held as ``~`` and a digest of it, so the temporary stays within NAME_MAX
#: whatever the host's name
_WHOLE_NAME_MAX = 150


def _stem(name: str) -> str:
    """What stands for the output ``name`` in its temporaries' names: the name, or when
    it is longer than ``_WHOLE_NAME_MAX`` bytes ``~`` and 32 hex digits of its SHA-256."""
    raw = os.fsencode(name)
    if len(raw) <= _WHOLE_NAME_MAX:
        return name
    import hashlib

    return "~" + hashlib.sha256(raw).hexdigest()[:32]


def new_temporary(path: str | Path) -> tuple[int, str]:
    """A new empty temporary file beside ``path`` (after removing stale ones): its open
    descriptor and its name ``.NAME.PID@HOST.RANDOM.tmp`` (NAME: :func:`_stem`), within
    NAME_MAX for any legal ``path``.

    The file is made with the mode ``open`` gives a new file, 0o666 less the umask, which
    the rename keeps: every output has the mode the user's umask says (``mkstemp``'s 0o600
    would have to be undone output by output, and a mode set by the writer ignores it).
    """
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    remove_stale_temporaries(p)
    prefix = f".{_stem(p.name)}.{writer_tag()}."
    if len(os.fsencode(prefix)) > 240:  # a host's name of 64 bytes: the name without it
        prefix = f".{_stem(p.name)}."
    flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    for _ in range(100):  # as mkstemp: another name when one is taken
        # os.urandom, not secrets: that imports hashlib, which most commands never need
        name = os.path.abspath(folder / f"{prefix}{os.urandom(4).hex()}.tmp")
        _live(name)  # recorded before it exists: a signal the moment it appears finds it
        try:
            return os.open(name, flags, 0o666), name
        except FileExistsError:  # a dead writer's of this process id (or a rare draw)
            _LIVE.discard(name)
            continue
        except OSError:  # not made (a signal's exception keeps it recorded: it may be)
            _LIVE.discard(name)
            raise
    raise FileExistsError(errno.EEXIST, "no unused temporary file name", str(folder))


#: the temporaries this process made that are neither renamed into place nor removed yet,
#: each recorded before it is made: removed when the process ends (atexit, which the
#: commands' endings run), so that a signal that ends a command between a temporary's
#: creation and its writer's own cleanup (the moment a watcher of the folder sends it, in
#: whichever thread it is delivered) leaves none behind
_LIVE: set[str] = set()


def _live(name: str) -> None:
    _LIVE.add(name)


@atexit.register
def _remove_live() -> None:
    for name in sorted(_LIVE):
        with contextlib.suppress(OSError):
            os.unlink(name)
    _LIVE.clear()


def _pattern(name: str) -> re.Pattern[str]:
    return re.compile(rf"\.{re.escape(name)}\.(?:(\d+)@([A-Za-z0-9._-]+)\.)?[A-Za-z0-9_]+\.tmp")


def writer_tag() -> str:
    """``PID@HOST``: who writes a temporary file or folder, as its name records it."""
    return f"{os.getpid()}@{_host()}"


def process_gone(pid: int, host: str) -> bool:
    """True when process ``pid`` of ``host`` surely no longer runs: ``host`` is this host
    and no process has that id. Another host's, another user's or a reused id: False."""
    if host != _host() or pid == os.getpid() or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # alive, another user's (EPERM), or cannot tell
        return False
    return False


def _writer_gone(pid: str | None, host: str | None, age: float) -> bool:
    """True when the writer named in a temporary's name cannot still be writing it."""
    if pid is None:  # no writer named (older versions): the age alone decides
        return age > LEGACY_AGE_S
    if host is None or age <= STALE_AGE_S:
        return False
    return process_gone(int(pid), host)


def remove_stale_temporaries(path: str | Path) -> list[str]:
    """Remove the temporaries of ``path`` (``.NAME.*.tmp`` beside it) left by killed runs;
    return their names (each logged at INFO).

    A temporary is removed only when it is a regular file owned by this user, its last
    write is more than :data:`STALE_AGE_S` ago, and the writer its name records (process
    id and host) no longer runs on this host. Why the process id and not the age alone:
    a live acquisition may write nothing for a long time (slow steps, long delays), and
    only the writer's existence says it is done. Why not a lock on the file: HDF5 takes
    and drops its own locks on the file it writes. A temporary written on another host
    is left to that host's runs (its process ids mean nothing here); one naming no writer
    (written by an older version) is removed after :data:`LEGACY_AGE_S`. A reused
    process id keeps a stale file longer, never removes a live one.
    """
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    pattern = _pattern(_stem(p.name))
    removed: list[str] = []
    uid = os.geteuid()
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    start = f".{_stem(p.name)}."
    for entry in entries:
        m = pattern.fullmatch(entry.name) if entry.name.startswith(start) else None
        if m is None:
            continue
        try:
            st = entry.stat(follow_symlinks=False)
            if (not stat.S_ISREG(st.st_mode) or st.st_uid != uid
                    or not _writer_gone(m.group(1), m.group(2), now - st.st_mtime)):
                continue
            os.unlink(entry.path)
        except OSError:
            continue
        removed.append(entry.path)
        logging.getLogger("enctools").info("removed %s, a temporary file of %s left by a "
                                           "run that was killed", entry.path, p)
    return removed


def rename_into_place(tmp: str, path: str | Path, force: bool = True) -> None:
    """Rename the complete temporary ``tmp`` over ``path``, checking ``path`` again just
    before (a device or FIFO may have appeared there since the command started; without
    ``force``, any file). On a refusal, ``tmp`` is left for the caller to remove."""
    check_replaceable(path)
    if not force and os.path.lexists(path):  # appeared meanwhile
        raise exists(path)
    os.replace(tmp, path)
    _LIVE.discard(os.path.abspath(tmp))


def write_atomic(path: str | Path, data: bytes | Callable[[BinaryIO], None], *,
                 durable: bool = False) -> None:
    """Write ``data`` (bytes, or a function writing to a binary file) to ``path`` atomically.

    The file gets the mode ``open`` would give (0o666 less the umask: :func:`new_temporary`).
    ``durable``: fsync the file and its folder, so the file survives a power cut once
    this returns (history records). A ``path`` that is not a regular file is refused
    (:func:`check_replaceable`).
    """
    p = Path(path)
    tmp = _write_temporary(p, data, durable)
    try:
        rename_into_place(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    if durable:
        _sync_folder(p)


def _write_temporary(p: Path, data: bytes | Callable[[BinaryIO], None], durable: bool) -> str:
    """``data`` written whole into a new temporary beside ``p``; its name."""
    check_replaceable(p)
    fd, tmp = new_temporary(p)
    try:
        with os.fdopen(fd, "wb") as f:
            if isinstance(data, bytes):
                f.write(data)
            else:
                data(f)
            f.flush()
            _check_complete(f)
            if durable:
                os.fsync(f.fileno())
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if exc.filename not in (None, tmp):  # another file's error (an input's)
            raise
        msg = f"output {p}: {exc.strerror or exc}"
        raise OutputError(msg, str(p)) from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return tmp


def _check_complete(f: BinaryIO) -> None:
    """OSError unless every byte written to ``f`` reached the file: a writer that goes
    around the file object (a C library's own buffered stream, as numpy's ``tofile``)
    can lose the error of a full disk or a file-size limit."""
    written, size = f.tell(), os.fstat(f.fileno()).st_size
    if size < written:
        msg = f"{size} of {written} bytes reached the file (disk full or file-size limit?)"
        raise OSError(msg)


def _sync_folder(p: Path) -> None:
    """Make a rename in ``p``'s folder durable (best effort)."""
    folder = p.parent if str(p.parent) else Path(".")
    try:
        dfd = os.open(str(folder), os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass


class OutputGroup:
    """The output files of one command: all of them replace their targets, or none does.

    Each output is written whole into its temporary (:meth:`write`, or a writer that
    :meth:`stage` s its finished temporary, as ``streams.OutputStream`` does); only when
    the block ends without an exception are the targets all checked again, then renamed
    into place one after the other (:meth:`commit`). On any failure, every temporary
    is removed and no target is touched: the files of an earlier run stay as they were.

    ``with OutputGroup() as outputs: streams.write_table(a, ..., group=outputs); ...``
    """

    def __init__(self) -> None:
        self._staged: list[tuple[str, str, bool]] = []

    def stage(self, tmp: str, path: str | Path, force: bool = True) -> None:
        """Hold the complete temporary ``tmp`` until :meth:`commit` renames it to ``path``."""
        self._staged.append((tmp, str(path), force))

    def write(self, path: str | Path, data: bytes | Callable[[BinaryIO], None], *,
              force: bool = True) -> None:
        """Write ``data`` (as :func:`write_atomic` takes it) into a temporary for ``path``;
        OutputError naming ``path`` when it cannot be written."""
        try:
            tmp = _write_temporary(Path(path), data, False)
        except OSError as exc:
            msg = f"output {path}: {exc.strerror or exc}"
            raise OutputError(msg, str(path)) from None
        self.stage(tmp, path, force)

    def commit(self) -> None:
        """Rename every temporary into place, once each target has passed its check."""
        staged, self._staged = self._staged, []
        try:
            for _, path, force in staged:
                check_replaceable(path)
                if not force and os.path.lexists(path):  # appeared meanwhile
                    raise exists(path)
            with signals_held():
                while staged:
                    tmp, path, _ = staged[0]
                    try:
                        os.replace(tmp, path)
                    except OSError as exc:
                        msg = f"output {path}: {exc.strerror or exc}"
                        raise OutputError(msg, path) from None
                    _LIVE.discard(tmp)
                    staged.pop(0)
        finally:
            self._staged = staged
            self.discard()

    def discard(self) -> None:
        """Remove every temporary not yet renamed."""
        staged, self._staged = self._staged, []
        for tmp, _, _ in staged:
            with contextlib.suppress(OSError):
                os.unlink(tmp)

    def __enter__(self) -> OutputGroup:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *rest: object) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def format_by_extension(path: str, fmt: str | None, formats: Sequence[str],
                        extensions: Mapping[str, str], what: str, hint: str) -> str:
    """The format of an output: ``fmt`` if given (one of ``formats``), else the one
    ``extensions`` gives for ``path``'s extension; SettingsError naming ``what`` otherwise
    (``hint`` says how to name it: the setting, as a field between backticks, and its
    choices)."""
    if fmt:
        if fmt not in formats:
            msg = f"unknown {what} {fmt!r} (formats: {', '.join(formats)})"
            raise SettingsError(msg)
        return fmt
    ext = Path(path).suffix.lower()
    if ext not in extensions:
        msg = f"cannot tell the {what} of {path!r} from its extension; {hint}"
        raise SettingsError(msg)
    return extensions[ext]
