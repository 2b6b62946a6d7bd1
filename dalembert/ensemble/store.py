"""Where an ensemble's arrays go as cases finish: memory, a Zarr store or a netCDF file.

Every case reports the same quantities at the same output times, so the results
are dense arrays over ``(case, time[, coordinate | constraint | input])``. The layout is
fixed before the first case runs (:class:`Layout`). In memory, the arrays are
filled in place. On disk, the file is created with every variable empty, each
finished block of cases is written into it as it arrives and dropped, and the
result reads the file back lazily (Dask arrays, chunked as written): the client
holds one block at a time, however many cases there are. The cases' columns are
coordinates along ``case``; ``status`` holds each case's code (its attributes
``flag_values`` / ``flag_meanings`` name them, CF-style), and cases that never
ran keep the code of ``"not-run"`` and NaN values.
"""

from __future__ import annotations

import ctypes
import functools
import mmap
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import EnsembleError, EnsembleWarning, user_stacklevel
from .faults import CODE, STATUSES, BatchOutcome
from .worker import QUANTITIES

#: Per-case numbers stored beside the arrays (the rest of the summary is a table).
CASE_NUMBERS = ("t_end", "energy_error", "seconds")
#: The file a Zarr store written here holds: ``overwrite=True`` removes a folder only
#: if it has it (or is an ensemble's Zarr store of a version before it).
MARKER = ".dalembert-ensemble"


@dataclass(frozen=True)
class Layout:
    """The variables of an ensemble's dataset and their shapes.

    Parameters
    ----------
    cases
        The case table (its columns become coordinates along ``case``).
    t_eval
        The output times.
    coordinates, constraints, inputs
        The model's names.
    keep
        Trajectory quantities (:data:`~dalembert.ensemble.worker.QUANTITIES`).
    outputs
        Names of derived quantities (one number per time).
    chunk
        Cases per block (the file's chunk along ``case``).
    """

    cases: Any
    t_eval: np.ndarray
    coordinates: tuple[str, ...]
    constraints: tuple[str, ...]
    inputs: tuple[str, ...]
    keep: tuple[str, ...]
    outputs: tuple[str, ...]
    chunk: int

    @property
    def size(self) -> int:
        return len(self.cases)

    def variables(self) -> dict[str, tuple[tuple[str, ...], tuple[int, ...]]]:
        """``name -> (dimensions, shape)`` of every per-time variable."""
        sizes = {"coordinate": len(self.coordinates), "constraint": len(self.constraints),
                 "input": len(self.inputs)}
        found = {}
        for name in (*self.keep, *self.outputs):
            extra = QUANTITIES.get(name, ())
            dims = ("case", "time", *extra)
            found[name] = (dims, (self.size, len(self.t_eval), *(sizes[d] for d in extra)))
        return found

    def dataset(self, data: dict[str, Any]):
        """An ``xarray.Dataset`` of this layout holding ``data`` (arrays by variable)."""
        import xarray as xr

        coords: dict[str, Any] = {"case": np.arange(self.size), "time": self.t_eval,
                                  "coordinate": list(self.coordinates),
                                  "constraint": list(self.constraints)}
        if "inputs" in self.keep:
            coords["input"] = list(self.inputs)
        for name in self.cases.columns:
            coords[name] = ("case", self.cases[name].to_numpy(dtype=float))
        variables: dict[str, tuple] = {name: (dims, data[name])
                                       for name, (dims, _) in self.variables().items()}
        variables["status"] = (("case",), data["status"], _status_attrs())
        for name in CASE_NUMBERS:
            variables[name] = (("case",), data[name])
        return xr.Dataset(variables, coords=coords)

    def check_names(self) -> None:
        """A case column must not take a variable's or a dimension's name."""
        taken = {*self.variables(), "status", *CASE_NUMBERS, "case", "time", "coordinate",
                 "constraint", "input"}
        for name in self.cases.columns:
            if name in taken:
                raise EnsembleError(f"the case column {name!r} has the name of a variable or "
                                    "dimension of the results; rename it")


def written_once(shape: tuple[int, ...]) -> np.ndarray:
    """An empty float array for results written once, a few rows at a time, as cases
    finish: anonymous memory without the huge-page advice NumPy gives arrays of 4 MB
    and more.

    Under that advice the kernel may compact memory when a page is first written (its
    transparent huge pages' default ``defrag=madvise``): pauses of milliseconds between
    two cases, which a loop over ``simulate``, whose arrays are smaller, does not pay
    (measured in bench/README.md). Small pages cost the same at every first write.

    Parameters
    ----------
    shape
        The array's shape.

    Examples
    --------
    >>> values = written_once((2, 3))
    >>> values[:] = 1.0
    >>> values.shape, values.dtype, float(values.sum())
    ((2, 3), dtype('float64'), 6.0)
    """
    size = int(np.prod(shape, dtype=np.int64))
    if size == 0:
        return np.empty(shape)
    return np.frombuffer(mmap.mmap(-1, size * 8), dtype=float).reshape(shape)


def _status_attrs() -> dict[str, Any]:
    return {"flag_values": list(range(len(STATUSES))), "flag_meanings": " ".join(STATUSES),
            "long_name": "what became of the case"}


class Sink:
    """Takes finished cases (:meth:`write`), gives the dataset at the end (:meth:`dataset`)."""

    @property
    def stored(self) -> Path | None:
        """The file or folder the dataset is read from (``None``: memory)."""
        return None

    def __init__(self, layout: Layout, before: Any = None) -> None:
        self.layout = layout
        self.status = np.full(layout.size, CODE["not-run"], dtype=np.int8)
        self.numbers = {name: np.full(layout.size, np.nan) for name in CASE_NUMBERS}
        if before is not None:  # a retry: the other cases keep what they had
            self.status[:] = before["status"].values
            for name in CASE_NUMBERS:
                self.numbers[name][:] = before[name].values

    def write(self, done: BatchOutcome) -> None:
        for o in done.cases:
            self.status[o.index] = CODE[o.status]
            self.numbers["seconds"][o.index] = o.seconds
            for name in ("t_end", "energy_error"):
                self.numbers[name][o.index] = o.numbers.get(name, np.nan)
        if done.arrays:
            self._write_arrays(done.indices, done.arrays)

    def _write_arrays(self, indices: np.ndarray, arrays: dict[str, np.ndarray]) -> None:
        """Write the rows ``arrays`` (stacked by name) of the cases ``indices``."""
        raise NotImplementedError

    def dataset(self):
        raise NotImplementedError


class MemorySink(Sink):
    """Every array held in memory, filled in place.

    The arrays are allocated empty (:func:`written_once`) and each batch's rows are
    written as they arrive; the rows of cases that never arrive are set to NaN at the
    end. Filling them all with NaN first would touch every page of them before the
    first case runs: a serial pause as long as writing them all."""

    def __init__(self, layout: Layout, before: Any = None) -> None:
        super().__init__(layout, before)
        self.data = {name: written_once(shape) for name, (_, shape) in layout.variables().items()}
        if before is not None:  # a retry: the other cases keep what they had
            for name, values in self.data.items():
                values[...] = before[name].values
        self.written = np.full(layout.size, before is not None)

    def _write_arrays(self, indices: np.ndarray, arrays: dict[str, np.ndarray]) -> None:
        for name, values in self.data.items():
            values[indices] = arrays[name]
        self.written[indices] = True

    def dataset(self):
        missing = ~self.written
        if missing.any():
            for values in self.data.values():
                values[missing] = np.nan
            self.written[:] = True
        return self.layout.dataset({**self.data, "status": self.status, **self.numbers})


class FileSink(Sink):
    """A Zarr store or a netCDF file, created empty, written block by block.

    Outcomes are gathered per block of :attr:`Layout.chunk` cases and a block is
    written once every case of it that this run has is in (each chunk is then
    written once, from one place).
    """

    def __init__(self, layout: Layout, path: Path, expected: Sequence[int],
                 overwrite: bool, before: Any = None) -> None:
        super().__init__(layout, before)
        self.path, self.kind = path, _kind(path)
        if before is not None and self.kind == "netcdf":
            before.close()  # HDF5 opens a file once: the earlier result reopens it to read
        if before is None:
            check_store(path, overwrite)
            _remove(path)
            try:
                self._create()
            except OSError as exc:  # before any case ran here: nothing is lost
                raise EnsembleError(f"could not create the store {path} ({exc.strerror or exc})"
                                    "; free space there, or write to another path") from exc
        self.expected: dict[int, int] = {}
        for i in expected:
            self.expected[i // layout.chunk] = self.expected.get(i // layout.chunk, 0) + 1
        self.pending: dict[int, list[tuple[np.ndarray, dict[str, np.ndarray]]]] = {}
        #: Where the arrays go once the store cannot be written (a full disk).
        self.fallback: MemorySink | None = None
        self.failure: OSError | None = None

    @property
    def stored(self) -> Path | None:
        return self.path if self.fallback is None else None

    def _fall_back(self, exc: OSError) -> None:
        """Keep the arrays in memory from now on: those on disk are read back (where
        they can be), those pending added, and every later block kept there. A full
        disk then loses no computed case."""
        self.failure = exc
        fallback = MemorySink(self.layout)
        try:
            with self._reader() as out:
                for name, values in fallback.data.items():
                    values[...] = np.asarray(out[name][...])
            fallback.written[:] = True  # blocks not written yet hold NaN on disk
        except Exception:  # what cannot be read back is NaN, and said
            fallback.written[:] = False
        self.fallback = fallback
        pending, self.pending = self.pending, {}
        for got in pending.values():
            for indices, arrays in got:
                fallback._write_arrays(indices, arrays)

    def _reader(self) -> Any:
        """The store opened to read only (which a full disk still allows)."""
        if self.kind == "zarr":
            import zarr

            return _Closing(zarr.open_group(str(self.path), mode="r"))
        import h5netcdf

        return h5netcdf.File(self.path, "r")

    def _create(self) -> None:
        import dask.array as da

        layout = self.layout
        data: dict[str, Any] = {}
        for name, (_, shape) in layout.variables().items():
            chunks = (layout.chunk, *shape[1:])
            data[name] = da.full(shape, np.nan, chunks=chunks)
        data["status"] = self.status  # written now, with the code of "not-run"
        data.update({name: da.full(layout.size, np.nan, chunks=layout.chunk)
                     for name in CASE_NUMBERS})
        ds = layout.dataset(data)
        if self.kind == "zarr":
            ds.to_zarr(self.path, mode="w", compute=False, zarr_format=2)
            # Zarr ignores files it does not know; this one says the folder may go.
            (self.path / MARKER).write_text('{"written_by": "dalembert.ensemble"}\n')
        else:
            ds.to_netcdf(self.path, engine="h5netcdf", compute=False)

    def _write_arrays(self, indices: np.ndarray, arrays: dict[str, np.ndarray]) -> None:
        if self.fallback is not None:
            self.fallback._write_arrays(indices, arrays)
            return
        try:
            self._write_blocks(indices, arrays)
        except OSError as exc:  # a full disk, a store gone: the cases stay in memory
            self._fall_back(exc)

    def _write_blocks(self, indices: np.ndarray, arrays: dict[str, np.ndarray]) -> None:
        chunks = indices // self.layout.chunk
        for k in np.unique(chunks):
            part = chunks == k
            rows = arrays if part.all() else {name: a[part] for name, a in arrays.items()}
            self.pending.setdefault(int(k), []).append((indices[part], rows))
        full = [k for k, got in self.pending.items()
                if sum(len(i) for i, _ in got) >= self.expected.get(k, 0)]
        for k in full:
            self._flush(k)
        if full:
            release_free_memory()

    def _flush(self, k: int) -> None:
        got = self.pending[k]  # dropped once written: a failed write keeps it
        start = k * self.layout.chunk
        stop = min(start + self.layout.chunk, self.layout.size)
        whole = sum(len(i) for i, _ in got) == stop - start
        as_came = len(got) == 1 and np.array_equal(got[0][0], np.arange(start, stop))
        with self._open() as out:
            for name, (_, shape) in self.layout.variables().items():
                if as_came:  # one batch made the block: written as it came
                    out[name][start:stop] = got[0][1][name]
                    continue
                if whole:
                    block = np.full((stop - start, *shape[1:]), np.nan)
                else:  # the block's other cases are kept: read them first
                    try:
                        block = np.array(out[name][start:stop])
                    except Exception as exc:  # a damaged chunk: the codec's own error
                        raise damaged_store(self.path, name, exc) from exc
                for indices, arrays in got:
                    block[indices - start] = arrays[name]
                out[name][start:stop] = block
        del self.pending[k]

    def finish(self) -> None:
        """Write what is still pending and the per-case numbers."""
        if self.fallback is not None:
            return
        try:
            for k in list(self.pending):
                self._flush(k)
            with self._open() as out:
                out["status"][:] = self.status
                for name, values in self.numbers.items():
                    out[name][:] = values
        except OSError as exc:
            self._fall_back(exc)

    def _open(self) -> Any:
        if self.kind == "zarr":
            import zarr

            return _Closing(zarr.open_group(str(self.path), mode="r+"))
        import h5netcdf

        return h5netcdf.File(self.path, "a")

    def dataset(self):
        import xarray as xr

        self.finish()
        if self.fallback is not None:
            return self._in_memory()
        if self.kind == "zarr":
            return guarded(xr.open_zarr(self.path), self.path)
        return xr.open_dataset(self.path, engine="h5netcdf", chunks={})


    def _in_memory(self) -> Any:
        """The dataset kept in memory after the store could not be written, with a
        warning naming the store and where the results are."""
        fallback, exc = self.fallback, self.failure
        assert fallback is not None and exc is not None
        fallback.status, fallback.numbers = self.status, self.numbers
        lost = int((~fallback.written & (self.status != CODE["not-run"])).sum())
        told = (f"the results of all {self.layout.size} cases are returned in memory "
                "(result.dataset)") if not lost else (
                f"the results are returned in memory (result.dataset), but the arrays of "
                f"{lost} cases written before could not be read back (NaN there; see the "
                "store)")
        warnings.warn(
            f"could not write to the store {self.path} ({exc.strerror or exc}); {told}; the "
            f"store is incomplete. Save them elsewhere: result.dataset.to_zarr(path)",
            EnsembleWarning, stacklevel=user_stacklevel())
        return fallback.dataset()


def guarded(dataset: Any, path: Path) -> Any:
    """``dataset`` (opened lazily from the Zarr store ``path``) whose variables read
    their chunks through :class:`_GuardedChunks`: a damaged chunk, met however the
    dataset is read (``.values``, ``.compute()``, a plot), raises
    :func:`damaged_store`'s error naming the store, the variable and the chunk's cases,
    not the codec's own. The values read are the store's, undecoded: its variables are
    floats (NaN their fill value) and the status codes, which xarray does not decode."""
    import dask.array as da
    import zarr

    group = zarr.open_group(str(path), mode="r")
    for name, variable in dataset.data_vars.items():
        if variable.chunks is None or name not in group:
            continue
        chunks = _GuardedChunks(group[name], path, str(name))
        data = da.from_array(chunks, chunks=variable.chunks, asarray=False, name=False,
                             meta=np.empty((0,) * chunks.ndim, chunks.dtype))
        dataset[name] = variable.copy(data=data)
    return dataset


class _GuardedChunks:
    """A Zarr array whose reads that fail raise :func:`damaged_store`'s error."""

    def __init__(self, array: Any, path: Path, name: str) -> None:
        self.array, self.path, self.name = array, path, name
        self.shape, self.dtype, self.ndim = array.shape, array.dtype, array.ndim

    def __getitem__(self, key: Any) -> np.ndarray:
        try:
            return np.asarray(self.array[key])
        except Exception as exc:  # a damaged chunk: the codec's or the file's own error
            raise damaged_store(self.path, self.name, exc) from exc


def damaged_store(path: Path, variable: str, exc: BaseException) -> EnsembleError:
    """The error for a store ``variable`` of which cannot be read (``exc``), naming the
    cases of its first chunk that cannot be read (each chunk is tried alone) and the
    retry that rewrites it.

    Parameters
    ----------
    path
        The store.
    variable
        The variable being read.
    exc
        What reading it raised (a codec's error, a short file...).

    Examples
    --------
    >>> str(damaged_store(Path("none.zarr"), "q", RuntimeError("bad")))
    "the store none.zarr cannot be read: a chunk of 'q' is damaged (RuntimeError: bad)"
    """
    where = "a chunk"
    retry = ""
    try:
        import zarr

        array: Any = zarr.open_group(str(path), mode="r")[variable]
        step = array.chunks[0]
        for start in range(0, array.shape[0], step):
            stop = min(start + step, array.shape[0])
            try:
                array[start:stop]
            except Exception:  # this chunk is the damaged one
                where = f"the chunk of {variable!r} holding cases {start} to {stop - 1}"
                retry = (f"; result.retry(cases={list(range(start, stop))}) runs those cases "
                         "again and rewrites it")
                break
    except Exception:  # not a Zarr store, or not readable at all: said as is
        pass
    if not retry:
        where = f"a chunk of {variable!r}"
    return EnsembleError(f"the store {path} cannot be read: {where} is damaged "
                         f"({type(exc).__name__}: {exc}){retry}")


def release_free_memory() -> None:
    """Give the memory the C allocator holds free back to the system (glibc's
    ``malloc_trim``; elsewhere nothing is done).

    A store's blocks arrive, are written and are freed one after the other. glibc
    keeps freed memory for later, and past its adaptive ``mmap`` threshold serves the
    next large arrays from a heap that fragments: a client writing a store would grow
    with the cases written; handed back after each block, its memory stays flat
    (measured in bench/README.md, "Ensembles").

    Examples
    --------
    >>> release_free_memory()
    """
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def _malloc_trim() -> Any:
    try:
        return ctypes.CDLL(None).malloc_trim
    except (AttributeError, OSError):  # not glibc
        return None


class _Closing:
    """A Zarr group as a context manager (it holds nothing to close)."""

    def __init__(self, group: Any) -> None:
        self.group = group

    def __enter__(self) -> Any:
        return self.group

    def __exit__(self, *exc: object) -> None:
        return None


def check_store(path: Path, overwrite: bool) -> None:
    """Refuse a store path of an unknown kind, one that exists (unless ``overwrite``),
    and a folder to overwrite that is not a store this library wrote (see :func:`_ours`).
    """
    _kind(path)
    if not os.path.lexists(path):
        return
    if not overwrite:
        raise EnsembleError(f"{path} exists; pass overwrite=True to replace it, or another "
                            "path")
    if path.is_dir() and not path.is_symlink() and not _ours(path):
        raise EnsembleError(
            f"overwrite=True replaces only a store simulate_many wrote, and {path} is a folder "
            f"it did not write (it has no {MARKER} marker and is not a Zarr store of an "
            "ensemble); remove it yourself if it may go, or write to another path")


def _ours(folder: Path) -> bool:
    """Whether ``folder`` may be removed to overwrite it: empty, marked (:data:`MARKER`),
    or a Zarr store with the ``status`` variable of an ensemble (versions before the
    marker wrote those)."""
    import json

    if (folder / MARKER).is_file() or not any(folder.iterdir()):
        return True
    try:
        attributes = json.loads((folder / "status" / ".zattrs").read_text())
    except (OSError, ValueError):
        return False
    return ((folder / ".zgroup").is_file() and isinstance(attributes, dict)
            # an earlier version's store names the first seven statuses (before "timeout")
            and attributes.get("flag_meanings") in (" ".join(STATUSES[:7]),
                                                    " ".join(STATUSES)))


def _remove(path: Path) -> None:
    """Remove a store that is overwritten (checked by :func:`check_store`): the new one
    is a new file or folder, not the old one rewritten in place. A result still reading
    an old netCDF file keeps its data (and HDF5 cannot truncate a file that is open). A
    Zarr store is read by path: a result still reading the old one reads the new one's
    chunks. A link is removed, not what it points to."""
    import shutil

    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        elif os.path.lexists(path):
            path.unlink()
    except OSError as exc:
        raise EnsembleError(f"could not replace {path} ({exc}); close what holds it open "
                            "(an earlier result's dataset: result.dataset.close()), or "
                            "write to another path") from exc


def _kind(path: Path) -> str:
    if path.suffix == ".zarr":
        return "zarr"
    if path.suffix in (".nc", ".nc4", ".netcdf"):
        return "netcdf"
    raise EnsembleError(f"store={str(path)!r}: a store path must end in .zarr (a Zarr store) or "
                        ".nc (a netCDF-4 file)")


def sink(layout: Layout, store: str | Path | None, expected: Sequence[int],
         overwrite: bool = False, before: Any = None) -> Sink:
    """The sink for ``store`` (``None``: memory).

    Parameters
    ----------
    layout
        The dataset's layout.
    store
        A path ending in ``.zarr`` or ``.nc``, or ``None``.
    expected
        The cases this run will write (a block is written once all of its are in).
    overwrite
        Replace an existing store.
    before
        For a retry, the dataset so far: the cases not run again keep its values
        (a store is then written in place).
    """
    layout.check_names()
    if store is None:
        return MemorySink(layout, before)
    return FileSink(layout, Path(store), expected, overwrite, before)
