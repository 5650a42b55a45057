"""jamlab: static avalanches in jammed soft spheres and mean-field glasses.

Sub-packages (data flows one way):

- :mod:`jamlab.theory`   Parisi functions, the mean-field jump distribution, cascade sampler
- :mod:`jamlab.spheres`  soft spheres: Lees–Edwards box, neighbours, forces, FIRE, packings, AQS
- :mod:`jamlab.analysis` pure functions on arrays: avalanches, power-law fits, moduli moments
- :mod:`jamlab.runs`     ensembles of samples: seeds, storage, resume, local and Dask execution

Conventions (units, signs, definitions) are those of ``SPEC.md``; see ``docs/``.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("jamlab")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
