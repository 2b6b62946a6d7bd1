"""A private on-disk cache of compiled libraries, each entry verified before it is loaded.

Loading a shared library runs its constructors in the calling process, so a
library is loaded only if this user built it here and it is intact. The cache is
the folder ``c`` under :func:`cache_dir`; each entry is four files named by its
key (the caller's hash of everything the library depends on)::

    dalembert_<key>.so       the library
    dalembert_<key>.sha256   its digest record: the key, the library's size and SHA-256
    dalembert_<key>.c        its source, kept for inspection
    dalembert_<key>.lock     locked while the entry is built

- Folders are made 0700. A cache folder that belongs to another user or is
  writable by group or others is refused (:class:`~dalembert.errors.UnsafeCacheError`):
  whoever can write there could plant a library that would run as you.
- Before a library is loaded, it must be a regular file of this user, not writable
  by others, with the size and SHA-256 of its digest record, written for this key.
  Anything else (empty, truncated, garbage, another entry's library, a symbolic
  link) is never opened as a library: it is rebuilt, with a
  :class:`~dalembert.errors.BadCacheEntryWarning` saying what was found.
- A library just built is first loaded by a fresh interpreter in a child process,
  which calls its probe function (:data:`PROBE_SOURCE`): a library that would crash
  the loader fails the build there, not in the caller. Only then is its digest
  recorded.
- A build holds the entry's lock, works in a private temporary folder, syncs the
  files, then renames them into place and syncs the folder: readers see the old
  entry or the new one, never a part of one, and two processes never build one
  entry twice. Temporary folders left by killed builds are removed by later builds.

The digest detects damage and mix-ups (a truncated write, a full disk, a file
copied over another), not someone who can write to the folder: the ownership and
mode checks keep them out.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import hashlib
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from ..errors import BadCacheEntryWarning, CompileError, UnsafeCacheError

#: The cache's sub-folder of compiled C libraries.
FOLDER = "c"
#: What a build writes into its temporary folder: the library and (optionally) its source.
LIBRARY, SOURCE = "lib.so", "lib.c"
#: Every cached library ends with this function; the test load calls it.
PROBE_SYMBOL, PROBE_VALUE = "dalembert_cache_probe", 271828
PROBE_SOURCE = f"\nint {PROBE_SYMBOL}(void) {{ return {PROBE_VALUE}; }}\n"
#: Temporary build folders of other entries older than this (seconds) are left by
#: killed builds (a build takes seconds) and removed.
STALE_AFTER = 3600.0
#: Seconds the test load of a new library may take.
TEST_LOAD_TIMEOUT = 60.0

_TEMPORARY = ".build"
_GROUP_OR_OTHERS_WRITE = stat.S_IWGRP | stat.S_IWOTH


def cache_dir() -> Path:
    """Where compiled libraries are kept (``$DALEMBERT_CACHE_DIR`` overrides).

    Else ``$XDG_CACHE_HOME/dalembert`` or ``~/.cache/dalembert``.

    >>> isinstance(cache_dir(), Path)
    True
    """
    env = os.environ.get("DALEMBERT_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "dalembert"


def load_library(key: str, build: Callable[[Path], None],
                 root: Path | None = None) -> ctypes.CDLL:
    """The library cached under ``key``, built first if it is missing or bad.

    Parameters
    ----------
    key
        A hash of everything the library depends on (letters and digits).
    build
        ``build(folder)`` writes the library to ``folder / LIBRARY`` and, for
        inspection, its source to ``folder / SOURCE``; ``folder`` is a new private
        folder inside the cache. The library must contain :data:`PROBE_SOURCE`.
        It raises :class:`~dalembert.errors.CompileError` when it cannot build.
    root
        The cache (default :func:`cache_dir`).

    Raises
    ------
    UnsafeCacheError
        A cache folder belongs to another user or is writable by group or others.
    CompileError
        The library cannot be built, stored or loaded; the message says why.

    Examples
    --------
    >>> import tempfile
    >>> from dalembert.codegen.c_backend import find_compiler
    >>> def build(folder):
    ...     (folder / SOURCE).write_text("int seven(void) { return 7; }" + PROBE_SOURCE)
    ...     subprocess.run([find_compiler(), "-shared", "-fPIC", str(folder / SOURCE),
    ...                     "-o", str(folder / LIBRARY)], check=True)
    >>> with tempfile.TemporaryDirectory() as root:
    ...     built = load_library("example", build, Path(root)).seven()
    ...     again = load_library("example", None, Path(root)).seven()  # verified, not rebuilt
    >>> built, again
    (7, 7)
    """
    folder = private_folder(root)
    entry = _Entry(folder, key)
    problem = entry.problem()
    if problem is not None:
        try:
            with entry.locked():
                problem = entry.problem()  # another process may have built it meanwhile
                if problem is not None:
                    _remove_stale_temporaries(folder, key)
                    entry.build(build)
        except CompileError as exc:
            if problem is _MISSING:
                raise
            raise CompileError(f"the cached library {entry.library} {problem} and cannot be "
                               f"rebuilt: {exc}") from exc
        if problem is not None and problem is not _MISSING:
            warnings.warn(f"the cached library {entry.library} {problem}; it was not loaded "
                          "but rebuilt", BadCacheEntryWarning, stacklevel=3)
    return _load_verified(entry)


def private_folder(root: Path | None = None) -> Path:
    """The cache's folder of libraries, ``root / FOLDER``, made (0700) or checked.

    Parameters
    ----------
    root
        The cache (default :func:`cache_dir`).

    Raises
    ------
    UnsafeCacheError
        ``root`` or the folder belongs to another user or is writable by group or
        others, or a folder above ``root`` belongs to another user (not root) or is
        writable by group or others without the sticky bit (as ``/tmp`` has it): its
        owner or writers could swap the cache for a folder of theirs.
    CompileError
        It cannot be made, or is not a folder.

    Examples
    --------
    >>> import stat, tempfile
    >>> with tempfile.TemporaryDirectory() as root:
    ...     mode = stat.S_IMODE(private_folder(Path(root) / "new").stat().st_mode)
    >>> oct(mode)
    '0o700'
    """
    root = cache_dir() if root is None else root
    folder = root / FOLDER
    for path in (root, folder):
        _make_private(path)
        _check_private(path)
    _check_parents(root)
    return folder


def _make_private(path: Path) -> None:
    """Make ``path`` and its missing parents, each 0700 whatever the umask."""
    missing = []
    while not os.path.lexists(path) and path != path.parent:
        missing.append(path)
        path = path.parent
    for folder in reversed(missing):
        try:
            os.mkdir(folder, 0o700)
            os.chmod(folder, 0o700)  # mkdir's mode is masked by the umask
        except FileExistsError:  # made by a concurrent process
            pass
        except OSError as exc:
            raise _unwritable(folder, exc) from exc


def _check_private(path: Path) -> None:
    try:
        info = os.stat(path)
    except OSError as exc:
        raise _unwritable(path, exc) from exc
    if not stat.S_ISDIR(info.st_mode):
        raise CompileError(f"the code cache {path} is not a folder; set DALEMBERT_CACHE_DIR to "
                           "a folder of your own")
    risk = "a library planted there would run as you"
    if info.st_uid != os.geteuid():
        raise UnsafeCacheError(
            f"the code cache {path} belongs to uid {info.st_uid}, not to you (uid "
            f"{os.geteuid()}): {risk}. Set DALEMBERT_CACHE_DIR to a folder of your own")
    if info.st_mode & _GROUP_OR_OTHERS_WRITE:
        raise UnsafeCacheError(
            f"the code cache {path} is writable by group or others (mode "
            f"{stat.S_IMODE(info.st_mode):04o}): {risk}. Make it private (chmod 700 {path}) "
            "or set DALEMBERT_CACHE_DIR to a folder of your own")


def _check_parents(root: Path) -> None:
    """Refuse a cache below a folder someone else could change: one owned by another
    user than root and this one, or writable by group or others without the sticky bit.

    Such a folder's owner or writers can rename the cache away and put a folder of
    theirs in its place (between the check of a library and its loading, or before
    it), as ssh's ``StrictModes`` and git's ``safe.directory`` guard against. Both the
    path as written and the one its links lead to are checked.
    """
    me = os.geteuid()
    written = Path(os.path.abspath(root))
    seen: set[Path] = set()
    for parent in [*written.parents, *Path(os.path.realpath(written)).parents]:
        if parent in seen:
            continue
        seen.add(parent)
        try:
            info = os.stat(parent)
        except OSError as exc:
            raise _unwritable(parent, exc) from exc
        risk = (f"whoever can change {parent} can put a folder of theirs in place of the "
                f"code cache {root}, and a library planted there would run as you")
        if info.st_uid not in (0, me):
            raise UnsafeCacheError(
                f"the folder {parent} above the code cache belongs to uid {info.st_uid}, "
                f"neither you (uid {me}) nor root: {risk}. Set DALEMBERT_CACHE_DIR to a "
                "folder of your own")
        if info.st_mode & _GROUP_OR_OTHERS_WRITE and not info.st_mode & stat.S_ISVTX:
            raise UnsafeCacheError(
                f"the folder {parent} above the code cache is writable by group or others "
                f"(mode {stat.S_IMODE(info.st_mode):04o}) without the sticky bit: {risk}. "
                f"Remove that permission (chmod go-w {parent}), or set DALEMBERT_CACHE_DIR "
                "to a folder of your own")


def _unwritable(path: Path, exc: OSError) -> CompileError:
    """The error for a cache that cannot be written, with the remedy for its cause."""
    if exc.errno == errno.ENOSPC:
        remedy = "free space there, or set DALEMBERT_CACHE_DIR to a folder on another disk"
    elif exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        remedy = "set DALEMBERT_CACHE_DIR to a writable folder"
    else:
        remedy = "set DALEMBERT_CACHE_DIR to another folder"
    return CompileError(f"cannot write to the code cache {path}: {exc.strerror or exc}; {remedy}")


class _Untrusted(Exception):
    """A file of an entry that must not be read as part of it (the message says why).

    Internal control flow, never seen by a user: the entry's check
    (:meth:`_Entry.problem`) turns it into what is wrong with the entry, which is then
    not loaded but rebuilt."""


#: What :meth:`_Entry.problem` says of an entry that is not there (not warned about).
_MISSING = "is missing"


class _Entry:
    """The files of one cache entry."""

    def __init__(self, folder: Path, key: str) -> None:
        self.folder, self.key = folder, key
        self.library, self.record, self.source, self.lock = (
            folder / f"dalembert_{key}{suffix}" for suffix in (".so", ".sha256", ".c", ".lock"))
        #: An open descriptor of the library the last :meth:`problem` found sound.
        self.verified: int | None = None

    def problem(self) -> str | None:
        """``None`` when the library may be loaded, else what is wrong with it.

        The library's file is opened once: when it is sound, its descriptor is kept in
        :attr:`verified`, and that file, not the path, is what gets loaded."""
        self._forget()
        try:
            fd = _open_own_file(self.library)
        except FileNotFoundError:
            return _MISSING
        except _Untrusted as why:
            return str(why)
        try:
            with os.fdopen(os.dup(fd), "rb") as fh:
                data = fh.read()
            problem = self._problem_with(data)
        except BaseException:
            os.close(fd)
            raise
        if problem is None:
            self.verified = fd
        else:
            os.close(fd)
        return problem

    def _forget(self) -> None:
        if self.verified is not None:
            os.close(self.verified)
            self.verified = None

    def _problem_with(self, data: bytes) -> str | None:
        if not data:
            return "is empty"
        try:
            record = json.loads(_read_own_file(self.record))
        except FileNotFoundError:
            return "has no digest record (it was not built and checked by this version)"
        except _Untrusted as why:
            return f"has a digest record that {why}"
        except ValueError:
            return "has an unreadable digest record"
        if not isinstance(record, dict) or record.get("key") != self.key:
            return "has the digest record of another library"
        size = record.get("size")
        if isinstance(size, int) and len(data) < size:
            return f"is truncated ({len(data)} of {size} bytes)"
        if len(data) != size or hashlib.sha256(data).hexdigest() != record.get("sha256"):
            return ("is not the library built here (its SHA-256 differs from the one recorded "
                    "when it was built)")
        return None

    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the entry's lock, waiting for a build in another process to end.

        Where no lock can be had (a read-only cache, which nobody can build in, or
        a file system without locks), the build goes ahead unlocked: a failure
        then names its cause, and a concurrent build only duplicates work, since
        each stores its files by renaming.
        """
        fd = None
        with suppress(OSError):
            fd = os.open(self.lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
            fcntl.flock(fd, fcntl.LOCK_EX)
        try:
            yield
        finally:
            if fd is not None:
                os.close(fd)  # releases the lock

    def build(self, build: Callable[[Path], None]) -> None:
        """Build, test-load, record and store the entry (with its lock held)."""
        try:
            work = Path(tempfile.mkdtemp(prefix=f"dalembert_{self.key}.", suffix=_TEMPORARY,
                                         dir=self.folder))
        except OSError as exc:
            raise _unwritable(self.folder, exc) from exc
        try:
            build(work)
            library, source = work / LIBRARY, work / SOURCE
            if not library.is_file():
                raise CompileError(f"the build wrote no library {LIBRARY}")
            data = _private_and_synced(library)
            _test_load(library)
            record = work / "record"
            _write_synced(record, json.dumps({"key": self.key, "size": len(data),
                                              "sha256": hashlib.sha256(data).hexdigest()}))
            if source.exists():
                os.chmod(source, 0o600)
                os.replace(source, self.source)
            os.replace(record, self.record)
            os.replace(library, self.library)
            _sync_folder(self.folder)
        except OSError as exc:
            raise _unwritable(self.folder, exc) from exc
        finally:
            shutil.rmtree(work, ignore_errors=True)


def _open_own_file(path: Path) -> int:
    """A descriptor of ``path`` if it is a regular file of this user that others cannot
    write (the caller closes it).

    Raises ``FileNotFoundError`` when it is not there and :class:`_Untrusted` saying
    why it is not read.
    """
    try:  # not following a link; not blocking on a FIFO
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise _Untrusted("is a symbolic link") from exc
        if exc.errno == errno.ENOENT:
            raise
        raise _Untrusted(f"cannot be read ({exc.strerror})") from exc
    info = os.fstat(fd)
    why = None
    if not stat.S_ISREG(info.st_mode):
        why = "is not a regular file"
    elif info.st_uid != os.geteuid():
        why = f"belongs to uid {info.st_uid}, not to you (uid {os.geteuid()})"
    elif info.st_mode & _GROUP_OR_OTHERS_WRITE:
        why = f"is writable by group or others (mode {stat.S_IMODE(info.st_mode):04o})"
    if why is not None:
        os.close(fd)
        raise _Untrusted(why)
    return fd


def _read_own_file(path: Path) -> bytes:
    """The bytes of ``path`` if it is a regular file of this user that others cannot write
    (see :func:`_open_own_file`)."""
    with os.fdopen(_open_own_file(path), "rb") as fh:
        return fh.read()


#: Where the open descriptors of a process are files of their own (Linux).
_FD_FOLDER = Path("/proc/self/fd")
#: The libraries loaded through their descriptor, by file identity, with the
#: descriptor: kept open while the process lives (a library is never unloaded), so
#: that its name ``/proc/self/fd/N`` is never given to another file (the dynamic
#: loader returns a library already loaded under the same name).
_LOADED: dict[tuple[int, int], tuple[int, ctypes.CDLL]] = {}
_LOADING = threading.Lock()


def cached_library(library: ctypes.CDLL) -> tuple[str, bytes] | None:
    """The key and the bytes of a library :func:`load_library` loaded (the file it
    checked and loaded), or ``None`` for another library.

    Parameters
    ----------
    library
        A loaded library.

    Examples
    --------
    >>> import ctypes
    >>> cached_library(ctypes.CDLL(None)) is None
    True
    """
    key = getattr(library, "_dalembert_key", None)
    if not isinstance(key, str):
        return None
    return key, Path(library._name).read_bytes()


def _load_verified(entry: _Entry) -> ctypes.CDLL:
    """Load the file ``entry``'s check verified, not whatever its path names now.

    Where the process's descriptors are files (``/proc/self/fd``) the loader opens the
    verified file itself, so a swap of the path after the check loads nothing of it;
    elsewhere the path is loaded, the folders above it checked
    (:func:`_check_parents`) so that no other user can swap it.
    """
    if entry.verified is None:  # built just now: checked as any entry before it is loaded
        problem = entry.problem()
        if problem is not None:
            raise CompileError(f"the library just built at {entry.library} {problem}")
    fd, entry.verified = entry.verified, None
    assert fd is not None
    try:
        if not _FD_FOLDER.is_dir():
            os.close(fd)
            library = ctypes.CDLL(str(entry.library))
        else:
            info = os.fstat(fd)
            identity = (info.st_dev, info.st_ino)
            with _LOADING:
                if identity in _LOADED:
                    os.close(fd)
                    return _LOADED[identity][1]
                library = ctypes.CDLL(str(_FD_FOLDER / str(fd)))
                _LOADED[identity] = (fd, library)
        library._dalembert_key = entry.key  # type: ignore[attr-defined]
        return library
    except OSError as exc:
        with suppress(OSError):
            os.close(fd)
        raise CompileError(f"cannot load the cached library {entry.library}: {exc}") from exc


def _private_and_synced(path: Path) -> bytes:
    """Make the file ``path`` 0600 (a compiler makes it 0777 less the umask), sync it to
    disk and return its bytes."""
    os.chmod(path, 0o600)
    with open(path, "rb") as fh:
        data = fh.read()
        os.fsync(fh.fileno())
    return data


def _write_synced(path: Path, text: str) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def _sync_folder(folder: Path) -> None:
    """Put the renames in ``folder`` on disk (best effort: not every file system can)."""
    with suppress(OSError):
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


_PROBE_SCRIPT = "\n".join([
    "import ctypes, sys",
    "probe = getattr(ctypes.CDLL(sys.argv[1]), sys.argv[2])",
    "probe.restype = ctypes.c_int",
    "sys.exit(0 if probe() == int(sys.argv[3]) else 3)",
])


def _test_load(library: Path) -> None:
    """Load ``library`` in a fresh interpreter and call its probe function.

    A library that crashes or hangs the loader (a bad constructor, code for
    another processor) then fails the build in the child, not in the caller.
    """
    command = [sys.executable, "-I", "-S", "-c", _PROBE_SCRIPT, str(library), PROBE_SYMBOL,
               str(PROBE_VALUE)]
    try:
        run = subprocess.run(command, capture_output=True, text=True, timeout=TEST_LOAD_TIMEOUT)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise CompileError(f"the test load of a library just built failed: {exc}") from exc
    if run.returncode == 0:
        return
    if run.returncode < 0:
        try:
            name = signal.Signals(-run.returncode).name
        except ValueError:
            name = f"signal {-run.returncode}"
        what = f"crashed the process loading it ({name})"
    elif run.returncode == 3:
        what = "returned a wrong value from its probe function"
    else:
        lines = run.stderr.strip().splitlines() or ["no message"]
        what = f"could not be loaded: {lines[-1]}"
    raise CompileError(f"a library just built {what}; it is not stored in the cache")


def _remove_stale_temporaries(folder: Path, key: str) -> None:
    """Remove build folders left by killed builds (only this user's).

    Those of ``key`` are stale whatever their age: its lock is held, so no live
    build owns them. Those of other entries (and the ``tmp*`` folders of earlier
    versions) are removed once older than :data:`STALE_AFTER`.
    """
    now, own = time.time(), f"dalembert_{key}."
    for name in os.listdir(folder):
        ours = name.endswith(_TEMPORARY) and name.startswith("dalembert_")
        if not (ours or name.startswith("tmp")):
            continue
        path = folder / name
        try:
            info = path.lstat()
        except FileNotFoundError:
            continue
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.geteuid():
            continue
        if (ours and name.startswith(own)) or now - info.st_mtime > STALE_AFTER:
            shutil.rmtree(path, ignore_errors=True)
