"""Ensembles of samples: seeds, storage, resume, local and Dask execution (``docs/runs.md``).

- :class:`Study` — the physics parameters (φ values, N values, samples, δγ, γ_max, seed, ...);
- :func:`sample_seed` — a sample's seed from the master seed and (φ, N, index), nothing else;
- :func:`run_study` — run or resume a study in a run directory, locally or on Dask;
- :func:`open_run` — the stored traces as an ``xarray.Dataset`` indexed by φ, N, sample, step;
- :func:`add_run_arguments`, :func:`sizes_per_run`, :func:`check_figure_path` — the analysis
  scripts' runs, their ``--n`` and their ``--figure``.
"""

from jamlab.runs.arguments import (
    add_run_arguments,
    check_figure_path,
    open_pressure_run,
    open_study,
    sizes_per_run,
)
from jamlab.runs.execute import Execution, RunSummary, run_study
from jamlab.runs.load import open_run, prepared_packing, read_sample
from jamlab.runs.seeds import sample_seed, sample_seed_sequence
from jamlab.runs.storage import RunDir, RunError
from jamlab.runs.study import SampleKey, Study, load_toml
from jamlab.runs.tasks import SampleFailed, SampleFailure, SampleResult

__all__ = [
    "Execution",
    "RunDir",
    "RunError",
    "RunSummary",
    "SampleFailed",
    "SampleFailure",
    "SampleKey",
    "SampleResult",
    "Study",
    "add_run_arguments",
    "check_figure_path",
    "open_pressure_run",
    "open_study",
    "load_toml",
    "open_run",
    "prepared_packing",
    "read_sample",
    "run_study",
    "sample_seed",
    "sample_seed_sequence",
    "sizes_per_run",
]
