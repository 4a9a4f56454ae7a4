"""Atomic file writes and content hashing.

A crash or Ctrl-C in the middle of a write must never leave a half-written
file where a finished one is expected (caches, EXRs, reports), and several
processes may write the same cache key at once: each writes to its own
temporary file in the target folder and renames it into place, which POSIX
makes atomic on one file system.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from pathlib import Path
from typing import Iterator


#: In the names of files being written (``.<name>.part-XXXX<suffix>``): a process killed while
#: writing (SIGKILL, power loss) leaves one; :func:`remove_stale_parts` removes them.
PART_MARK = ".part-"


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    The temporary file keeps ``path``'s suffix (or ``suffix``) because some
    writers (OpenEXR, PNG) choose the format from it. On any exception the
    temporary file is removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}{PART_MARK}", suffix=suffix or path.suffix, dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes the file private (0600); a finished output gets the permissions any new file
        # gets here (0666 less the umask), so that reports and images can be shared.
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def check_outputs(outputs: dict[str, str | os.PathLike], inputs=(), suffixes: dict[str, str] | None = None) -> None:
    """Refuse outputs, before any work, that would destroy something or cannot be written.

    ``outputs`` maps each output's option name (for the message, e.g. ``"-o"``) to its path,
    ``inputs`` are the files the command reads, and ``suffixes`` the required file kind per
    option (e.g. ``{"-o": ".exr"}``, compared case-insensitively). Raises
    :class:`~compare.util.errors.OutputError` naming the option and the path when an output is
    an input, two outputs are the same file, a suffix is wrong, or the output's folder
    cannot be written (its nearest existing ancestor is checked, as parents are created).
    """
    from compare.util.errors import OutputError

    def same(a: Path, b: Path) -> bool:
        a, b = Path(a), Path(b)
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()

    seen: dict[Path, str] = {}
    for option, raw in outputs.items():
        path = Path(raw)
        want = (suffixes or {}).get(option)
        if want and path.suffix.lower() != want:
            raise OutputError(f"{option} {path}: the output must be a {want} file (ending in {want})")
        if path.is_dir():
            raise OutputError(f"{option} {path}: is a folder, not a file")
        for src in inputs:
            if same(path, src):
                raise OutputError(f"{option} {path}: is an input of this command ({src}); choose another path")
        for other, opt in seen.items():
            if same(path, other):
                raise OutputError(f"{option} {path}: is also the output of {opt}; choose two paths")
        seen[path] = option
        _check_writable_below(option, path, path.parent if str(path.parent) else Path("."))


def check_output_folder(option: str, path: str | os.PathLike) -> None:
    """Refuse an output folder, before any work, that is a file or cannot be created or written
    (:class:`~compare.util.errors.OutputError` naming the option and the path)."""
    from compare.util.errors import OutputError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"{option} {path}: is a file, not a folder")
    _check_writable_below(option, path, path)


def _check_writable_below(option: str, path: Path, folder: Path) -> None:
    """``folder`` (or its nearest existing ancestor, as parents are created) is a writable folder."""
    from compare.util.errors import OutputError

    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"{option} {path}: cannot be created, {folder} is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {path}: cannot write in {folder} (permission denied)")
    # access() says yes to root everywhere and knows nothing of read-only or special file systems
    # (/proc, a full disk): a file made and removed there says for sure.
    try:
        fd, probe = tempfile.mkstemp(prefix=".compare-probe-", dir=folder)
    except OSError as exc:
        raise OutputError(f"{option} {path}: cannot write in {folder} ({exc.strerror or exc})") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)


def _umask() -> int:
    """The process's umask (read by setting it, the only way POSIX offers, and restoring it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    write_bytes_atomic(path, text.encode("utf-8"))


def sha256_bytes(*parts: bytes | str) -> str:
    """Hex SHA-256 of the parts, each length-prefixed so that boundaries matter."""
    h = hashlib.sha256()
    for p in parts:
        b = p.encode("utf-8") if isinstance(p, str) else p
        h.update(len(b).to_bytes(8, "little"))
        h.update(b)
    return h.hexdigest()


def remove_stale_parts(folder: str | os.PathLike, *, older_than: float = 0.0) -> list[Path]:
    """Remove half-written files (:data:`PART_MARK`) below ``folder`` older than ``older_than``
    seconds; returns what was removed. Call it where no other process writes (a locked output
    folder), or with an age no write lasts (a shared cache)."""
    import time

    folder, now, gone = Path(folder), time.time(), []
    if not folder.is_dir():
        return gone
    for p in folder.rglob(f".*{PART_MARK}*"):
        try:
            if p.is_file() and not p.is_symlink() and now - p.stat().st_mtime >= older_than:
                p.unlink()
                gone.append(p)
        except OSError:
            pass  # gone meanwhile, or not ours to remove
    return gone


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike, what: str) -> Iterator[None]:
    """Hold ``folder`` for this process while the block runs (an advisory ``flock`` on
    ``folder/.compare.lock``): a second command into the same folder is refused with
    :class:`~compare.util.errors.OutputError` instead of mixing its files with this one's.
    The lock ends with the process, however it ends (no stale lock after a kill)."""
    import fcntl

    from compare.util.errors import OutputError

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / ".compare.lock"
    f = open(path, "a+", encoding="utf-8")
    try:
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.seek(0)
            holder = f.read().strip() or "another process"
            raise OutputError(f"{folder}: in use by {holder}; wait for it to finish or choose another "
                              "output folder") from None
        f.seek(0)
        f.truncate()
        f.write(f"{what} (pid {os.getpid()})\n")
        f.flush()
        yield
    finally:
        f.close()  # closing releases the lock


#: The most of a log an error message quotes: its last lines, and at most this many bytes of them.
TAIL_BYTES = 4096


def log_tail(path: str | os.PathLike, lines: int = 12, *, drop: str | None = None) -> str:
    """The last ``lines`` lines of the log file ``path`` (without those containing ``drop``), at most
    :data:`TAIL_BYTES` bytes of them: a program that writes one endless line (a ``\\r`` progress bar)
    makes no endless message. Only the file's end is read; "" when it cannot be read."""
    try:
        with open(path, "rb") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            f.seek(max(size - 16 * TAIL_BYTES, 0))
            data = f.read()
    except OSError:
        return ""
    text = data.decode("utf-8", errors="replace").replace("\r", "\n")
    kept = [t for t in text.rstrip().splitlines() if t.strip() and (drop is None or drop not in t)][-lines:]
    out = "\n".join(kept)
    if len(out.encode("utf-8")) > TAIL_BYTES:
        out = "…" + out.encode("utf-8")[-TAIL_BYTES:].decode("utf-8", errors="ignore")
    return out


def sweep_folder_parts(path: str | os.PathLike) -> list[Path]:
    """What a killed :func:`atomic_folder` of ``path`` left beside it: its half-written ``.<name>.part-*``
    folders are removed; a ``.<name>.old.part-*`` folder holds the previous ``path`` (moved aside just
    before the new one was to take its place), which is put back where ``path`` is missing, else removed.
    Call it holding :func:`sibling_lock` of ``path``. Returns what was removed or restored."""
    import shutil

    path = Path(path)
    done: list[Path] = []
    if not path.parent.is_dir():
        return done
    for p in sorted(path.parent.glob(f".{path.name}.old{PART_MARK}*")):
        if (p / "x").is_dir() and not path.exists():
            os.replace(p / "x", path)  # the swap was cut between its two renames: the old folder comes back
        shutil.rmtree(p, ignore_errors=True)
        done.append(p)
    for p in sorted(path.parent.glob(f".{path.name}{PART_MARK}*")):
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
            done.append(p)
    return done


@contextlib.contextmanager
def sibling_lock(path: str | os.PathLike, what: str) -> Iterator[None]:
    """Hold the folder ``path`` (which may not exist yet) for this process: an advisory ``flock`` on its
    parent folder itself (no lock file is left anywhere), so that two commands never write or sweep folders
    there at once (one error instead). The lock ends with the process, however it ends."""
    import fcntl

    from compare.util.errors import OutputError

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise OutputError(f"{path}: another compare command is writing a folder in {path.parent}; wait for it "
                              f"to finish ({what})") from None
        yield
    finally:
        os.close(fd)  # closing releases the lock


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike, *, replace: bool = False) -> Iterator[Path]:
    """Yield a temporary folder beside ``path``; on success it becomes ``path``.

    With ``replace`` an existing ``path`` is swapped out (renamed aside, then removed once the new folder
    is in place); without, an existing ``path`` is an :class:`~compare.util.errors.OutputError`. On any
    exception the temporary folder is removed and ``path`` is left as it was: a reader never sees a
    half-written folder. The parts a killed swap left are swept first (:func:`sweep_folder_parts`), under
    :func:`sibling_lock`.
    """
    with sibling_lock(path, "writing it"):
        sweep_folder_parts(path)
        yield from _atomic_folder(path, replace=replace)


def _atomic_folder(path, *, replace: bool) -> Iterator[Path]:
    import shutil

    from compare.util.errors import OutputError

    path = Path(path)
    if path.exists() and not replace:
        raise OutputError(f"{path}: exists; choose a new folder (or update the one there)")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}{PART_MARK}", dir=path.parent))
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_umask())
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old{PART_MARK}", dir=path.parent))
            os.replace(path, old / "x")
        try:
            os.replace(tmp, path)
        except BaseException:
            if old is not None:  # put the old folder back
                os.replace(old / "x", path)
                shutil.rmtree(old, ignore_errors=True)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
