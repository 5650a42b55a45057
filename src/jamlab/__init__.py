"""jamlab: static avalanches in jammed soft spheres and mean-field glasses.

Sub-packages (data flows one way):

- :mod:`jamlab.theory`   Parisi functions, the mean-field jump distribution, cascade sampler
- :mod:`jamlab.spheres`  soft spheres: Lees–Edwards box, neighbours, forces, FIRE, packings, AQS
- :mod:`jamlab.analysis` pure functions on arrays: avalanches, power-law fits, moduli moments
- :mod:`jamlab.runs`     ensembles of samples: seeds, storage, resume, local and Dask execution

Conventions (units, signs, definitions) are those of ``SPEC.md``; see ``docs/``.
"""

__all__ = ["__version__"]


def __getattr__(name: str) -> str:
    # ``__version__`` on first use: ``importlib.metadata`` costs start-up time of every command
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("jamlab")
        except PackageNotFoundError:  # running from a source tree without installation
            value = "0.0.0+unknown"
        globals()["__version__"] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
