"""Fault injection into the code cache: each case rebuilds correctly or refuses clearly.

Every loading of a library that might have been tampered with runs in a child
process (forked from a server that has imported dalembert, so a child costs
milliseconds): a crash there is reported as the child's exit signal instead of
ending the test run. The references are independent of the cache's code: the
value a library's function returns (7, as written in its C source), SHA-256
computed here with ``hashlib``, file modes and owners read with ``os.stat``, and a
marker file that a planted library's constructor would write if it ever ran.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import multiprocessing
import multiprocessing.forkserver
import os
import shutil
import signal
import stat
import subprocess
import time
import warnings
from pathlib import Path

import pytest
import sympy as sp

from dalembert.codegen import c_backend, cache
from dalembert.errors import (
    BadCacheEntryWarning,
    CompileError,
    NativeUnavailableWarning,
    UnsafeCacheError,
)

pytestmark = pytest.mark.skipif(c_backend.find_compiler() is None, reason="no C compiler found")
SEVEN = "int seven(void) { return 7; }"
EIGHT = "int eight(void) { return 8; }"
x = sp.Symbol("x")
SPEC = ("triple", [("q", [x])], [3 * x])
NOBODY = 65534  # another user's uid, for files and folders not owned by the caller
IS_ROOT = os.geteuid() == 0


# -- running cases in a child process ---------------------------------------------------
@pytest.fixture(scope="module")
def forks():
    """A forkserver that has imported this module (so dalembert) once: a child forked
    from it starts in milliseconds."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([__name__])
    # The server imports its preload before it is told the parent's sys.path.
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("PYTHONPATH", os.pathsep.join(
            [str(Path(__file__).parent), os.environ.get("PYTHONPATH", "")]))
        multiprocessing.forkserver.ensure_running()
    return context


def _child(connection, function, args):
    try:
        connection.send(("returned", function(*args)))
    except BaseException as exc:  # reported to the parent, which asserts on it
        connection.send(("raised", f"{type(exc).__name__}: {exc}"))


class Child:
    """``function(*args)`` running in a forked child process."""

    def __init__(self, forks, function, *args) -> None:
        self.pipe, sending = forks.Pipe(duplex=False)
        self.process = forks.Process(target=_child, args=(sending, function, args))
        self.process.start()
        sending.close()

    def result(self, timeout: float = 300.0):  # a guard against a hang, not a timing
        """The child's ``("returned", value)`` or ``("raised", text)``; a crash fails."""
        ready = self.pipe.poll(timeout)
        outcome = self.pipe.recv() if ready else None
        self.process.join(timeout)
        if self.process.exitcode is None:
            self.process.kill()
            pytest.fail(f"the child process did not end within {timeout} s")
        code = self.process.exitcode
        assert code == 0 and outcome is not None, (
            f"the child process died: exit code {code}"
            + (f" (signal {signal.Signals(-code).name})" if code < 0 else ""))
        return outcome


def isolated(forks, function, *args):
    """Run ``function(*args)`` in a child; its return value (its exception fails the test)."""
    kind, value = Child(forks, function, *args).result()
    assert kind == "returned", value
    return value


def load_seven(root: str, kind: str = "source", cc: str | None = None) -> dict:
    """In a child: load SEVEN (or the flat SPEC) from the cache at ``root``."""
    os.environ["DALEMBERT_CACHE_DIR"] = root
    if cc is not None:
        os.environ["CC"] = cc
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if kind == "source":
            value, native = c_backend.source_library(SEVEN).seven(), True
        else:
            (fn,) = c_backend.build_flat_functions([SPEC], use="c")
            value, native = float(fn([7.0 / 3.0])[0]), hasattr(fn, "library")
    return {"value": value, "native": native,
            "warnings": [(w.category.__name__, str(w.message)) for w in caught]}


# -- helpers in the parent ---------------------------------------------------------------
def entry(root: Path, source: str = SEVEN, cc: str | None = None) -> dict[str, Path]:
    """The files of ``source_library(source)``'s cache entry."""
    compiler = c_backend.find_compiler() if cc is None else cc
    key = c_backend._source_key(source, compiler, c_backend.SOURCE_CFLAGS)
    folder = root / cache.FOLDER
    return {suffix: folder / f"dalembert_{key}.{suffix}" for suffix in ("so", "sha256", "c")}


def assert_valid(files: dict[str, Path]) -> None:
    """The library is this user's, private, and matches its record (checked here)."""
    data = files["so"].read_bytes()
    record = json.loads(files["sha256"].read_text())
    assert record["sha256"] == hashlib.sha256(data).hexdigest() and record["size"] == len(data)
    for path in files.values():
        info = path.lstat()
        assert stat.S_ISREG(info.st_mode) and info.st_uid == os.geteuid()
        assert stat.S_IMODE(info.st_mode) == 0o600, path


def replace_bytes(path: Path, data: bytes) -> None:
    """Put ``data`` at ``path`` as a new file (a library mapped somewhere is not touched)."""
    new = path.with_name(path.name + ".new")
    new.write_bytes(data)
    new.chmod(0o600)
    new.replace(path)


def temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".build")
                  or p.name.startswith("tmp"))


def compile_c(source: str, out: Path) -> None:
    src = out.with_suffix(".c")
    src.write_text(source)
    subprocess.run([c_backend.find_compiler(), "-shared", "-fPIC", str(src), "-o", str(out)],
                   check=True)


@pytest.fixture()
def root(tmp_path, monkeypatch) -> Path:
    """A cache of this test's own (the caller's folder is private, as pytest makes it)."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(folder))
    monkeypatch.setattr(c_backend, "_WARNED", set())
    return folder


def planted_source(marker: Path, value: int = 666) -> str:
    """A library whose constructor writes ``marker`` (and that passes for SEVEN's)."""
    return "\n".join([
        "#include <stdio.h>",
        "__attribute__((constructor)) static void planted(void) {",
        f'  FILE *f = fopen("{marker}", "w"); if (f) {{ fputs("ran", f); fclose(f); }}',
        "}",
        f"int seven(void) {{ return {value}; }}",
        cache.PROBE_SOURCE,
    ])


# -- a new cache ---------------------------------------------------------------------------
def build_under_umask(root: str) -> dict:
    os.umask(0)  # the worst case: everything made would be 0777 / 0666
    return load_seven(root)


def test_a_new_cache_is_private_whatever_the_umask(forks, tmp_path):
    root = tmp_path / "deep" / "cache"  # its parent is made too
    result = isolated(forks, build_under_umask, str(root))
    assert result["value"] == 7 and result["warnings"] == []
    for folder in (tmp_path / "deep", root, root / cache.FOLDER):
        assert stat.S_IMODE(folder.stat().st_mode) == 0o700, folder
    files = entry(root)
    assert_valid(files)
    lock = files["so"].with_suffix(".lock")
    assert stat.S_IMODE(lock.stat().st_mode) == 0o600
    assert temporaries(root / cache.FOLDER) == []


def test_a_verified_entry_is_loaded_without_building(forks, root, monkeypatch):
    isolated(forks, load_seven, str(root))

    def forbidden(*args, **kwargs):
        raise AssertionError("built or test-loaded again on a verified hit")

    monkeypatch.setattr(cache._Entry, "build", forbidden)
    monkeypatch.setattr(cache, "_test_load", forbidden)
    assert c_backend.source_library(SEVEN).seven() == 7


# -- the window between the check and the load ---------------------------------------------
def load_after_a_swap(root: str, planted: str) -> dict:
    """In a child: load SEVEN while the library's path is swapped for ``planted`` right
    after its check passed (what another user who can write a folder above the cache
    could do)."""
    checked = cache._Entry.problem

    def problem_then_swap(self):
        found = checked(self)
        if found is None:
            os.replace(planted, self.library)
        return found

    cache._Entry.problem = problem_then_swap  # type: ignore[method-assign]
    return load_seven(root)


def test_a_library_swapped_after_its_check_is_not_loaded(forks, root, tmp_path):
    """The file loaded is the one whose owner, mode and SHA-256 were checked: a planted
    library moved onto the path between the check and the load never runs."""
    isolated(forks, load_seven, str(root))  # a sound entry
    marker = tmp_path / "marker"
    planted = tmp_path / "planted.so"
    compile_c(planted_source(marker), planted)
    planted.chmod(0o600)
    planted_bytes = planted.read_bytes()
    result = isolated(forks, load_after_a_swap, str(root), str(planted))
    assert entry(root)["so"].read_bytes() == planted_bytes  # the swap happened
    assert result["value"] == 7 and result["native"]
    assert not marker.exists()


def shared_parent(tmp_path: Path, how: str) -> tuple[Path, str]:
    """A cache below a folder made shared ``how``; the start of the expected message."""
    shared = tmp_path / "project"
    shared.mkdir()
    if how == "another user's":
        os.chown(shared, NOBODY, NOBODY)
        return shared, f"the folder {shared} above the code cache belongs to uid {NOBODY}"
    shared.chmod(0o775 if how == "group-writable" else 0o777)
    mode = "0775" if how == "group-writable" else "0777"
    return shared, (f"the folder {shared} above the code cache is writable by group or "
                    f"others (mode {mode}) without the sticky bit")


@pytest.mark.parametrize("how", ["group-writable", "world-writable", "another user's"])
def test_a_cache_below_a_folder_others_can_change_is_refused(tmp_path, monkeypatch, how):
    if how == "another user's" and not IS_ROOT:
        pytest.skip("giving a folder to another user needs root")
    shared, expected = shared_parent(tmp_path, how)
    root = shared / "deep" / "cache"
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(root))
    with pytest.raises(UnsafeCacheError) as info:
        c_backend.source_library(SEVEN)
    message = str(info.value)
    assert expected in message and "run as you" in message
    assert "DALEMBERT_CACHE_DIR to a folder of your own" in message
    if how != "another user's":
        assert f"chmod go-w {shared}" in message
    assert not (root / cache.FOLDER).exists() or not any((root / cache.FOLDER).glob("*.so"))


def test_a_cache_below_a_sticky_shared_folder_is_used(forks, tmp_path):
    """Like /tmp: writable by all, but only an entry's owner may rename or remove it."""
    shared = tmp_path / "tmp"
    shared.mkdir()
    shared.chmod(0o1777)
    result = isolated(forks, load_seven, str(shared / "cache"))
    assert result["value"] == 7 and result["warnings"] == []


def test_a_cache_reached_through_a_link_checks_the_folders_the_link_passes(tmp_path,
                                                                          monkeypatch):
    """A link from a private folder into a shared one: the shared folder is named."""
    shared, expected = shared_parent(tmp_path, "world-writable")
    (shared / "real").mkdir(mode=0o700)
    private = tmp_path / "mine"
    private.mkdir(mode=0o700)
    (private / "link").symlink_to(shared / "real")
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(private / "link" / "cache"))
    with pytest.raises(UnsafeCacheError) as info:
        c_backend.source_library(SEVEN)
    assert expected in str(info.value)


# -- bad entries: rebuilt, never loaded ------------------------------------------------------
def truncated(files, root):
    replace_bytes(files["so"], files["so"].read_bytes()[:2000])
    return "is truncated (2000 of"


def empty(files, root):
    replace_bytes(files["so"], b"")
    return "is empty"


def garbage(files, root):
    size = files["so"].stat().st_size
    replace_bytes(files["so"], os.urandom(size))
    return "is not the library built here (its SHA-256 differs"


def foreign(files, root):
    """A valid library of another source copied over this one."""
    other = entry(root, EIGHT)
    replace_bytes(files["so"], other["so"].read_bytes())
    return "is not the library built here"


def foreign_with_its_record(files, root):
    other = entry(root, EIGHT)
    replace_bytes(files["so"], other["so"].read_bytes())
    replace_bytes(files["sha256"], other["sha256"].read_bytes())
    return "has the digest record of another library"


def without_record(files, root):
    files["sha256"].unlink()
    return "has no digest record"


def symbolic_link(files, root):
    target = root.parent / "elsewhere.so"
    shutil.copy(files["so"], target)
    files["so"].unlink()
    files["so"].symlink_to(target)
    return "is a symbolic link"


def writable_by_others(files, root):
    files["so"].chmod(0o666)
    return "is writable by group or others (mode 0666)"


def owned_by_another_user(files, root):
    os.chown(files["so"], NOBODY, NOBODY)
    return f"belongs to uid {NOBODY}, not to you"


def planted_with_a_forged_record(files, root):
    """Another user's library whose constructor would write a marker, with a record
    that matches it: refused for its owner, whatever the record says."""
    marker = root.parent / "marker"
    compile_c(planted_source(marker), root.parent / "planted.so")
    data = (root.parent / "planted.so").read_bytes()
    replace_bytes(files["so"], data)
    key = files["so"].stem.removeprefix("dalembert_")
    replace_bytes(files["sha256"], json.dumps(
        {"key": key, "size": len(data), "sha256": hashlib.sha256(data).hexdigest()}).encode())
    for path in (files["so"], files["sha256"]):
        os.chown(path, NOBODY, NOBODY)
    return f"belongs to uid {NOBODY}, not to you"


def planted_by_copy(files, root):
    """The same library put in place of ours, keeping our record."""
    compile_c(planted_source(root.parent / "marker"), root.parent / "planted.so")
    replace_bytes(files["so"], (root.parent / "planted.so").read_bytes())
    return "is not the library built here"


BAD_ENTRIES = [truncated, empty, garbage, foreign, foreign_with_its_record, without_record,
               symbolic_link, writable_by_others, owned_by_another_user,
               planted_with_a_forged_record, planted_by_copy]


@pytest.mark.parametrize("damage", BAD_ENTRIES, ids=lambda f: f.__name__)
def test_a_bad_entry_is_rebuilt_and_never_loaded(forks, root, damage):
    if damage in (owned_by_another_user, planted_with_a_forged_record) and not IS_ROOT:
        pytest.skip("giving a file to another user needs root")
    isolated(forks, load_seven, str(root))
    files = entry(root)
    if damage in (foreign, foreign_with_its_record):
        isolated(forks, _load_eight, str(root))
    found = damage(files, root)
    result = isolated(forks, load_seven, str(root))
    assert result["value"] == 7
    assert [category for category, _ in result["warnings"]] == ["BadCacheEntryWarning"]
    message = result["warnings"][0][1]
    assert f"the cached library {files['so']} {found}" in message, message
    assert message.endswith("; it was not loaded but rebuilt")
    assert not (root.parent / "marker").exists()  # the planted constructor never ran
    assert_valid(files)
    assert temporaries(root / cache.FOLDER) == []
    assert isolated(forks, load_seven, str(root))["warnings"] == []  # repaired for good


def _load_eight(root: str) -> int:
    os.environ["DALEMBERT_CACHE_DIR"] = root
    return c_backend.source_library(EIGHT).eight()


def test_an_empty_model_library_is_rebuilt_and_the_model_stays_in_c(forks, root):
    """The model route (build_flat_functions): C again, not NumPy with a wrong hint."""
    first = isolated(forks, load_seven, str(root), "model")
    assert first["native"] and first["value"] == 7.0
    (library,) = (root / cache.FOLDER).glob("*.so")
    replace_bytes(library, b"")
    again = isolated(forks, load_seven, str(root), "model")
    assert again["native"] and again["value"] == 7.0
    assert [c for c, _ in again["warnings"]] == ["BadCacheEntryWarning"]
    assert f"{library} is empty" in again["warnings"][0][1]


# -- folders that are not private: refused ---------------------------------------------------
def share(folder: Path, how: str) -> str:
    folder.mkdir(parents=True, exist_ok=True)
    if how == "group-writable":
        folder.chmod(0o770)
        return f"{folder} is writable by group or others (mode 0770)"
    if how == "world-writable":
        folder.chmod(0o1777)
        return f"{folder} is writable by group or others (mode 1777)"
    os.chown(folder, NOBODY, NOBODY)
    return f"{folder} belongs to uid {NOBODY}, not to you"


@pytest.mark.parametrize("which", ["root", "libraries"])
@pytest.mark.parametrize("how", ["group-writable", "world-writable", "another user's"])
def test_a_shared_folder_is_refused_and_nothing_is_loaded_from_it(root, which, how):
    if how == "another user's" and not IS_ROOT:
        pytest.skip("giving a folder to another user needs root")
    folder = root if which == "root" else root / cache.FOLDER
    root.mkdir(mode=0o700)
    expected = share(folder, how)
    marker = root.parent / "marker"
    # A planted library, with a matching record, where SEVEN's entry would be.
    files = entry(root)
    files["so"].parent.mkdir(exist_ok=True)
    compile_c(planted_source(marker, 7), files["so"])
    data = files["so"].read_bytes()
    key = files["so"].stem.removeprefix("dalembert_")
    files["sha256"].write_text(json.dumps(
        {"key": key, "size": len(data), "sha256": hashlib.sha256(data).hexdigest()}))
    with pytest.raises(UnsafeCacheError) as info:
        c_backend.source_library(SEVEN)
    message = str(info.value)
    assert f"the code cache {expected}" in message and "run as you" in message
    assert "DALEMBERT_CACHE_DIR to a folder of your own" in message
    if how != "another user's":
        assert f"chmod 700 {folder}" in message
    with pytest.warns(NativeUnavailableWarning, match="using NumPy instead") as caught:
        (fn,) = c_backend.build_flat_functions([SPEC], use="c")
    assert expected in str(caught[0].message)
    assert not hasattr(fn, "library") and fn([2.0])[0] == 6.0  # NumPy, still correct
    assert not marker.exists()
    assert sorted(p.name for p in files["so"].parent.iterdir()) == sorted(
        [files["so"].name, files["sha256"].name, files["so"].with_suffix(".c").name])


def test_a_cache_that_is_a_file_is_named(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(blocker))
    with pytest.raises(CompileError, match=rf"the code cache {blocker} is not a folder; set "
                                           "DALEMBERT_CACHE_DIR to a folder of your own"):
        c_backend.source_library(SEVEN)


# -- read-only and full folders -----------------------------------------------------------------
def _private_mount_namespace() -> None:
    """Enter a mount namespace of this process alone (mounts made now stay in it)."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.unshare(0x00020000) != 0:  # CLONE_NEWNS
        raise PermissionError(f"unshare: {os.strerror(ctypes.get_errno())}")
    subprocess.run(["mount", "--make-rprivate", "/"], check=True, capture_output=True)


def _read_only(folder: Path) -> None:
    """Make ``folder`` read-only: its mode for a user, a read-only mount for root (who
    writes whatever the mode)."""
    if not IS_ROOT:
        folder.chmod(0o500)
        return
    _private_mount_namespace()
    for options in (["--bind", str(folder), str(folder)],
                    ["-o", "remount,bind,ro", str(folder)]):
        subprocess.run(["mount", *options], check=True, capture_output=True)


def load_read_only(root: str, source: str) -> tuple[str, object]:
    os.environ["DALEMBERT_CACHE_DIR"] = root
    try:
        _read_only(Path(root) / cache.FOLDER)
    except (OSError, subprocess.CalledProcessError) as exc:
        return "unavailable", str(exc)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            library = c_backend.source_library(source)
        except CompileError as exc:
            return "refused", str(exc)
    assert not caught, [str(w.message) for w in caught]
    return "loaded", library.seven()


@pytest.mark.parametrize("state", ["valid", "missing", "empty"])
def test_a_read_only_cache(forks, root, state):
    """A valid entry loads from it; a missing or bad one is refused with the cause."""
    isolated(forks, load_seven, str(root))
    files = entry(root)
    if state == "missing":
        for path in files.values():
            path.unlink()
    elif state == "empty":
        replace_bytes(files["so"], b"")
    outcome, value = isolated(forks, load_read_only, str(root), SEVEN)
    if outcome == "unavailable":
        pytest.skip(f"no read-only folder can be made here: {value}")
    folder = root / cache.FOLDER
    if state == "valid":
        assert (outcome, value) == ("loaded", 7)
        return
    assert outcome == "refused"
    assert f"cannot write to the code cache {folder}: " in value
    assert ("Read-only file system" if IS_ROOT else "Permission denied") in value
    assert value.endswith("; set DALEMBERT_CACHE_DIR to a writable folder")
    if state == "empty":
        assert value.startswith(f"the cached library {files['so']} is empty and cannot be "
                                "rebuilt: ")


def test_a_full_disk_is_named_and_leaves_nothing(root, monkeypatch):
    """ENOSPC while the digest record is written (the last write of a build)."""
    def full(path, text):
        raise OSError(28, os.strerror(28), str(path))

    monkeypatch.setattr(cache, "_write_synced", full)
    with pytest.raises(CompileError) as info:
        c_backend.source_library(SEVEN)
    folder = root / cache.FOLDER
    assert str(info.value) == (f"cannot write to the code cache {folder}: No space left on "
                               "device; free space there, or set DALEMBERT_CACHE_DIR to a folder "
                               "on another disk")
    assert [p.suffix for p in folder.iterdir()] == [".lock"]  # no library, no temporaries
    with pytest.warns(NativeUnavailableWarning, match="No space left on device"):
        (fn,) = c_backend.build_flat_functions([SPEC], use="c")
    assert fn([1.0])[0] == 3.0


def fill_and_load(root: str) -> tuple[str, object]:
    """On a tiny file system filled up: the build fails; freed, it succeeds."""
    os.environ["DALEMBERT_CACHE_DIR"] = root
    try:
        _private_mount_namespace()
        Path(root).mkdir()
        subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k,mode=0700", "tmpfs", root],
                       check=True,
                       capture_output=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        return "unavailable", str(exc)
    cache.private_folder()
    filler = Path(root) / "filler"
    with open(filler, "wb", buffering=0) as fh, pytest.raises(OSError, match="No space"):
        while True:
            fh.write(b"\0" * 4096)
    try:
        c_backend.source_library(SEVEN)
    except CompileError as exc:
        refused = str(exc)
    else:
        return "loaded on a full disk", None
    left = temporaries(Path(root) / cache.FOLDER)
    filler.unlink()
    return refused, (left, c_backend.source_library(SEVEN).seven())


def test_a_really_full_file_system(forks, root):
    if not IS_ROOT:
        pytest.skip("mounting a small file system needs root")
    outcome, value = isolated(forks, fill_and_load, str(root))
    if outcome == "unavailable":
        pytest.skip(f"no small file system can be mounted here: {value}")
    assert "No space left on device" in outcome, outcome
    assert value == ([], 7)  # nothing left behind; built once there is room


# -- killed and concurrent builds ------------------------------------------------------------
def wrapper_compiler(folder: Path) -> Path:
    """A compiler that logs each run, waits 0.3 s (so that builds overlap), waits while
    ``hold`` exists (so that a build can be killed midway), then runs the real one."""
    script = folder / "cc"
    script.write_text("\n".join([
        "#!/bin/sh",
        f'echo run >> "{folder / "log"}"',
        "sleep 0.3",
        f'while [ -e "{folder / "hold"}" ]; do sleep 0.05; done',
        f'exec "{c_backend.find_compiler()}" "$@"',
    ]))
    script.chmod(0o700)
    return script


def build_in_own_group(root: str, cc: str) -> dict:
    os.setpgrp()  # so that the parent can kill the compiler with this process
    return load_seven(root, "source", cc)


def test_a_killed_build_leaves_the_entry_missing_and_a_later_build_cleans_up(forks, root,
                                                                              tmp_path):
    cc = wrapper_compiler(tmp_path)
    (tmp_path / "hold").touch()
    child = Child(forks, build_in_own_group, str(root), str(cc))
    folder = root / cache.FOLDER
    deadline = time.monotonic() + 30
    while not (folder.is_dir() and temporaries(folder)) or not (tmp_path / "log").exists():
        assert time.monotonic() < deadline, "the build did not start"
        time.sleep(0.02)
    os.killpg(child.process.pid, signal.SIGKILL)
    child.process.join(10)
    assert child.process.exitcode == -signal.SIGKILL
    assert len(temporaries(folder)) == 1  # the killed build's
    files = entry(root, cc=str(cc))
    assert not files["so"].exists()
    # Temporaries of other entries: a stale one and one of earlier versions go,
    # a fresh one (a build running elsewhere) stays.
    stale, legacy, fresh = (folder / name for name in (
        "dalembert_0123.abcd.build", "tmpk2j4_x9z", "dalembert_4567.efgh.build"))
    for path in (stale, legacy, fresh):
        path.mkdir()
    hours_ago = time.time() - 2 * cache.STALE_AFTER
    for path in (stale, legacy):
        os.utime(path, (hours_ago, hours_ago))
    (tmp_path / "hold").unlink()
    result = isolated(forks, load_seven, str(root), "source", str(cc))
    assert result == {"value": 7, "native": True, "warnings": []}
    assert temporaries(folder) == [fresh.name]
    assert_valid(files)


def test_two_concurrent_builds_build_once_and_both_load(forks, root, tmp_path):
    cc = wrapper_compiler(tmp_path)
    children = [Child(forks, load_seven, str(root), "source", str(cc)) for _ in range(2)]
    results = [child.result() for child in children]
    assert results == [("returned", {"value": 7, "native": True, "warnings": []})] * 2
    assert (tmp_path / "log").read_text().split() == ["run"]  # one compile, one waited
    assert_valid(entry(root, cc=str(cc)))
    assert temporaries(root / cache.FOLDER) == []


# -- the test load in a child process ---------------------------------------------------------
def test_a_library_that_crashes_when_loaded_fails_its_build_not_the_caller(root):
    """Its constructor aborts: the test load's child dies, the caller gets an error."""
    def build(folder):
        compile_c("#include <stdlib.h>\n__attribute__((constructor)) static void die(void) "
                  "{ abort(); }\n" + cache.PROBE_SOURCE, folder / cache.LIBRARY)

    with pytest.raises(CompileError, match=r"a library just built crashed the process loading "
                                           r"it \(SIGABRT\); it is not stored in the cache"):
        cache.load_library("crashes", build)
    assert sorted(p.name for p in (root / cache.FOLDER).iterdir()) == ["dalembert_crashes.lock"]


def test_a_library_without_the_probe_is_not_stored(root):
    def build(folder):
        compile_c(SEVEN, folder / cache.LIBRARY)

    with pytest.raises(CompileError, match=r"a library just built could not be loaded: "
                                           r"AttributeError: .*dalembert_cache_probe"):
        cache.load_library("no_probe", build)


# -- the C runtime ---------------------------------------------------------------------------
def simulate_pendulum(root: str, broken_runtime: bool = False) -> dict:
    """In a child: plan and run the pendulum; which loop, and the cache's warnings."""
    os.environ["DALEMBERT_CACHE_DIR"] = root
    from dalembert.examples import load
    from dalembert.solvers.native import library

    if broken_runtime:
        library.runtime_source = lambda: "#error a runtime that does not compile"
    module = load("pendulum")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        system = module.build()
        plan = system.plan((0.0, 0.1), **module.INITIAL)
        traj = system.run(plan)
    return {"loop": plan.loop, "why": plan.why_python, "success": traj.success,
            "warnings": [(w.category.__name__, str(w.message)) for w in caught
                         if issubclass(w.category, (BadCacheEntryWarning,
                                                    NativeUnavailableWarning))]}


def test_an_empty_runtime_is_rebuilt_and_the_c_loop_runs(forks, root):
    """It used to take the Python loop (74x slower) without a word."""
    from dalembert.solvers.native import library

    key = c_backend._source_key(library.runtime_source(), c_backend.find_compiler(),
                                c_backend.SOURCE_CFLAGS)
    runtime = root / cache.FOLDER / f"dalembert_{key}.so"
    cache.private_folder()
    runtime.write_bytes(b"")
    runtime.chmod(0o600)
    result = isolated(forks, simulate_pendulum, str(root))
    assert result["loop"] == "c" and result["success"]
    assert result["warnings"] == [("BadCacheEntryWarning", f"the cached library {runtime} is "
                                   "empty; it was not loaded but rebuilt")]


def test_an_unavailable_runtime_is_said_once_with_its_cause(forks, root):
    result = isolated(forks, simulate_pendulum, str(root), True)
    assert result["loop"] == "python" and result["success"]
    assert "the C runtime could not be compiled" in result["why"]
    ((category, message),) = result["warnings"]  # once, though planned twice
    assert category == "NativeUnavailableWarning"
    assert message.startswith("the C simulation loop is unavailable, the Python loop runs "
                              "instead (slower): ")
    assert "a runtime that does not compile" in message
