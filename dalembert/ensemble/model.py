"""Sending a model to worker processes once, with its compiled code.

A :class:`~dalembert.System` holds loaded C libraries, which cannot be pickled. A
:class:`ModelPackage` holds instead the System pickled without what it computes on
first use (every ``functools.cached_property`` value: the derived equations, the
compiled functions; they are made again where they are needed), what travels with
it (an ensemble's settings and the functions that make a case's initial state,
pickled apart, so that a new ensemble of the same model does not prepare the model
again) and the
compiled libraries it uses, each with its code-cache key: the model's generated
code and the C simulation loop. A worker installs them in its own code cache
under the same keys (:func:`dalembert.codegen.cache.load_library` checks and
test-loads them as it does a library built there), then rebuilds the System,
whose compile finds them there: a worker with an empty cache compiles nothing.
:func:`prepared` does this once per process and model.

The keys include the compiler's path and flags, so a worker whose compiler differs
computes other keys and compiles the model once itself; one without a compiler
uses generated NumPy code, as a plain ``simulate`` there would (with a
:class:`~dalembert.errors.NativeUnavailableWarning`). Installing the libraries
trusts the client that sent them, as running its tasks already does.
"""

from __future__ import annotations

import copyreg
import ctypes
import hashlib
import io
import pickle
import threading
import time
from contextlib import suppress
from dataclasses import dataclass, field
from functools import cached_property, partial
from pathlib import Path
from typing import Any

from ..codegen import c_backend, cache
from ..errors import CompileError
from ..system import System


@dataclass(frozen=True)
class Library:
    """One compiled library as its cache stores it: its key and its bytes (its C source,
    kept in the cache for inspection, does not travel)."""

    key: str
    data: bytes = field(repr=False)


@dataclass(frozen=True)
class ModelPackage:
    """A System ready to travel: pickled without its loaded code, plus that code, and
    what an ensemble sends with it (its settings, pickled apart).

    ``token`` identifies the model (a digest of its pickle and its libraries' keys),
    so a worker prepares it once however many tasks and ensembles bring it;
    ``extra_token`` identifies the settings, unpickled once per worker and ensemble.
    """

    token: str
    system: bytes = field(repr=False)
    libraries: tuple[Library, ...] = field(repr=False)
    extra: bytes = field(default=b"", repr=False)
    extra_token: str = ""

    @property
    def size(self) -> int:
        """Bytes sent with each task."""
        return len(self.system) + len(self.extra) + sum(len(lib.data)
                                                        for lib in self.libraries)


def package(system: System, extra: Any = None) -> ModelPackage:
    """Pack ``system`` (its code compiled first, here) for worker processes.

    Parameters
    ----------
    system
        Any System; its ``compiled`` functions are made now if they were not.
    extra
        What travels with it (with cloudpickle where it is installed, so that
        functions defined in a script travel too).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum").build()
    >>> again, extra = prepared(package(pendulum, "settings"))
    >>> again.coordinate_names, again is not pendulum, extra
    (('x', 'y'), True, 'settings')
    """
    system.compiled  # noqa: B018 - compiled here, once, so that its libraries travel
    data, settings = _dumps(system), _dumps(extra)
    libraries = tuple(_libraries(system))
    digest = hashlib.sha256(data)
    for lib in libraries:
        digest.update(lib.key.encode())
    return ModelPackage(digest.hexdigest()[:32], data, libraries, settings,
                        hashlib.sha256(settings).hexdigest()[:32])


def _dumps(obj: Any) -> bytes:
    buffer = io.BytesIO()
    _packer(buffer).dump(obj)
    return buffer.getvalue()


_PREPARED: dict[str, System] = {}
_EXTRAS: dict[str, Any] = {}
#: Settings of this many ensembles are kept per process (the models all are: few).
_KEPT_EXTRAS = 8
_PREPARING = threading.Lock()


def prepared(pack: ModelPackage) -> tuple[System, Any]:
    """The System of ``pack`` and what came with it, in this process: made on the first
    call, then reused.

    The libraries are installed in this process's code cache, the System unpickled
    and its code loaded (found in the cache under the shipped keys), once per model;
    the settings are unpickled once per ensemble.

    Parameters
    ----------
    pack
        From :func:`package`.
    """
    with _PREPARING:  # threads of one worker prepare a package once
        system = _PREPARED.get(pack.token)
        if system is None:
            system = _PREPARED[pack.token] = _unpack_system(pack)
        if pack.extra_token not in _EXTRAS:
            while len(_EXTRAS) >= _KEPT_EXTRAS:
                _EXTRAS.pop(next(iter(_EXTRAS)))
            _EXTRAS[pack.extra_token] = pickle.loads(pack.extra) if pack.extra else None
        return system, _EXTRAS[pack.extra_token]


def preparation_seconds(pack: ModelPackage) -> float:
    """Seconds this process takes to prepare ``pack`` from scratch (install, unpickle,
    load the code), for measurements; it is not kept."""
    start = time.perf_counter()
    _unpack(pack)
    return time.perf_counter() - start


def _unpack(pack: ModelPackage) -> tuple[System, Any]:
    """The System and the settings of ``pack``, made from scratch."""
    return _unpack_system(pack), pickle.loads(pack.extra) if pack.extra else None


def _unpack_system(pack: ModelPackage) -> System:
    for lib in pack.libraries:
        install(lib)
    system = pickle.loads(pack.system)
    system.compiled  # noqa: B018 - loaded now, from the libraries just installed
    if system.compiled.backend == "c":
        from ..solvers.native.library import runtime

        with suppress(CompileError):  # warned about once; the Python loop runs instead
            runtime()
    return system


def install(lib: Library, root: Path | None = None) -> None:
    """Put ``lib`` in the code cache under its key (nothing happens if it is there).

    It goes through the cache's own checks: written privately, test-loaded in a
    child process, its digest recorded. A failure leaves the cache as it was, and
    the model is then compiled here when it is loaded.

    Parameters
    ----------
    lib
        The library.
    root
        The cache (default: :func:`dalembert.codegen.cache.cache_dir`).
    """
    with suppress(CompileError):  # not fatal: the System then compiles its code itself
        cache.load_library(lib.key, partial(_write, lib), root)


def _write(lib: Library, folder: Path) -> None:
    (folder / cache.LIBRARY).write_bytes(lib.data)


def _libraries(system: System) -> list[Library]:
    """The cached libraries ``system``'s simulations load: its compiled functions' and,
    when they are C, the simulation loop's."""
    compiled = system.compiled
    loaded: list[ctypes.CDLL] = []
    for fn in (compiled.kkt_values, compiled.velocity_values, compiled.position_values,
               compiled.energy_values):
        lib = getattr(fn, "library", None) or getattr(fn, "_library", None)
        if lib is not None:
            loaded.append(lib)
    if compiled.backend == "c" and c_backend.backend() == "c":
        from ..solvers.native.library import runtime

        with suppress(CompileError):
            loaded.append(runtime())
    found: dict[str, Library] = {}
    for lib in loaded:  # each once, in order
        cached = cache.cached_library(lib)
        if cached is not None and cached[0] not in found:
            found[cached[0]] = Library(*cached)
    return list(found.values())


def _packer(buffer: io.BytesIO) -> pickle.Pickler:
    """A pickler of dalembert's objects without their ``cached_property`` values: what
    they compute on first use (equations, compiled code holding loaded libraries) is
    made again on the other side. Based on cloudpickle's where it is installed (it
    comes with Dask), so that functions defined in a script or a notebook travel."""
    try:
        from cloudpickle import Pickler as Base
    except ImportError:  # pragma: no cover - cloudpickle comes with Dask
        Base = pickle.Pickler

    class Packer(Base):
        def reducer_override(self, obj: Any) -> Any:
            reduced = _without_cache(obj)
            if reduced is not NotImplemented:
                return reduced
            # Classes made at run time with a reducer of their own (SymPy's functions
            # of time, the coordinates): pickled as their library says, not searched
            # for through every module by cloudpickle (seconds for a 16-link chain).
            own = copyreg.dispatch_table.get(type(obj)) if isinstance(obj, type) else None
            if own is not None:
                return own(obj)
            parent = getattr(super(), "reducer_override", None)
            return NotImplemented if parent is None else parent(obj)

    return Packer(buffer, protocol=pickle.HIGHEST_PROTOCOL)


def _without_cache(obj: Any) -> Any:
    cls = type(obj)
    module = getattr(cls, "__module__", None)
    if not isinstance(module, str) or not module.startswith("dalembert.") \
            or not hasattr(obj, "__dict__"):
        return NotImplemented
    cached = _cached_names(cls)
    state = obj.__dict__
    if not cached or not cached.intersection(state):
        return NotImplemented
    return _rebuild, (cls, {k: v for k, v in state.items() if k not in cached})


def _cached_names(cls: type) -> frozenset[str]:
    return frozenset(name for klass in cls.__mro__ for name, value in vars(klass).items()
                     if isinstance(value, cached_property))


def _rebuild(cls: Any, state: dict[str, Any]) -> Any:
    obj = cls.__new__(cls)
    obj.__dict__.update(state)
    return obj
