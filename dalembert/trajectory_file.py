"""The trajectory file (``.npz``): written atomically, read without trusting it.

A trajectory file is a NumPy ``.npz`` archive: one ``.npy`` member per array of
:data:`ARRAYS`, ``t_events_<k>`` and ``y_events_<k>`` per event function, those of
:data:`CONTACT_ARRAYS` (and :data:`OPTIONAL_CONTACT_ARRAYS`) for a run with unilateral
constraints, and ``meta``, a JSON text of the names, status, message, statistics and
initialization report (:data:`METADATA`).

Writing goes to a temporary file beside the target (locked while it is written),
synced, then renamed over the target: the file appears whole or not at all, and a
save killed midway leaves the old file as it was. The temporary file of a killed
save is removed by a later save to the same path.

Reading trusts nothing in the file: a path that is not a regular file (a FIFO, a
folder) is refused before anything is read from it; an archive of more than
:data:`MAX_MEMBERS` members is refused from the end record of its zip directory,
before the directory is parsed; members other than those above are refused;
before anything is decompressed, the sizes the archive declares must add up to at
most ``max_bytes`` (by default :data:`MAX_EXPANSION` times the file's size, at
least :data:`MIN_LIMIT`: ``save`` does not compress, so a file written by it
reads to about its own size, while a small crafted file could otherwise expand to
gigabytes); each array's header must agree with its declared size; nothing is
unpickled; and the metadata and the arrays' shapes must be consistent (one row per
time, one column per coordinate or constraint). Any failure raises
:class:`~dalembert.errors.TrajectoryFileError` naming the field.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import re
import stat
import struct
import tempfile
import time
import zipfile
from contextlib import suppress
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from .errors import TrajectoryFileError

SUFFIX = ".npz"
#: The arrays of a trajectory, one row per output time.
ARRAYS = ("t", "q", "qd", "qdd", "multipliers", "constraint_forces", "kinetic_energy",
          "potential_energy", "jacobi_integral", "position_residual", "velocity_residual")
#: Arrays a file may lack: a model's inputs (one column each; none in files of earlier
#: versions) and the times near a singular configuration (written where there are some).
OPTIONAL_ARRAYS = ("inputs", "near_singular")
#: A run with unilateral constraints: its impacts (time, impulse on each contact, energy
#: lost, velocities before and after) and its switches (time, the contacts closed from
#: then, the state there); written with ``contact_names`` in the metadata.
CONTACT_ARRAYS = ("impact_t", "impact_impulses", "impact_energy_lost", "impact_qd_before",
                  "impact_qd_after", "switch_t", "switch_closed", "switch_q", "switch_qd")
#: A run with unilateral constraints may also have (files of earlier versions lack them)
#: the friction impulse of each impact (every contact's sliding velocities side by side)
#: and how many sliding velocities each contact has; they come together.
OPTIONAL_CONTACT_ARRAYS = ("impact_friction_impulses", "contact_tangents")
#: How a trajectory can end (its ``status``).
STATUSES = ("finished", "event", "failed", "interrupted", "timeout")
#: The metadata fields and their JSON types.
METADATA: dict[str, type] = {"coordinate_names": list, "constraint_names": list,
                             "status": str, "message": str, "stats": dict,
                             "initialization": str, "parameters": dict, "input_names": list,
                             "energy_conserved": bool, "contact_names": list}
#: Fields a file of an earlier version may lack, and their value then.
OPTIONAL = {"parameters": dict, "input_names": list}
#: Fields that are absent where not known (``None`` then).
UNKNOWN_IF_ABSENT = ("energy_conserved", "contact_names")
#: By default a file may read to at most this many times its size ...
MAX_EXPANSION = 16
#: ... or this many bytes, whichever is more.
MIN_LIMIT = 64 * 2**20
#: A save's temporary file older than this (seconds) and not locked was left by a
#: killed save.
ABANDONED_AFTER = 60.0
#: The most members a trajectory file may have: its arrays and two per event
#: function (4 990 of them). Checked from the zip directory before it is parsed.
MAX_MEMBERS = 10_000

_NAMES = (*ARRAYS, *OPTIONAL_ARRAYS, *CONTACT_ARRAYS, *OPTIONAL_CONTACT_ARRAYS)
_MEMBER = re.compile(rf"(meta|{'|'.join(_NAMES)}|[ty]_events_\d+)\.npy")
#: What reading a damaged, encrypted or oddly compressed member raises.
_UNREADABLE = (ValueError, OSError, EOFError, RuntimeError, NotImplementedError,
               zipfile.BadZipFile)
_HEADER_READERS = {(1, 0): np.lib.format.read_array_header_1_0,
                   (2, 0): np.lib.format.read_array_header_2_0}


def write(path: Path, arrays: dict[str, Any], metadata: dict[str, Any]) -> None:
    """Write ``arrays`` and ``metadata`` to ``path`` atomically.

    The file gets the mode a plain ``open`` would give it under the umask.

    Parameters
    ----------
    path
        The file; it must end in ``.npz``.
    arrays
        Member name -> array.
    metadata
        The :data:`METADATA` fields (stored as JSON).

    Raises
    ------
    TrajectoryFileError
        ``path`` does not end in ``.npz``.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     write(Path(folder) / "run.csv", {}, {})
    Traceback (most recent call last):
    ...
    dalembert.errors.TrajectoryFileError: Trajectory.save writes NumPy .npz files only; ...
    """
    if path.suffix.lower() != SUFFIX:
        got = f"the suffix {path.suffix!r}" if path.suffix else "no suffix"
        raise TrajectoryFileError(
            f"Trajectory.save writes NumPy .npz files only; {str(path)!r} has {got}. Give a "
            "path ending in .npz (for a table: traj.to_dataframe().to_csv(path))")
    try:
        _remove_abandoned(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f"{path.name}.", suffix=".tmp")
    except OSError as exc:  # said of the file asked for, not of the temporary one
        why = "the folder does not exist (create it first)" if not path.parent.is_dir() \
            else (exc.strerror or str(exc))
        raise type(exc)(exc.errno, f"cannot save {path}: {why}", str(path.parent)) from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # held until closed: the file is in use
        # mkstemp makes the file 0600; a saved result gets the mode a plain open()
        # would give it, 0666 less the umask (read back without changing it).
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(metadata)), **arrays)
            fh.flush()
            os.fsync(fh.fileno())  # on disk before the rename makes it visible
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    with suppress(OSError):  # the rename on disk too (not every file system can)
        folder = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(folder)
        finally:
            os.close(folder)


def _remove_abandoned(path: Path) -> None:
    """Remove the temporary files that killed saves to ``path`` left: this user's, older
    than :data:`ABANDONED_AFTER` and not locked by a save in progress."""
    pattern = re.compile(re.escape(path.name) + r"\.[a-z0-9_]{8}\.tmp")
    try:
        names = os.listdir(path.parent)
    except OSError:
        return
    for name in filter(pattern.fullmatch, names):
        try:
            fd = os.open(path.parent / name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
        except OSError:
            continue
        try:
            info = os.fstat(fd)
            if (stat.S_ISREG(info.st_mode) and info.st_uid == os.geteuid()
                    and time.time() - info.st_mtime > ABANDONED_AFTER):
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # fails if a save holds it
                os.unlink(path.parent / name)
        except OSError:
            pass
        finally:
            os.close(fd)


def file_path(path: object, caller: str) -> Path:
    """``path`` as a ``Path``; a ``TypeError`` naming ``caller`` if it is not a path.

    Parameters
    ----------
    path
        What was given.
    caller
        ``Trajectory.save`` or ``Trajectory.load``.

    Examples
    --------
    >>> file_path(None, "Trajectory.load")
    Traceback (most recent call last):
    ...
    TypeError: Trajectory.load takes a path (a str or os.PathLike ending in .npz), got None ...
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{caller} takes a path (a str or os.PathLike ending in .npz), got "
                        f"{path!r:.80} ({type(path).__name__})")
    return Path(path)


def read(path: Path, max_bytes: int | None = None) -> dict[str, Any]:
    """The fields of the trajectory in ``path``, checked (see the module's description).

    Parameters
    ----------
    path
        A file written by :func:`write`.
    max_bytes
        The most bytes its arrays may take once read (default: :data:`MAX_EXPANSION`
        times the file's size, at least :data:`MIN_LIMIT`).

    Returns
    -------
    dict
        The arrays of :data:`ARRAYS`, the :data:`METADATA` fields (names as
        tuples), ``t_events`` and ``y_events``: the keywords of a ``Trajectory``; with
        ``contact_names``, ``contacts``: the arrays of :data:`CONTACT_ARRAYS` (and
        of :data:`OPTIONAL_CONTACT_ARRAYS` where the file has them) by name.

    Raises
    ------
    TrajectoryFileError
        The file is not a trajectory file, is larger than allowed once read, or
        holds inconsistent data; the message names the member or field.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     np.savez(Path(folder) / "other.npz", x=np.zeros(3))
    ...     read(Path(folder) / "other.npz")
    Traceback (most recent call last):
    ...
    dalembert.errors.TrajectoryFileError: ... is an .npz archive but not a trajectory file: \
it has no 'meta' member (Trajectory.save writes one)
    """
    members = _read_members(path, max_bytes)
    fields = _metadata(members.pop("meta"), path)
    n, m = len(fields["coordinate_names"]), len(fields["constraint_names"])

    def bad(name: str, problem: str) -> TrajectoryFileError:
        return TrajectoryFileError(f"{path} is not a valid trajectory file: {name} {problem}")

    missing = [name for name in ARRAYS if name not in members]
    if missing:
        raise bad(f"the array {missing[0]!r}", "is missing")
    t = members["t"]
    if t.ndim != 1:
        raise bad("the array 't'", f"has shape {t.shape}, not one value per time")
    k = len(t)
    shapes: dict[str, tuple[int, ...]] = {name: (k,) for name in ARRAYS}
    shapes.update({name: (k, n) for name in ("q", "qd", "qdd", "constraint_forces")},
                  multipliers=(k, m), inputs=(k, len(fields["input_names"])),
                  near_singular=(k,))
    contacts = fields.pop("contact_names", None)
    if contacts is not None:
        for name in CONTACT_ARRAYS:
            if name not in members:
                raise bad(f"the array {name!r}", "is missing (a run with contacts has it)")
        impacts, switches, g = len(members["impact_t"]), len(members["switch_t"]), len(contacts)
        shapes.update(impact_t=(impacts,), impact_impulses=(impacts, g),
                      impact_energy_lost=(impacts,), impact_qd_before=(impacts, n),
                      impact_qd_after=(impacts, n), switch_t=(switches,),
                      switch_closed=(switches, g), switch_q=(switches, n),
                      switch_qd=(switches, n))
        present = [name in members for name in OPTIONAL_CONTACT_ARRAYS]
        if any(present) and not all(present):
            absent = OPTIONAL_CONTACT_ARRAYS[present.index(False)]
            raise bad(f"the array {absent!r}", "is missing (it comes with "
                      f"{OPTIONAL_CONTACT_ARRAYS[present.index(True)]!r})")
        if all(present):
            sizes = members["contact_tangents"]
            if sizes.shape != (g,) or sizes.dtype.kind not in "iu" or np.any(sizes < 0):
                raise bad("the array 'contact_tangents'", f"holds {sizes.dtype} of shape "
                          f"{sizes.shape}, not a count >= 0 per contact ({g})")
            shapes.update(contact_tangents=(g,),
                          impact_friction_impulses=(impacts, int(sizes.sum())))
    n_events = sum(1 for name in members if name.startswith("t_events_"))
    for e in range(n_events):
        events = members.get(f"t_events_{e}")
        if events is None or f"y_events_{e}" not in members:
            raise bad(f"the events of event function {e}", "are missing (t_events_0, y_events_0, "
                      "... come in pairs, numbered from 0)")
        if events.ndim != 1:
            raise bad(f"the array 't_events_{e}'", f"has shape {events.shape}, not one time per "
                      "event")
        shapes[f"t_events_{e}"] = (len(events),)
        shapes[f"y_events_{e}"] = (len(events), 2 * n)
    for name, array in members.items():
        if name not in shapes:  # y_events_<e> without its t_events_<e>
            raise bad(f"the array {name!r}", "has no t_events of the same number")
        if array.shape != shapes[name]:
            raise bad(f"the array {name!r}", f"has shape {array.shape}; {k} times, {n} "
                      f"coordinates and {m} constraints make it {shapes[name]}")
        if array.dtype.kind not in ("b" if name in ("near_singular", "switch_closed")
                                    else "fiu"):
            raise bad(f"the array {name!r}", f"holds {array.dtype}, not numbers")
    fields.update({name: members[name] for name in ARRAYS})
    fields["inputs"] = members.get("inputs", np.zeros((k, len(fields["input_names"]))))
    fields["near_singular"] = members.get("near_singular", np.zeros(k, dtype=bool))
    fields["t_events"] = [members[f"t_events_{e}"] for e in range(n_events)]
    fields["y_events"] = [members[f"y_events_{e}"] for e in range(n_events)]
    if contacts is not None:
        fields["contacts"] = {"names": tuple(contacts),
                              **{name: members[name] for name in CONTACT_ARRAYS},
                              **{name: members[name] for name in OPTIONAL_CONTACT_ARRAYS
                                 if name in members}}
    return fields


def _read_members(path: Path, max_bytes: int | None) -> dict[str, np.ndarray]:
    """Every member of the archive, read only once its declared sizes are within bounds."""
    with _open_regular(path) as fh:
        size = os.fstat(fh.fileno()).st_size
        _check_member_count(fh, size, path)
        try:
            archive = zipfile.ZipFile(fh)
        except (zipfile.BadZipFile, NotImplementedError, ValueError, EOFError) as exc:
            raise TrajectoryFileError(f"{path} is not a trajectory file: it is not an .npz "
                                      f"archive (Trajectory.save writes those): {exc}") from exc
        with archive:
            return _read_archive(archive, path, size, max_bytes)


def _read_archive(archive: zipfile.ZipFile, path: Path, size: int,
                  max_bytes: int | None) -> dict[str, np.ndarray]:
    infos = archive.infolist()
    if len(infos) > MAX_MEMBERS:  # the end record's count may understate the directory
        raise _too_many(path, str(len(infos)))
    names = [info.filename for info in infos]
    if "meta.npy" not in names:
        raise TrajectoryFileError(f"{path} is an .npz archive but not a trajectory file: it "
                                  "has no 'meta' member (Trajectory.save writes one)")
    seen: set[str] = set()
    for name in names:
        if not _MEMBER.fullmatch(name) or name in seen:
            raise TrajectoryFileError(f"{path} is not a trajectory file: it has an "
                                      f"unexpected member {name!r}")
        seen.add(name)
    limit = max_bytes if max_bytes is not None else max(MAX_EXPANSION * size, MIN_LIMIT)
    total = sum(info.file_size for info in infos)
    if total > limit:
        raise TrajectoryFileError(
            f"{path} would take {total} bytes once read, more than the limit of {limit} "
            f"bytes for a file of {size} bytes; if you trust it, pass "
            "max_bytes= to Trajectory.load")
    return {info.filename[:-4]: _read_array(archive, info, path) for info in infos}


_FILE_KINDS = {stat.S_ISDIR: "a folder", stat.S_ISFIFO: "a FIFO", stat.S_ISSOCK: "a socket",
               stat.S_ISCHR: "a character device", stat.S_ISBLK: "a block device"}


def _open_regular(path: Path) -> BinaryIO:
    """``path`` opened for reading if it is a regular file (following links).

    It is opened without blocking and checked before anything is read: opening a FIFO
    for reading would wait for a writer forever, and a device could be endless.
    ``FileNotFoundError`` and ``PermissionError`` pass through, as from ``open``.
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = next((name for test, name in _FILE_KINDS.items() if test(mode)),
                        "a special file")
            raise TrajectoryFileError(f"{path} is not a trajectory file: it is {kind}, not a "
                                      "regular file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


#: The end record of a zip directory: signature, disk numbers, entry counts (this
#: disk, all), directory size and offset, comment length.
_END_RECORD = struct.Struct("<4s4H2LH")
_END_SIGNATURE = b"PK\x05\x06"


def _check_member_count(fh: BinaryIO, size: int, path: Path) -> None:
    """Refuse an archive whose zip directory announces more than :data:`MAX_MEMBERS`
    members, from its end record alone (the last 22 bytes to 64 KiB of the file),
    before the directory is parsed.

    A file without an end record is left to ``zipfile``, which says what it is not.
    A count of 0xFFFF (a ZIP64 archive of that many members or more) is over the
    limit too.
    """
    tail = min(size, _END_RECORD.size + 0xFFFF)  # the record, then a comment of up to 64 KiB
    fh.seek(size - tail)
    data = fh.read(tail)
    at = data.rfind(_END_SIGNATURE)
    if at >= 0 and at + _END_RECORD.size <= len(data):
        count = _END_RECORD.unpack_from(data, at)[4]
        if count > MAX_MEMBERS:  # 0xFFFF: that many or more (ZIP64 holds the rest)
            raise _too_many(path, f"{count} or more" if count == 0xFFFF else str(count))
    fh.seek(0)


def _too_many(path: Path, count: str) -> TrajectoryFileError:
    return TrajectoryFileError(
        f"{path} is not a trajectory file: it has {count} members, more than the "
        f"{MAX_MEMBERS} a trajectory file may have (one per array, two per event function)")


def _read_array(archive: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path) -> np.ndarray:
    """One member, its header checked against its declared size first; never unpickled."""
    name = info.filename[:-4]
    try:
        fh = archive.open(info)
        reader = _HEADER_READERS[np.lib.format.read_magic(fh)]
        shape, _, dtype = reader(fh)
    except (*_UNREADABLE, KeyError) as exc:
        raise TrajectoryFileError(f"{path} is not a trajectory file: its member {name!r} is "
                                  f"not a NumPy array ({exc})") from exc
    with fh:
        if dtype.hasobject:
            raise TrajectoryFileError(f"{path} is not a trajectory file: its member {name!r} "
                                      "holds Python objects (they are never unpickled)")
        size = math.prod(shape) * dtype.itemsize  # exact, however large the shape claimed
        if fh.tell() + size != info.file_size:
            raise TrajectoryFileError(
                f"{path} is not a valid trajectory file: its member {name!r} declares shape "
                f"{shape} of {dtype} ({size} bytes) but holds {info.file_size - fh.tell()}")
        fh.seek(0)
        try:
            return np.lib.format.read_array(fh, allow_pickle=False)
        except _UNREADABLE as exc:
            raise TrajectoryFileError(f"{path} is not a valid trajectory file: its member "
                                      f"{name!r} cannot be read ({exc})") from exc


def _metadata(meta: np.ndarray, path: Path) -> dict[str, Any]:
    """The checked metadata fields (names as tuples)."""
    def bad(name: str, problem: str) -> TrajectoryFileError:
        return TrajectoryFileError(f"{path} is not a valid trajectory file: {name} {problem}")

    if meta.shape != () or meta.dtype.kind != "U":
        raise bad("the member 'meta'", f"is a {meta.dtype} array of shape {meta.shape}, not a "
                  "text")
    try:
        fields = json.loads(str(meta))
    except RecursionError as exc:  # the parser recurses once per level
        raise bad("the member 'meta'", "is JSON nested too deeply (a trajectory's metadata "
                  "is a flat object)") from exc
    except ValueError as exc:
        raise bad("the member 'meta'", f"is not JSON ({exc})") from exc
    if not isinstance(fields, dict):
        raise bad("the member 'meta'", "is not a JSON object")
    for name in fields:
        if name not in METADATA:
            raise bad(f"the field {name!r}", f"is unknown (the fields are {', '.join(METADATA)})")
    for name, make in OPTIONAL.items():
        fields.setdefault(name, make())
    for name, kind in METADATA.items():
        if name not in fields and name in UNKNOWN_IF_ABSENT:
            fields[name] = None
            continue
        if name not in fields:
            raise bad(f"the field {name!r}", "is missing")
        if not isinstance(fields[name], kind):
            raise bad(f"the field {name!r}", f"is {fields[name]!r}, not a JSON {kind.__name__}")
    for name in ("coordinate_names", "constraint_names", "input_names", "contact_names"):
        names = fields[name]
        if names is None:  # no contacts
            continue
        if not all(isinstance(s, str) for s in names) or len(set(names)) != len(names):
            raise bad(f"the field {name!r}", f"is {names!r}, not a list of distinct names")
        fields[name] = tuple(names)
    if fields["status"] not in STATUSES:
        raise bad("the field 'status'", f"is {fields['status']!r}; a trajectory's status is one "
                  f"of {', '.join(map(repr, STATUSES))}")
    for name in ("stats", "parameters"):
        for key, value in fields[name].items():
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise bad(f"the field {name!r}", f"has {key!r}: {value!r}, not a number")
    return fields
