"""Every file a command writes: output locations checked before any work, names kept inside them,
and each file written atomically.

A command checks its `--out` first (`prepare_out_dir`, `prepare_out_file`): a directory that cannot
be created or written, a file path that is a directory or a device, or an existing file a command
must not overwrite end the command with one line (UsageError) before any work starts. Files are
then written through `OutputDir` or `atomic_write`: the content goes to a hidden temporary file
beside the target and is renamed over it, so a file is either complete or absent, and a name that
would leave the directory (`../x`, `/abs/x`, `a/b`) is refused (UsageError).
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Callable
from pathlib import Path

from tsad_drake.errors import UsageError

#: longest file name written (the usual file-system limit)
MAX_NAME_LENGTH = 255


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call `write(temporary path)` and rename the result to `path`; the temporary file keeps
    `path`'s suffix (numpy, matplotlib and open3d choose the format by it) and is removed when
    `write` fails or is interrupted."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` atomically."""
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def safe_name(name: str) -> str:
    """`name` when it is a plain file name (no folder part, not `.` or `..`); UsageError otherwise."""
    if (not isinstance(name, str) or not name or name in (".", "..") or "/" in name
            or "\\" in name or "\0" in name or len(name) > MAX_NAME_LENGTH):
        raise UsageError(f"refusing to write {name!r}: not a plain file name inside the output "
                         "directory")
    return name


class OutputDir:
    """A directory a command writes into: every name resolves to a file directly inside it."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(os.path.realpath(root))

    def path(self, name: str) -> Path:
        """The path of file `name` inside the directory (UsageError for any other name)."""
        return self.root / safe_name(name)

    def __truediv__(self, name: str) -> Path:
        return self.path(name)

    def __fspath__(self) -> str:
        return str(self.root)

    def __str__(self) -> str:
        return str(self.root)

    def write_text(self, name: str, text: str) -> Path:
        return atomic_write_text(self.path(name), text)

    def write_with(self, name: str, write: Callable[[Path], None]) -> Path:
        """`atomic_write` of file `name` (see there)."""
        return atomic_write(self.path(name), write)

    def append_line(self, name: str, line: str) -> Path:
        """Append one line (a streaming log such as bench rows: one write call per line)."""
        path = self.path(name)
        with path.open("a", encoding="utf-8") as f:
            f.write(line.rstrip("\n") + "\n")
        return path


def _describe(err: OSError) -> str:
    return err.strerror or type(err).__name__


def prepare_out_dir(path: str | Path, option: str = "--out") -> OutputDir:
    """Create the output directory and prove it is writable, before any work is done."""
    if not str(path).strip():
        raise UsageError(f"{option} must not be empty")
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UsageError(f"{option} {out} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".tsad-write-probe-{os.getpid()}"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise UsageError(f"cannot write to output directory {out}: {_describe(err)}") from None
    return OutputDir(out)


def prepare_out_file(path: str | Path, option: str = "--out",
                     may_replace: Callable[[Path], bool] | None = None,
                     kind: str = "") -> Path:
    """Check an output file before any work: not a directory or a device, its folder created and
    writable, and (with `may_replace`) an existing file only replaced when `may_replace(path)` says
    it is one of this command's own outputs (`kind` names what that is)."""
    out = Path(path)
    if not out.name or out.name in (".", ".."):
        raise UsageError(f"{option} {path!s} is not a file name")
    if out.is_dir():
        raise UsageError(f"{option} {out} is a directory; give the path of a file")
    if out.exists() or out.is_symlink():
        try:
            mode = out.lstat().st_mode
        except OSError as err:
            raise UsageError(f"cannot use {option} {out}: {_describe(err)}") from None
        if not stat.S_ISREG(mode):
            raise UsageError(f"{option} {out} exists and is not a regular file")
        if may_replace is not None and not may_replace(out):
            raise UsageError(f"{option} {out} exists and is not {kind or 'an output of this command'}; "
                             "remove it or choose another path")
    prepare_out_dir(out.parent if str(out.parent) else ".", option)
    return out
