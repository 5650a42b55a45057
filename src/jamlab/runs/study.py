"""A study: the physics parameters of an ensemble, validated once, from the CLI or a TOML file.

A study is the product ``φ values × N values × samples``; each sample is prepared at its ``φ``
(``"jamming"``: a jammed packing by compression/decompression; a number: an UNSAT packing
minimised at that packing fraction) and sheared quasi-statically with strain step ``dgamma`` up to
``gamma_max``. Execution-only options (workers, scheduler, cluster, quiet) are *not* part of a
study: they may change between a run and its resumption without changing any result.

TOML layout (``examples/study.toml``): physics keys at the top level (the names of the
:class:`Study` fields; ``phi`` and ``n`` are lists), ``out`` for the run directory, and an
optional ``[execution]`` table with ``workers``, ``scheduler`` or ``cluster`` and ``[slurm]``.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from jamlab import validation

__all__ = [
    "PHI_KEYWORDS",
    "Study",
    "SampleKey",
    "phi_label",
    "parse_phi",
    "load_toml",
    "TASKS",
]

PHI_KEYWORDS = ("jamming",)
"""Non-numeric φ values: ``"jamming"`` = prepare at the jamming point (φ = the sample's φ_J)."""

TASKS = ("aqs", "toy")
"""Built-in sample tasks: ``aqs`` = prepare + AQS shear (the physics); ``toy`` = a cheap,
deterministic stand-in used to test the run machinery (see :mod:`jamlab.runs.tasks`)."""


def parse_phi(value: str | float | int) -> str | float:
    """``"jamming"`` or a packing fraction ``0 < φ < 1``; ``ValueError`` otherwise."""
    if isinstance(value, bool):
        raise ValueError(f"phi must be a number > 0 or one of {PHI_KEYWORDS}, got {value!r}")
    if isinstance(value, int | float):
        phi = value
    elif not isinstance(value, str):
        raise ValueError(f"phi must be a number or one of {PHI_KEYWORDS}, got {value!r}")
    else:
        text = str(value).strip()
        if text.lower() in PHI_KEYWORDS:
            return text.lower()
        try:
            phi = float(text)
        except ValueError:
            raise ValueError(
                f"unknown phi {text!r}: give a packing fraction > 0 or one of "
                f"{', '.join(PHI_KEYWORDS)}"
            ) from None
    return validation.packing_fraction("phi", phi)


def phi_label(phi: str | float) -> str:
    """The label of a φ value in paths and in :func:`jamlab.runs.open_run`: the keyword itself,
    or the shortest ``repr`` of the float (``0.75``, ``0.8``) so that it round-trips exactly."""
    return phi if isinstance(phi, str) else repr(float(phi))


def _phi_order(phi: str | float) -> tuple[int, float]:
    return (0, 0.0) if isinstance(phi, str) else (1, float(phi))


@dataclass(frozen=True)
class SampleKey:
    """One sample of a study: its φ (keyword or number), particle number and index."""

    phi: str | float
    n: int
    index: int

    @property
    def phi_label(self) -> str:
        return phi_label(self.phi)

    def relpath(self) -> str:
        """Path of the sample's file inside the run directory (POSIX separators)."""
        return f"samples/phi={self.phi_label}/N={self.n}/sample-{self.index:05d}.h5"


def _as_list(value: Any) -> list[Any]:
    if isinstance(value, str | int | float):
        return [value]
    return list(value)


@dataclass(frozen=True)
class Study:
    """The physics parameters of an ensemble (everything that changes results).

    - ``phi``: tuple of packing fractions and/or ``"jamming"``; stored sorted (keyword first,
      then ascending numbers), duplicates refused.
    - ``n``: particle numbers, sorted ascending, each ``>= 2``.
    - ``samples``: samples per ``(φ, N)``, indices ``0 .. samples−1``.
    - ``dgamma``, ``gamma_max``: AQS strain step and final strain, ``0 < dgamma < gamma_max``,
      at most :data:`jamlab.validation.MAX_STEPS` steps.
    - ``seed``: master seed (integer in ``[0, 2^64 − 1]``); see :mod:`jamlab.runs.seeds`.
    - ``dim``: space dimension, ``2 .. 64`` (:data:`jamlab.validation.MAX_DIM`).
    - ``p_target``: target pressure of the jamming protocol (``φ = "jamming"`` only).
    - ``force_tol``: FIRE convergence, largest per-particle force ``|F_i|`` (SPEC §3).
    - ``sizes``: diameters, ``"mono"``, ``"bidisperse"`` or ``"polydisperse[:w]"`` (SPEC §5,
      :mod:`jamlab.spheres.state`); ``alpha``: pair exponent, ``V = (1 − r/σ_ij)^α``, ``> 1``.
    - ``pressure``: ``None`` (default): AQS at constant volume (the paper's protocol); a number:
      AQS at this fixed pressure (``shear(..., pressure=...)``; the prepared packing is first
      brought to it). Stored only when set, so earlier run directories keep their study.
    - ``floppy``: how constant-volume AQS takes a step from an unjammed minimum —
      ``"fire"`` (default: the usual strategies, FIRE where they end) or ``"project"`` (the
      overlap-free configuration nearest to the affine start;
      :class:`jamlab.spheres.aqs.AQSParameters`, ``docs/aqs.md``). Stored only when not
      ``"fire"``, so earlier run directories keep their study.
    - ``volume_guess``: fixed pressure only, where each step starts its box side
      (:data:`jamlab.validation.VOLUME_GUESSES`; default ``"elastic"``: extrapolated across
      elastic steps only). Stored with every fixed-pressure study; a run directory whose
      manifest has a pressure and no ``volume_guess`` was made by the rule of its time,
      ``"always"`` (:meth:`jamlab.runs.RunDir.study`), so it is not resumed by another.
    - ``checkpoint_every``: ``0`` (default): a sample is computed in one go; ``k >= 1``: its
      shear is saved every ``k`` steps (with the prepared packing) in the run directory's
      ``checkpoints/``, and a sample interrupted mid-way (a killed worker, the end of a SLURM
      allocation) resumes from its last save instead of from the start (``docs/runs.md``).
      It changes results at rounding level (each save is a restart point of the solver state,
      as ``shear(save_every=k)``), hence part of the study; an interrupted and an
      uninterrupted sample of the same study are identical bit for bit. Stored only when set.
    - ``task``: ``"aqs"`` (prepare + shear) or ``"toy"`` (machinery tests only).
    """

    phi: tuple[str | float, ...]
    n: tuple[int, ...]
    samples: int
    dgamma: float
    gamma_max: float
    seed: int = 0
    dim: int = 3
    p_target: float = 1e-7
    force_tol: float = 1e-12
    task: str = "aqs"
    sizes: str = "mono"
    alpha: float = 2.0
    pressure: float | None = None
    floppy: str = "fire"
    checkpoint_every: int = 0
    volume_guess: str | None = None

    def __post_init__(self) -> None:
        phis = [parse_phi(p) for p in _as_list(self.phi)]
        if not phis:
            raise ValueError("at least one phi value is needed")
        labels = [phi_label(p) for p in phis]
        dupes = sorted({lab for lab in labels if labels.count(lab) > 1})
        if dupes:
            raise ValueError(f"phi values given twice: {', '.join(dupes)}")
        object.__setattr__(self, "phi", tuple(sorted(phis, key=_phi_order)))

        ns = [validation.integer("n", v, minimum=2) for v in _as_list(self.n)]
        if not ns:
            raise ValueError("at least one N value is needed")
        if len(set(ns)) != len(ns):
            raise ValueError(f"N values given twice: {sorted({v for v in ns if ns.count(v) > 1})}")
        object.__setattr__(self, "n", tuple(sorted(ns)))

        object.__setattr__(self, "samples", validation.integer(
            "samples", self.samples, minimum=1, maximum=validation.MAX_SAMPLES))
        object.__setattr__(self, "seed", validation.seed("seed", self.seed))
        object.__setattr__(self, "dim", validation.dimension("dim", self.dim))
        if self.task == "aqs":  # an over-jammed preparation below jamming fails every sample
            for p in phis:
                if not isinstance(p, str):
                    validation.above_jamming("phi", p, self.dim)
        for name in ("dgamma", "gamma_max", "p_target", "force_tol"):
            object.__setattr__(self, name, validation.positive(name, getattr(self, name)))
        validation.strain_steps(self.dgamma, self.gamma_max)
        object.__setattr__(self, "sizes", validation.sizes("sizes", self.sizes))
        object.__setattr__(self, "alpha", validation.pair_exponent("alpha", self.alpha))
        if self.pressure is not None:
            object.__setattr__(self, "pressure", validation.positive("pressure", self.pressure))
        validation.floppy(self.floppy)
        if self.floppy != "fire" and self.pressure is not None:
            raise ValueError("floppy applies to constant-volume runs only, not with pressure")
        if self.pressure is None and self.volume_guess is not None:
            raise ValueError("volume_guess applies to fixed-pressure runs only: give pressure too")
        if self.pressure is not None:
            guess = (validation.DEFAULT_VOLUME_GUESS if self.volume_guess is None
                     else self.volume_guess)
            object.__setattr__(self, "volume_guess", validation.volume_guess(guess))
        object.__setattr__(
            self, "checkpoint_every", validation.integer(
                "checkpoint_every", self.checkpoint_every, minimum=0, maximum=validation.MAX_STEPS)
        )
        if not isinstance(self.task, str) or self.task not in TASKS:
            raise ValueError(f"unknown task {self.task!r}: valid tasks are {', '.join(TASKS)}")

    # -- the samples ------------------------------------------------------------------------

    def check_geometry(self) -> None:
        """``ValueError`` unless every ``(φ, N)`` gives a valid box in ``dim`` dimensions (side
        ``L > 2``; at jamming, at the protocol's starting ``φ_init``), checked before a run
        writes anything. Imports the physics (:func:`jamlab.validation.box_fits`)."""
        if self.task != "aqs":
            return
        import inspect

        from jamlab.spheres.packing import jam

        phi_init = inspect.signature(jam).parameters["phi_init"].default
        for phi in self.phi:
            for n in self.n:
                validation.box_fits(
                    n, self.dim, phi_init if isinstance(phi, str) else phi, self.sizes
                )

    def keys(self) -> list[SampleKey]:
        """All samples, φ-major then N then index (the order of submission, not of results)."""
        return [
            SampleKey(phi, n, i) for phi in self.phi for n in self.n for i in range(self.samples)
        ]

    @property
    def n_samples(self) -> int:
        return len(self.phi) * len(self.n) * self.samples

    @property
    def n_steps(self) -> int:
        """AQS steps per sample, ``round(γ_max / δγ)``."""
        return round(self.gamma_max / self.dgamma)

    # -- (de)serialisation ------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """JSON/TOML-ready dict (lists for tuples); ``Study(**d)`` round-trips."""
        d = asdict(self)
        d["phi"] = list(self.phi)
        d["n"] = list(self.n)
        if d["pressure"] is None:  # constant volume: the study of earlier run directories
            del d["pressure"]
        if d["floppy"] == "fire":  # the default: the study of earlier run directories
            del d["floppy"]
        if d["checkpoint_every"] == 0:  # the default: the study of earlier run directories
            del d["checkpoint_every"]
        if d["volume_guess"] is None:  # constant volume
            del d["volume_guess"]
        return d

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Study:
        """Build from a mapping with the field names; unknown keys are an error."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(
                f"unknown study parameter(s) {', '.join(unknown)}; "
                f"valid: {', '.join(sorted(names))}"
            )
        missing = [k for k in ("phi", "n", "samples", "dgamma", "gamma_max") if k not in data]
        if missing:
            raise ValueError(f"missing study parameter(s): {', '.join(missing)}")
        return cls(**dict(data))

    def differences(self, other: Study) -> list[str]:
        """Human-readable ``name: this != other`` for each differing parameter."""
        # every field, the defaults too (to_dict leaves some out to match earlier studies)
        a, b = asdict(self), asdict(other)
        return [f"{k}: {a[k]!r} != {b[k]!r}" for k in a if a[k] != b[k]]


def load_toml(path: str | os.PathLike) -> tuple[dict[str, Any], str | None, dict[str, Any]]:
    """Read a study file: ``(study parameters, out, execution options)``.

    The study parameters are returned unvalidated (so command-line flags can override them before
    :class:`Study` validates the merged set); ``out`` is resolved relative to the file's folder.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such study file: {path}")
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot parse study file {path}: {exc}") from None
    execution = data.pop("execution", {})
    if not isinstance(execution, dict):
        raise ValueError(f"[execution] in {path} must be a table")
    out = data.pop("out", None)
    if out is not None:
        out = str(path.parent / str(out)) if not Path(str(out)).is_absolute() else str(out)
    return data, out, execution


def merge(base: Mapping[str, Any], overrides: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    """``base`` updated by the overrides whose value is not ``None``."""
    merged = dict(base)
    for key, value in overrides:
        if value is not None:
            merged[key] = value
    return merged
