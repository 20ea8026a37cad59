"""Opening the files a user names: only regular files, never an input as output.

Every reader (G-code, SVG, DXF, images) and every command that writes a result
goes through these two checks, so that a FIFO with no writer cannot hang a
command, a directory or a device gives a clear error instead of a traceback, and
``svg2gcode a.svg -o a.svg`` cannot destroy the artwork it reads.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from labkit.errors import InputError

__all__ = ["check_input_file", "check_output_file"]


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


def check_output_file(path, *inputs) -> Path:
    """Return ``path`` as a Path, refusing to write over any of ``inputs``.

    Parameters
    ----------
    path : str or os.PathLike
        Where the command will write.
    *inputs : str or os.PathLike
        The files the command reads.

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
                             "expected a different output name (-o), the input is left untouched")
    return out
