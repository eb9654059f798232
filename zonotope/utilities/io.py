"""Safe output writing shared by ``zonotope``, ``isp`` and ``splat``.

Rules every output follows:

- **atomic**: data go to a temporary sibling (same folder, so the final ``os.replace`` is a rename on
  one file system), are flushed and ``fsync``-ed, then renamed over the destination. A reader, or a
  later run after a crash, sees either the previous file or the complete new one, never a mix;
- **no orphans**: the temporary is removed on any exception, ``KeyboardInterrupt`` included. A
  process killed outright (SIGKILL, power loss) cannot clean up, so temporaries carry the writer's
  process id in their name and the next write to the same destination removes those of dead
  processes;
- **normal permissions**: files get ``0o666 & ~umask`` and folders ``0o777 & ~umask``, like any file
  the user creates (``tempfile`` makes them private, 0600 / 0700);
- **nothing but a previous output is replaced**, and only when asked: :func:`check_output` runs
  *before* the long work and refuses an existing destination unless ``overwrite`` is given and the
  destination carries the mark of the same command (:data:`MARKER` inside a folder, or a signature
  line at the top of a text file).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from .._errors import ZonotopeError

__all__ = [
    "MARKER",
    "OutputExistsError",
    "atomic_dir",
    "atomic_file",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output",
    "clean_stale_temporaries",
]

#: File written inside every output folder: its first line names the command that wrote it.
MARKER = ".zonotope-output"

_TMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.(?:tmp|partial)-[A-Za-z0-9_]+(?:\.[A-Za-z0-9]+)?$")


class OutputExistsError(ZonotopeError, FileExistsError):
    """The output path exists and may not be replaced (not asked to, or not an output of this command)."""


def _umask() -> int:
    # os.umask can only be read by setting it; restore at once (single-threaded writers only race
    # on the value they themselves set back).
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _make_parent(dest: Path) -> None:
    """Create ``dest``'s folder; a file in the way is an :class:`OutputExistsError`, not a raw
    ``FileExistsError`` / ``NotADirectoryError``."""
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise OutputExistsError(
            f"cannot create the folder of {str(dest)!r}: a file of that name (or of one "
            "of its parents) is in the way. Choose another output path."
        ) from None


def _temp_name(dest: Path, kind: str) -> str:
    return f".{dest.name}.{os.getpid()}.{kind}-"


def clean_stale_temporaries(dest: str | os.PathLike) -> list[Path]:
    """Remove temporaries of ``dest`` left by writer processes that no longer run.

    Returns the paths removed. Temporaries of live processes (a concurrent writer) are kept.
    """
    dest = Path(dest)
    removed: list[Path] = []
    try:
        entries = list(dest.parent.iterdir()) if dest.parent.is_dir() else []
    except OSError:
        return removed
    for p in entries:
        m = _TMP.match(p.name)
        if not m or m.group("name") != dest.name or _pid_alive(int(m.group("pid"))):
            continue
        with contextlib.suppress(OSError):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
            removed.append(p)
    return removed


def _signature_ok(dest: Path, signature: str | None) -> bool:
    """Whether ``dest`` is an output of the command identified by ``signature``."""
    if signature is None:
        return False
    if dest.is_dir():
        try:
            return (dest / MARKER).read_text(encoding="utf-8").splitlines()[:1] == [signature]
        except (OSError, UnicodeDecodeError):
            return False
    try:
        with open(dest, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    return signature.encode("utf-8") in head.split(b"\n", 1)[0]


def check_output(
    dest: str | os.PathLike,
    *,
    overwrite: bool = False,
    signature: str | None = None,
    inputs: Iterable[str | os.PathLike | None] = (),
    what: str = "output",
) -> Path:
    """Refuse an output path before any long work starts.

    Parameters
    ----------
    dest
        The file or folder about to be written.
    overwrite
        Whether the caller asked to replace an existing output.
    signature
        What marks an output of this command: the first line of :data:`MARKER` in a folder, or a text
        that the first line of a file contains. ``None``: no existing path is ever replaced.
    inputs
        Files the command reads; ``dest`` may never be one of them (nor contain one, for folders).
    what
        The argument's name for messages (e.g. ``"--markdown"``).

    Returns
    -------
    Path
        ``dest`` as a Path.

    Raises
    ------
    OutputExistsError
        ``dest`` is an input, exists without ``overwrite``, or exists but is not an output of this
        command (then it is never replaced, ``overwrite`` or not).
    """
    dest = Path(dest)
    for p in inputs:
        if p is None:
            continue
        p = Path(p)
        try:
            same = p.exists() and dest.exists() and os.path.samefile(p, dest)
        except OSError:
            same = False
        if same or p.resolve() == dest.resolve() or dest.resolve() in p.resolve().parents:
            raise OutputExistsError(
                f"{what}={str(dest)!r} is (or holds) the input {str(p)!r}; refusing to "
                "overwrite an input. Choose another output path."
            )
    if not (dest.exists() or dest.is_symlink()):
        blocker = next((p for p in dest.parents if p.exists()), None)
        if blocker is not None and not blocker.is_dir():
            raise OutputExistsError(
                f"{what}={str(dest)!r}: {str(blocker)!r} is a file, not a folder. Choose another output path."
            )
        return dest
    if not overwrite:
        raise OutputExistsError(
            f"{what}={str(dest)!r} already exists; choose another path, or pass "
            "overwrite/--force to replace a previous output of this command."
        )
    if dest.is_symlink() or not _signature_ok(dest, signature):
        kind = "folder" if dest.is_dir() else "file"
        raise OutputExistsError(
            f"{what}={str(dest)!r} exists but is not an output of this command (no "
            f"{MARKER if dest.is_dir() else 'signature line'} in the {kind}); it is never replaced. "
            "Choose another path, or move it away yourself."
        )
    return dest


@contextlib.contextmanager
def atomic_file(dest: str | os.PathLike, *, mode: str = "wb") -> Iterator:
    """Context manager yielding an open temporary file that becomes ``dest`` on success.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_file(d / "a.txt", mode="w") as fh:
    ...     _ = fh.write("hello")
    >>> (d / "a.txt").read_text()
    'hello'
    """
    dest = Path(dest)
    _make_parent(dest)
    clean_stale_temporaries(dest)
    fd, tmp = tempfile.mkstemp(prefix=_temp_name(dest, "tmp"), dir=dest.parent)
    try:
        kwargs = {"encoding": "utf-8", "newline": ""} if "b" not in mode else {}
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, dest)
        _fsync_dir(dest.parent)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_path(dest: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp_path)`` (a writer that takes a file name, e.g. ``np.savez``), then rename.

    The temporary keeps ``dest``'s suffix (some writers append one otherwise)."""
    dest = Path(dest)
    _make_parent(dest)
    clean_stale_temporaries(dest)
    fd, tmp = tempfile.mkstemp(prefix=_temp_name(dest, "tmp"), suffix=dest.suffix, dir=dest.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, dest)
        _fsync_dir(dest.parent)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return dest


def atomic_write_bytes(dest: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``dest`` atomically (see the module notes)."""
    with atomic_file(dest, mode="wb") as fh:
        fh.write(data)
    return Path(dest)


def atomic_write_text(dest: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``dest`` atomically (see the module notes)."""
    return atomic_write_bytes(dest, text.encode("utf-8"))


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths atomically (Linux ``renameat2`` with ``RENAME_EXCHANGE``, glibc ≥ 2.28);
    False, with nothing changed, where that call or flag is not available."""
    import ctypes
    import ctypes.util

    try:
        renameat2 = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2  # <fcntl.h>, <linux/fs.h>
    return renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _fsync_tree(folder: Path) -> None:
    for root, _, files in os.walk(folder):
        for f in files:
            with contextlib.suppress(OSError), open(os.path.join(root, f), "rb") as fh:
                os.fsync(fh.fileno())
        _fsync_dir(Path(root))


@contextlib.contextmanager
def atomic_dir(dest: str | os.PathLike, *, signature: str, overwrite: bool = False) -> Iterator[Path]:
    """Context manager yielding a temporary folder that becomes ``dest`` when the block succeeds.

    The folder gets a :data:`MARKER` file whose first line is ``signature``, so that a later
    ``overwrite`` of the same command recognises it. An existing ``dest`` is replaced only if
    :func:`check_output` allows it (call that first, before the long work, too): the two folders are
    swapped in one atomic step (Linux ``renameat2(RENAME_EXCHANGE)``) and the old one, now at the
    temporary name, removed, so ``dest`` is always one complete folder. Where the exchange is not
    available (another OS or file system) the old folder is renamed aside and the new one renamed in: a
    kill between those two renames leaves no ``dest``. On any exception the temporary folder is removed.
    """
    dest = Path(dest)
    _make_parent(dest)
    clean_stale_temporaries(dest)
    tmp = Path(tempfile.mkdtemp(prefix=_temp_name(dest, "partial"), dir=dest.parent))
    try:
        tmp.chmod(0o777 & ~_umask())
        yield tmp
        (tmp / MARKER).write_text(signature + "\n", encoding="utf-8")
        _fsync_tree(tmp)
        check_output(dest, overwrite=overwrite, signature=signature)  # may have appeared meanwhile
        if dest.exists():
            if _exchange(tmp, dest):  # tmp now holds the old folder
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                old = Path(tempfile.mkdtemp(prefix=_temp_name(dest, "partial"), dir=dest.parent))
                old.rmdir()
                os.rename(dest, old)
                os.rename(tmp, dest)
                shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(tmp, dest)
        _fsync_dir(dest.parent)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
