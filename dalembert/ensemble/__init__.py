"""Ensembles: one model simulated over many parameters and initial states.

Design studies, uncertainty quantification and identification run one model
thousands of times. :func:`simulate_many` (also ``System.simulate_many``) takes a
table of cases -- a DataFrame or list of dicts whose columns name parameters,
initial coordinates and velocities, or made by :func:`grid` (a sweep) or
:func:`sample` (Monte Carlo, seeded) -- and runs them serially, on threads, on a
local Dask cluster or on any ``dask.distributed`` cluster, the compiled model sent
to each worker once. The result (:class:`EnsembleResult`) is an ``xarray.Dataset``
over ``case`` and ``time`` (kept in memory or written to Zarr / netCDF as cases
finish), a summary DataFrame, reductions over cases, and a one-call retry of the
cases that failed.

Modules: :mod:`.cases` (case tables, grid, sampling), :mod:`.model` (a System
packed with its compiled code for workers), :mod:`.worker` (one case, one
batch), :mod:`.backends` (serial, threads, Dask), :mod:`.faults` (statuses),
:mod:`.store` (memory, Zarr, netCDF), :mod:`.results`, :mod:`.run`.
Needs the ``ensemble`` extra: ``pip install 'dalembert[ensemble]'``.
"""

from .cases import grid, sample
from .faults import STATUSES, SUCCESS
from .results import EnsembleResult
from .run import simulate_many

__all__ = ["STATUSES", "SUCCESS", "EnsembleResult", "grid", "sample", "simulate_many"]
