"""Output files: checked before a command runs, written atomically, all of a command's or none.

Every file refimpl writes goes through this module (the CLI, ``io.write_text_atomic``, the
scene, plot and benchmark writers).  The rules (docs/robustness.md, "Outputs"):

* **Checked first.**  :func:`check_outputs` runs before any work: an output may not be the
  same file as an input or as another output of the command (compared by resolved real path,
  and by device and inode when both exist, so symlinks and hard links count), may not be a
  directory, and its folder must exist or be creatable (the nearest existing ancestor is a
  writable directory).  A path that names a folder (ends in ``/``, or in ``/.``) is not a
  file, whether that folder exists or not.  A violation is an :class:`OutputError`: one line,
  exit 2.
* **Atomic.**  A regular file is written to a temporary file beside its real target and renamed
  over it only when the command has succeeded; an interrupted or failed command leaves the old
  file (or nothing) and no temporary file.  :class:`OutputSet` stages several outputs and
  renames them together at the end, so a command's outputs all land or none do.  (Renames in
  one folder do not fail in practice; if one of several renames did fail, the earlier ones
  would have landed: POSIX offers no multi-file transaction.)
* **Symlinks** are written through: the real target is replaced, the link stays a link.
* **Device nodes and FIFOs** (``/dev/null``, ``/dev/stdout``, a named pipe) are never
  replaced: the output is staged in an anonymous temporary file and copied into them when the
  command succeeds.  ``-`` is standard output, staged the same way.
* **Write errors name the file.**  An OS error while staging, writing or committing an output
  (a full disk, a quota, an I/O error, a read-only folder) is an :class:`OutputWriteError`
  naming that output, e.g. ``cannot write out.txt: No space left on device`` (a closed pipe on
  standard output stays a ``BrokenPipeError``: the reader went away).
* **Modes.**  Replacing an existing file keeps its permission bits (and, as root, its owner);
  a new file gets ``0o666 & ~umask``, as ``open()`` would give it.
"""

from __future__ import annotations

import os
import shutil
import stat
import sys
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Iterator, Mapping

from ..core.errors import UserFacingError

STDOUT = "-"


class OutputError(UserFacingError):
    """An output path that cannot or must not be written: one line, exit code 2."""


class OutputWriteError(OutputError, OSError):
    """An OS error writing one output (disk full, quota, I/O error), naming the output: one line,
    exit 2 in the CLI; an OSError still (errno, strerror, filename) for a caller that catches those."""

    def __init__(self, shown: str, exc: OSError):
        OSError.__init__(self, exc.errno, exc.strerror, shown)
        self.path, self.message = shown, f"cannot write {shown}: {exc.strerror or exc}"
        self.cause = exc

    def __str__(self) -> str:
        return self.message

    def __reduce__(self):
        return OutputWriteError, (self.path, self.cause)


def _shown(path: str) -> str:
    return "standard output" if path == STDOUT else path


def _names_a_folder(path: str) -> bool:
    """``dir/``, ``dir/.``, ``..``: a path whose last part is a folder whatever is on the disk."""
    seps = os.sep + (os.altsep or "")
    return path.endswith(tuple(seps)) or os.path.basename(path) in (".", "..") or path in (".", "..")


def _umask() -> int:
    """The process umask, read without changing it where the kernel reports it."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)  # fallback: read by setting and restoring at once
    os.umask(old)
    return old


def _identity(path: str) -> tuple[str, tuple[int, int] | None]:
    real = os.path.realpath(path)
    try:
        st = os.stat(real)
        return real, (st.st_dev, st.st_ino)
    except OSError:
        return real, None


def _same(a: tuple[str, tuple[int, int] | None], b: tuple[str, tuple[int, int] | None]) -> bool:
    return a[0] == b[0] or (a[1] is not None and a[1] == b[1])


def _is_special(st: os.stat_result) -> bool:
    return stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) or stat.S_ISFIFO(st.st_mode) \
        or stat.S_ISSOCK(st.st_mode)


def check_output(label: str, path: str) -> None:
    """One output path is writable as a file (see the module doc); raises OutputError."""
    if path == STDOUT:
        return
    if not path:
        raise OutputError(f"{label}: empty output path")
    if _names_a_folder(path) and not os.path.isdir(path):
        raise OutputError(f"{label} {path}: names a folder, not a file; give a file name "
                          f"(e.g. {os.path.join(path, 'out.txt')})")
    real = os.path.realpath(path)
    try:
        st = os.stat(real)
    except FileNotFoundError:
        st = None
    except NotADirectoryError:
        raise OutputError(f"{label} {path}: a folder on the path is not a directory") from None
    except OSError as exc:
        raise OutputError(f"{label} {path}: {exc.strerror}") from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise OutputError(f"{label} {path}: is a directory, not a file")
        if not os.access(real, os.W_OK):
            raise OutputError(f"{label} {path}: not writable")
        if _is_special(st):
            return
    folder = Path(real).parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"{label} {path}: {folder} is not a directory")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{label} {path}: folder {folder} is not writable")


def check_outputs(outputs: Mapping[str, str | None], inputs: Mapping[str, str | None] = {}) -> None:
    """Refuse, before any work, outputs that would destroy an input or each other (OutputError).

    ``outputs`` and ``inputs`` map an option name (e.g. ``--out``) to its path (None: not given).
    """
    given_in = [(label, p, _identity(p)) for label, p in inputs.items() if p and p != STDOUT]
    seen: list[tuple[str, str, tuple]] = []
    stdout_label = None
    for label, path in outputs.items():
        if path is None:
            continue
        if path == STDOUT:
            if stdout_label is not None:
                raise OutputError(f"{label} and {stdout_label} both write to standard output (-)")
            stdout_label = label
            continue
        check_output(label, path)
        ident = _identity(path)
        special = ident[1] is not None and _is_special(os.stat(ident[0]))
        for in_label, in_path, in_ident in given_in:
            if _same(ident, in_ident):
                raise OutputError(f"{label} {path} is the same file as the input {in_label} {in_path}: "
                                  "refusing to overwrite an input")
        for other_label, other_path, other_ident in seen:
            if _same(ident, other_ident) and not special:
                raise OutputError(f"{label} {path} is the same file as {other_label} {other_path}: "
                                  "each output needs its own file")
        seen.append((label, path, ident))


@dataclass
class _Staged:
    target: str           # the real path (symlinks resolved), or "-" for standard output
    handle: IO
    tmp: str | None       # temporary file beside the target (regular targets)
    binary: bool
    shown: str            # the path as given, for messages


class _Handle:
    """A staged output's file, as callers see it: an OS error writing it names the output."""

    def __init__(self, raw: IO, shown: str):
        self._raw, self._shown = raw, shown

    def _call(self, name: str, *args):
        try:
            return getattr(self._raw, name)(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputWriteError(self._shown, exc) from None

    def write(self, data):
        return self._call("write", data)

    def writelines(self, lines) -> None:
        self._call("writelines", lines)

    def flush(self) -> None:
        self._call("flush")

    def close(self) -> None:
        self._call("close")

    def __getattr__(self, name: str):  # fileno, closed, tell, seek, ... as the file has them
        return getattr(self._raw, name)

    def __enter__(self) -> "_Handle":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@contextmanager
def _naming(shown: str) -> Iterator[None]:
    """An OS error inside names the output ``shown`` (a closed pipe stays what it is)."""
    try:
        yield
    except BrokenPipeError:
        raise
    except OutputError:
        raise
    except OSError as exc:
        raise OutputWriteError(shown, exc) from None


class OutputSet:
    """Outputs staged during a command and committed together (see the module doc).

    Use as a context manager: a normal exit commits, an exception (KeyboardInterrupt included)
    removes every temporary file and the folders it created, and re-raises.
    """

    def __init__(self) -> None:
        self._staged: list[_Staged] = []
        self._made_dirs: list[Path] = []
        self._done = False

    def open(self, path: str | os.PathLike, binary: bool = False) -> IO:
        """A writable file whose content lands at ``path`` on commit."""
        path = os.fspath(path)
        check_output("output", path)
        with _naming(_shown(path)):
            handle = self._open(path, binary)
        return _Handle(handle, _shown(path))

    def _open(self, path: str, binary: bool) -> IO:
        if path == STDOUT:
            handle = tempfile.TemporaryFile("w+b" if binary else "w+", **({} if binary else
                                                                         {"encoding": "utf-8", "newline": "\n"}))
            self._staged.append(_Staged(STDOUT, handle, None, binary, _shown(path)))
            return handle
        real = os.path.realpath(path)
        try:
            special = _is_special(os.stat(real))
        except FileNotFoundError:
            special = False
        if special:
            handle = tempfile.TemporaryFile("w+b" if binary else "w+", **({} if binary else
                                                                         {"encoding": "utf-8", "newline": "\n"}))
            self._staged.append(_Staged(real, handle, None, binary, path))
            return handle
        folder = Path(real).parent
        missing = []
        while not folder.exists():
            missing.append(folder)
            folder = folder.parent
        for d in reversed(missing):
            d.mkdir()
            self._made_dirs.append(d)
        fd, tmp = tempfile.mkstemp(dir=Path(real).parent, prefix=f".{Path(real).name}.", suffix=".tmp")
        try:
            handle = os.fdopen(fd, "wb" if binary else "w", **({} if binary else
                                                               {"encoding": "utf-8", "newline": "\n"}))
        except BaseException:
            os.close(fd)
            os.unlink(tmp)
            raise
        self._staged.append(_Staged(real, handle, tmp, binary, path))
        return handle

    def write(self, path: str | os.PathLike, data: str | bytes) -> None:
        """Stage the whole content of one output (its temporary file is closed at once, so a set
        of many outputs does not hold many open files)."""
        handle = self.open(path, binary=isinstance(data, bytes))
        staged = self._staged[-1]
        with _naming(staged.shown):
            staged.handle.write(data)
            if staged.tmp is not None:
                staged.handle.flush()
                os.fsync(staged.handle.fileno())
                staged.handle.close()

    def commit(self) -> None:
        """Flush every staged output to disk, then put each in place."""
        umask = _umask()
        for s in self._staged:
            with _naming(s.shown):
                self._flush(s, umask)
        for s in self._staged:
            with _naming(s.shown):
                self._land(s)
        self._done = True
        self._made_dirs.clear()

    @staticmethod
    def _flush(s: _Staged, umask: int) -> None:
        """One staged output on disk in its temporary file, with the target's (or a new file's) mode."""
        if not s.handle.closed:
            s.handle.flush()
        if s.tmp is not None:
            if not s.handle.closed:
                os.fsync(s.handle.fileno())
                s.handle.close()
            try:
                st = os.stat(s.target)
                os.chmod(s.tmp, stat.S_IMODE(st.st_mode))
                if os.geteuid() == 0:
                    os.chown(s.tmp, st.st_uid, st.st_gid)
            except FileNotFoundError:
                os.chmod(s.tmp, 0o666 & ~umask)

    @staticmethod
    def _land(s: _Staged) -> None:
        """One staged output in place: renamed over its target, or copied into stdout / a device."""
        if s.tmp is not None:
            os.replace(s.tmp, s.target)
            s.tmp = None
        else:
            s.handle.seek(0)
            if s.target == STDOUT:
                sys.stdout.flush()
                out = sys.stdout.buffer if s.binary else sys.stdout
                shutil.copyfileobj(s.handle, out)
                out.flush()
            else:
                with open(s.target, "wb" if s.binary else "w",
                          **({} if s.binary else {"encoding": "utf-8", "newline": "\n"})) as fh:
                    shutil.copyfileobj(s.handle, fh)
            s.handle.close()

    def abort(self) -> None:
        """Remove every temporary file (and the folders this set created); targets are untouched."""
        for s in self._staged:
            try:
                s.handle.close()
            except Exception:  # noqa: BLE001 - closing a half-written temp file; it is removed next
                pass
            if s.tmp is not None:
                try:
                    os.unlink(s.tmp)
                except FileNotFoundError:
                    pass
        self._staged.clear()
        for d in reversed(self._made_dirs):
            try:
                d.rmdir()
            except OSError:
                pass
        self._made_dirs.clear()

    def __enter__(self) -> "OutputSet":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None and not self._done:
            try:
                self.commit()
            except BaseException:
                self.abort()
                raise
        elif exc_type is not None:
            self.abort()


@contextmanager
def atomic_file(path: str | os.PathLike, binary: bool = False) -> Iterator[IO]:
    """One output written atomically: ``with atomic_file(p) as fh: fh.write(...)``."""
    with OutputSet() as outs:
        yield outs.open(path, binary=binary)


def write_atomic(path: str | os.PathLike, data: str | bytes) -> None:
    """Write text or bytes to path atomically (the rules of the module doc)."""
    with atomic_file(path, binary=isinstance(data, bytes)) as fh:
        fh.write(data)


def section_text(path: str | os.PathLike, begin: str, end: str, body: str, title: str = "# Benchmarks") -> str:
    """A markdown file's text with the block between the begin/end markers replaced (appended if
    absent; a missing file starts with ``title``): how the report commands update docs/*.md."""
    p = Path(path)
    text = p.read_text(encoding="utf-8") if p.exists() else title + "\n"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + block + tail
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    return text


def write_section(path: str | os.PathLike, begin: str, end: str, body: str, title: str = "# Benchmarks") -> None:
    """Replace the text between the begin/end markers of a markdown file (append them if absent), atomically."""
    write_atomic(path, section_text(path, begin, end, body, title))
