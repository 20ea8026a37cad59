"""Opening the files a user names: only regular files, never an input as output, never half a file.

Every reader (G-code, SVG, DXF, images) and every command that writes a result
goes through these checks, so that a FIFO with no writer cannot hang a
command, a directory or a device gives a clear error instead of a traceback, and
``svg2gcode a.svg -o a.svg`` cannot destroy the artwork it reads.

Every file labkit writes goes through :func:`atomic_output` (or
:func:`write_figure` for plots): the bytes go to a temporary file in the target's
folder, which replaces the target only once it is complete and on disk. A full
disk, Ctrl-C or an exception leaves the old file or no file — never a truncated
program whose last line leaves the beam on.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import stat
from pathlib import Path

from labkit.errors import InputError

__all__ = ["check_input_file", "check_output_file", "atomic_output", "write_figure", "figure_format", "read_json"]


def check_input_file(path, *, what: str = "input file") -> Path:
    """Return ``path`` as a :class:`~pathlib.Path` if it is a readable regular file.

    Parameters
    ----------
    path : str or os.PathLike
        The file the user named.
    what : str
        How to call it in the message ("G-code file", "SVG file", …).

    Raises
    ------
    InputError
        When the path does not exist, or is a directory, FIFO, socket or device
        (reading those could block forever or never end).

    Examples
    --------
    >>> check_input_file("/dev/null")
    Traceback (most recent call last):
    ...
    labkit.errors.InputError: /dev/null: not a regular file (a character device); expected an input file
    """
    p = Path(os.fspath(path))
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{p}: no such file; expected an existing {what}") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror}); expected a readable {what}") from None
    if not stat.S_ISREG(st.st_mode):
        kind = ("a directory" if stat.S_ISDIR(st.st_mode) else
                "a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else
                "a socket" if stat.S_ISSOCK(st.st_mode) else
                "a character device" if stat.S_ISCHR(st.st_mode) else
                "a block device" if stat.S_ISBLK(st.st_mode) else "not a file")
        raise InputError(f"{p}: not a regular file ({kind}); expected an {what}"
                         if what[0] in "aeiouAEIOU" else
                         f"{p}: not a regular file ({kind}); expected a {what}")
    return p


def check_output_file(path, *inputs, option: str = "-o") -> Path:
    """Return ``path`` as a Path, refusing to write over any of ``inputs``.

    Parameters
    ----------
    path : str or os.PathLike
        Where the command will write.
    *inputs : str or os.PathLike
        The files the command reads.
    option : str
        The option that named ``path``, for the message.

    Raises
    ------
    InputError
        When ``path`` is one of the inputs (also through links), or is a directory.

    Examples
    --------
    >>> check_output_file("/tmp/out.gcode", "/tmp/in.svg").name
    'out.gcode'
    """
    out = Path(os.fspath(path))
    if out.is_dir():
        raise InputError(f"{out}: is a directory; expected a file name to write")
    for src in inputs:
        src = Path(os.fspath(src))
        try:
            same = out.exists() and src.exists() and os.path.samefile(out, src)
        except OSError:
            same = False
        if same or out.resolve() == src.resolve():
            raise InputError(f"{out}: is also the input file {src}; "
                             f"expected a different output name ({option}), the input is left untouched")
    return out


def _new_file_mode() -> int:
    """Permission bits a plain ``open(path, "w")`` gives a new file: 0o666 less the umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def atomic_output(path, mode: str = "w", *, encoding: str | None = None, newline: str | None = None,
                  errors: str | None = None):
    """Open a temporary file beside ``path``; it replaces ``path`` only when the block completes.

    On leaving the block normally the file is flushed, ``fsync``-ed and renamed over
    ``path`` (an atomic step on one file system), then the folder is synced. On any
    exception — ``KeyboardInterrupt`` from Ctrl-C included — or a failed write
    (``ENOSPC``: disk full) the temporary file is removed and ``path`` is left as it
    was: the old file, or no file.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    mode : {"w", "wb"}
        Text or binary.
    encoding, newline, errors : str, optional
        As for :func:`open` (text mode only).

    Yields
    ------
    file object
        Open for writing on the temporary file (``.NAME.<random>.part`` in the same folder).

    Raises
    ------
    InputError
        When the file cannot be written (folder missing or read-only, disk full):
        the message names the file, the reason, and that nothing was replaced.

    Notes
    -----
    The temporary file lives in the target's folder (a rename is atomic only within
    one file system), so that folder must be writable, not only the file.
    A file that existed keeps its permission bits; a new one gets those ``open``
    would give it (0o666 less the umask). A symbolic link at ``path`` is replaced
    by the new file and the file it pointed to is left untouched: writing through
    a link could overwrite a file the user never named as output.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "job.gcode"
    >>> with atomic_output(out) as fh:
    ...     _ = fh.write("G0 X0\\n")
    >>> out.read_text()
    'G0 X0\\n'
    >>> try:
    ...     with atomic_output(out) as fh:
    ...         _ = fh.write("G1 X10 S1000")
    ...         raise KeyboardInterrupt
    ... except KeyboardInterrupt:
    ...     pass
    >>> out.read_text(), sorted(p.name for p in out.parent.iterdir())
    ('G0 X0\\n', ['job.gcode'])
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    target = Path(os.fspath(path))
    if target.is_dir():
        raise InputError(f"{target}: is a directory; expected a file name to write")
    folder = target.parent
    try:
        st = target.lstat()
        perm = stat.S_IMODE(st.st_mode) if stat.S_ISREG(st.st_mode) else _new_file_mode()
        existed = True
    except FileNotFoundError:
        perm, existed = _new_file_mode(), False
    except OSError as exc:
        raise _not_written(target, exc, existed=False) from None
    # the name is chosen first and the file created inside the try, so that Ctrl-C at any
    # instant finds the name to remove (tempfile.mkstemp returns it only after creating it)
    # (os.urandom is what secrets.token_hex reads; importing secrets loads OpenSSL, ~4 ms a command)
    tmp = folder / f".{target.name}.{os.urandom(8).hex()}.part"
    try:
        try:
            fh = _create_temporary(tmp, mode, encoding=encoding, newline=newline, errors=errors)
        except OSError as exc:
            raise _not_written(target, exc, existed=existed) from None
        with fh:
            os.fchmod(fh.fileno(), perm)
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, (FileNotFoundError, IsADirectoryError)):
            raise _not_written(target, exc, existed=existed) from None
        raise
    _sync_folder(folder)


def _create_temporary(path: Path, mode: str, *, encoding, newline, errors):
    """A new file at ``path`` (never an existing one), readable by its owner only until finished.

    The file object owns its descriptor from the start: there is no moment at which an
    interrupt could leave a bare descriptor for someone to close twice.
    """
    def owner_only(name, flags):
        return os.open(name, flags, 0o600)

    if "b" in mode:
        return open(path, "xb", opener=owner_only)
    return open(path, "x", encoding=encoding or "utf-8", newline=newline, errors=errors, opener=owner_only)


def _not_written(target: Path, exc: OSError, *, existed: bool) -> InputError:
    reason = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        reason = "the disk is full"
    kept = "the previous file is left as it was" if existed else "no file was written"
    return InputError(f"{target}: cannot be written ({reason}); {kept}")


def _sync_folder(folder: Path) -> None:
    """Make the rename itself durable (best effort: not every system opens folders)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_figure(fig, path, **savefig_options) -> None:
    """Save a matplotlib figure to ``path`` through :func:`atomic_output`.

    The format is the file name's suffix (PNG when it has none): a temporary name
    says nothing about the format, so matplotlib is told it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or os.PathLike
        Where to save: ``.png``, ``.svg``, ``.pdf`` or any format the figure's canvas supports.
    **savefig_options
        Passed to :meth:`~matplotlib.figure.Figure.savefig` (``dpi``, ``bbox_inches``, …).

    Raises
    ------
    InputError
        The suffix names no format matplotlib writes, or the file cannot be written.
    """
    with atomic_output(path, "wb") as fh:
        fig.savefig(fh, format=figure_format(path), **savefig_options)


def figure_format(path) -> str:
    """The picture format matplotlib writes for ``path``'s suffix (``png`` without one).

    Commands call it before any work, so that a preview named ``out.gcode`` is refused
    before the program beside it is written.

    Raises
    ------
    InputError
        When matplotlib writes no such format; the message lists those it writes.

    Examples
    --------
    >>> figure_format("window.SVG"), figure_format("preview")
    ('svg', 'png')
    """
    from matplotlib.backend_bases import FigureCanvasBase

    target = Path(os.fspath(path))
    fmt = target.suffix.lstrip(".").lower() or "png"
    supported = FigureCanvasBase.get_supported_filetypes()
    if fmt not in supported:
        raise InputError(f"{target}: cannot draw a '.{fmt}' file; expected one of "
                         f"{', '.join('.' + k for k in sorted(supported))}")
    return fmt


def read_json(path, *, what: str = "JSON file"):
    """The JSON value in the regular file ``path``, or a clear :class:`InputError`.

    ``path`` and ``what`` (how the message calls the file: "layout file", "fit file", …)
    are checked as by :func:`check_input_file`; text that is not JSON is refused too.

    Examples
    --------
    >>> read_json("/dev/null", what="fit file")
    Traceback (most recent call last):
    ...
    labkit.errors.InputError: /dev/null: not a regular file (a character device); expected a fit file
    """
    import json

    p = check_input_file(path, what=what)
    try:
        return json.loads(p.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: not JSON ({exc})") from None


def read_toml(path, *, what: str, format: str, version: int) -> tuple[Path, dict]:
    """(the path, the table) of a labkit TOML document with ``format`` and ``version`` keys.

    A syntax error names its line and column; another ``format`` or ``version`` is refused.
    """
    import tomllib

    p = check_input_file(path, what=what)
    try:
        data = tomllib.loads(p.read_text("utf-8"))
    except UnicodeDecodeError as exc:
        raise InputError(f"{p}: not UTF-8 text ({exc.reason} at byte {exc.start}); expected a {what}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: not valid TOML: {exc}") from None
    if data.get("format") != format:
        raise InputError(f"{p}: format = {data.get('format')!r}; expected format = \"{format}\" (a {what})")
    if data.get("version") != version:
        raise InputError(f"{p}: version = {data.get('version')!r}; this labkit reads version {version}")
    return p, data


def toml_number(where, key, value, *, lo=None, lo_open=False, whole=False):
    """``value`` read from a TOML document as a number (``whole``: an integer) at least ``lo``
    (above it with ``lo_open``); an InputError naming ``where`` and ``key`` otherwise."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok and whole:
        ok = float(value) == int(value)
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if not ok:
        kind = "a whole number" if whole else "a finite number"
        bound = "" if lo is None else f" {'>' if lo_open else '>='} {lo:g}"
        raise InputError(f"{where}: {key} = {value!r}; expected {kind}{bound}")
    return int(value) if whole else float(value)
