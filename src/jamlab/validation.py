"""One validation layer for user-given parameters, shared by the command line, the TOML study
files (:mod:`jamlab.runs.study`) and the Python API.

Every checker takes the parameter's user-facing ``name`` (``"--dgamma"`` on the command line,
``"dgamma"`` in a study) and the raw value (a number, or a string from the command line or a
TOML file), and returns the value converted to its type or raises ``ValueError`` with a one-line
message naming the parameter. The bounds (``docs/formats.md``, "Limits"):

- seeds: integers in ``[0, 2^64 − 1]`` (what ``numpy.random.default_rng`` and the 64-bit HDF5
  attributes hold);
- packing fractions: ``0 < φ < 1``; dimension ``2 ≤ d ≤ MAX_DIM`` with a box side ``L > 2``
  (twice the cut-off) at the requested ``(N, d, φ)``;
- strains: finite, ``|γ| ≤ MAX_STRAIN``; an AQS run: ``0 < δγ < γ_max``, at most ``MAX_STEPS``
  steps, and ``δγ`` resolved by float64 at the run's largest strain (``δγ ≥ STRAIN_RESOLUTION ·
  max(1, |γ_0| + γ_max)``), so that every step really changes the strain.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

__all__ = [
    "SEED_MAX",
    "MAX_STEPS",
    "MAX_ITER",
    "MAX_SAMPLES",
    "MAX_STRAIN",
    "STRAIN_RESOLUTION",
    "FLOPPY",
    "VOLUME_GUESSES",
    "DEFAULT_VOLUME_GUESS",
    "DEFAULT_PTOL",
    "VOLUME_GUESS_BEFORE",
    "floppy",
    "volume_guess",
    "MAX_DIM",
    "integer",
    "dimension",
    "number",
    "positive",
    "seed",
    "shape",
    "packing_fraction",
    "strain",
    "strain_steps",
    "box_fits",
    "is_real",
    "is_integer",
    "save_every",
    "pressure_tolerance",
    "format_version",
    "above_jamming",
    "sizes",
    "pair_exponent",
]

SEED_MAX = 2**64 - 1
"""Largest seed (``numpy.random.default_rng`` takes any ``int >= 0``, the files store 64 bits)."""

MAX_STEPS = 10_000_000
"""Largest number of AQS steps of one run (the trace is held in memory: ~1 GB at this size)."""

MAX_ITER = 10**12
"""Largest iteration cap of one minimisation (``--max-iter``, ``max_iter``): FIRE's slowest steps
take ~10^6 iterations, and 10^12 would run for days even at N = 2; above 2^63 the compiled
kernels cannot take the number at all."""

MAX_SAMPLES = 1_000_000
"""Largest number of samples per (φ, N) of one run (one file each; a run of 10^20 samples wrote its
manifest and then hung enumerating them)."""

MAX_DIM = 64
"""Largest space dimension ``d``. The ball volume ``v_d(1/2)`` is ~1.7e-39 at ``d = 64`` (it
underflows to 0 at ``d = 340`` and ``Γ(d/2 + 1)`` overflows at ``d = 342``); a box of side
``L > 2`` (twice the cut-off) at any ``φ`` already needs astronomically many spheres far below
the cap, so it only turns absurd values into a one-line error."""

MAX_STRAIN = 1e6
"""Largest accumulated strain ``|γ|`` of a configuration or a run."""

STRAIN_RESOLUTION = 2.0**-40
"""Smallest ``δγ / max(1, |γ|)``: below it ``γ + δγ`` loses more than ~12 bits of ``δγ``."""


FLOPPY = ("fire", "project")
"""How a constant-volume step from an unjammed minimum is taken (``docs/aqs.md``): ``"fire"``
(the usual strategies; the default) or ``"project"`` (the nearest overlap-free configuration)."""

VOLUME_GUESSES = ("elastic", "always", "never")
"""Where a fixed-pressure AQS step starts its box side
(:func:`jamlab.spheres.barostat.box_side_guess`): ``"elastic"`` (the default) — the linear
extrapolation of the last two minima when the last step was not a candidate jump, else the
current side; ``"always"`` — the extrapolation after every step (the rule of the runs and traces
made before the choice existed); ``"never"`` — the current side."""

DEFAULT_PTOL = 1e-6
"""Relative pressure tolerance of a fixed-pressure minimum that does not name one
(``|p − p_t| ≤ max(ptol p_t, p_floor)``, :func:`jamlab.spheres.barostat.minimize_enthalpy`)."""

DEFAULT_VOLUME_GUESS = "elastic"
"""The rule of a fixed-pressure run that does not name one."""

VOLUME_GUESS_BEFORE = "always"
"""The rule of a fixed-pressure run directory or trace that records none (made before it)."""


def floppy(value: Any, name: str = "floppy") -> str:
    """One of :data:`FLOPPY`, or ``ValueError`` naming the choices."""
    if value not in FLOPPY:
        raise _reject(name, " or ".join(repr(c) for c in FLOPPY), value)
    return value


def volume_guess(value: Any, name: str = "volume_guess") -> str:
    """One of :data:`VOLUME_GUESSES`, or ``ValueError`` naming the choices."""
    if value not in VOLUME_GUESSES:
        raise _reject(name, " or ".join(repr(c) for c in VOLUME_GUESSES), value)
    return value


def _reject(name: str, what: str, value: Any) -> ValueError:
    return ValueError(f"{name} must be {what}, got {value!r}")


def is_real(value: Any) -> bool:
    """A real number given to a library function: a Python or numpy integer or float, never a
    ``bool`` or a string. Callers convert it with ``float()`` after their range checks, so a numpy
    ``float32`` argument is computed with in float64 (its value, widened exactly)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_integer(value: Any) -> bool:
    """An integer given to a library function: a Python or numpy integer, never a ``bool``, a
    float or a string (:func:`integer` takes those too, for the command line and manifests)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def integer(
    name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None
) -> int:
    """An integer (``int``, an integral float or a decimal string; never a ``bool``) in
    ``[minimum, maximum]``."""
    if minimum is not None and maximum is not None:
        bounds = f" in [{minimum}, {maximum}]"
    elif minimum is not None:
        bounds = f" >= {minimum}"
    elif maximum is not None:
        bounds = f" <= {maximum}"
    else:
        bounds = ""
    what = f"an integer{bounds}"
    if isinstance(value, bool):
        raise _reject(name, what, value)
    if isinstance(value, int):
        as_int = value
    elif isinstance(value, float):
        if not (math.isfinite(value) and value == int(value)):
            raise _reject(name, what, value)
        as_int = int(value)
    elif isinstance(value, str):
        text = value.strip()
        try:
            as_int = int(text)
        except ValueError:
            try:
                f = float(text)
            except ValueError:
                raise _reject(name, what, value) from None
            if not (math.isfinite(f) and f == int(f)):
                raise _reject(name, what, value) from None
            as_int = int(f)
    else:
        try:
            import numpy as np

            if isinstance(value, np.integer):
                as_int = int(value)
            else:
                raise TypeError
        except TypeError:
            raise _reject(name, what, value) from None
    if (minimum is not None and as_int < minimum) or (maximum is not None and as_int > maximum):
        raise _reject(name, what, as_int)
    return as_int


def shape(name: str, value: Any) -> int | tuple[int, ...]:
    """An array size for numpy: an integer ``>= 0`` or a tuple of them."""
    if isinstance(value, tuple):
        return tuple(integer(name, v, minimum=0) for v in value)
    return integer(name, value, minimum=0)


def dimension(name: str, value: Any) -> int:
    """A space dimension: an integer in ``[2, MAX_DIM]``."""
    return integer(name, value, minimum=2, maximum=MAX_DIM)


def number(
    name: str,
    value: Any,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """A finite float (a number or a numeric string; never a ``bool``) in the interval given by
    ``low``/``high`` (closed unless ``low_open``/``high_open``)."""
    lo = "" if low is None else ("(" if low_open else "[") + f"{low:g}"
    hi = "" if high is None else f"{high:g}" + (")" if high_open else "]")
    if low is not None and high is not None:
        what = f"a finite number in {lo}, {hi}"
    elif low is not None:
        what = f"a finite number {'>' if low_open else '>='} {low:g}"
    elif high is not None:
        what = f"a finite number {'<' if high_open else '<='} {high:g}"
    else:
        what = "a finite number"
    if isinstance(value, bool):
        raise _reject(name, what, value)
    try:
        x = float(value.strip() if isinstance(value, str) else value)
    except (TypeError, ValueError, OverflowError):
        raise _reject(name, what, value) from None
    if not math.isfinite(x):
        raise _reject(name, what, value)
    if low is not None and (x < low or (low_open and x == low)):
        raise _reject(name, what, value)
    if high is not None and (x > high or (high_open and x == high)):
        raise _reject(name, what, value)
    return x


def positive(name: str, value: Any, *, maximum: float | None = None) -> float:
    """A finite float ``> 0`` (and ``<= maximum`` if given)."""
    return number(name, value, low=0.0, low_open=True, high=maximum)


def save_every(value: Any, out: Any = None, *, needs_out: bool = False) -> None:
    """A checkpoint interval given to a library shear: ``None`` or an integer in
    ``[1, MAX_STEPS]``; with ``needs_out``, only together with an output path ``out``."""
    if value is not None and not (is_integer(value) and 1 <= value <= MAX_STEPS):
        raise ValueError(f"save_every must be an integer in [1, {MAX_STEPS}], "
                         f"got save_every={value!r}")
    if needs_out and value is not None and out is None:
        raise ValueError("save_every needs an output path (out=...)")


def pressure_tolerance(ptol: Any, pressure: Any, *, applies: str) -> float:
    """The command-line ``--ptol``: ``None`` means :data:`DEFAULT_PTOL`; given, it must be
    positive and come with ``--pressure`` (``applies`` names what it applies to)."""
    if ptol is None:
        return DEFAULT_PTOL
    value = positive("--ptol", ptol)
    if pressure is None:
        raise ValueError(f"--ptol applies to {applies}: give --pressure too")
    return value


def format_version(where: Any, value: Any, newest: int, what: str) -> int:
    """The ``format_version`` of a file or manifest ``where`` that this jamlab reads: an integer
    in ``[1, newest]``; anything else (a newer jamlab's file, a damaged one) is a ``ValueError``
    naming ``what`` is read (e.g. ``"trace files"``)."""
    if not (is_integer(value) and 1 <= value <= newest):
        shown = value.item() if hasattr(value, "item") else value  # a numpy scalar as a number
        raise ValueError(f"{where} has format_version {shown!r}: this jamlab reads {what} of "
                         f"version 1 to {newest}")
    return int(value)


def seed(name: str, value: Any) -> int:
    """A seed: an integer in ``[0, SEED_MAX]``."""
    return integer(name, value, minimum=0, maximum=SEED_MAX)


def packing_fraction(name: str, value: Any) -> float:
    """A packing fraction ``0 < φ < 1``."""
    return number(name, value, low=0.0, high=1.0, low_open=True, high_open=True)


PHI_CLEARLY_UNJAMMED_3D = 0.62
"""In 3D no monodisperse random packing jams below ~0.63 (O'Hern et al. 2003: φ_J ≈ 0.639): a
direct (over-jammed, UNSAT) preparation there only returns an unjammed, zero-pressure state."""


def above_jamming(name: str, phi: float, dim: int) -> float:
    """``phi`` for an over-jammed (UNSAT) preparation: refused in 3D below
    :data:`PHI_CLEARLY_UNJAMMED_3D` (other dimensions: the preparation's own stopping rule)."""
    if dim == 3 and phi < PHI_CLEARLY_UNJAMMED_3D:
        raise ValueError(
            f"{name} {phi} is below jamming (phi_J ~ 0.64 in 3D): use 'jamming' or a value >= "
            f"{PHI_CLEARLY_UNJAMMED_3D}"
        )
    return phi


def strain(name: str, value: Any) -> float:
    """An accumulated strain: finite, ``|γ| <= MAX_STRAIN``."""
    return number(name, value, low=-MAX_STRAIN, high=MAX_STRAIN)


def strain_steps(
    dgamma: Any,
    gamma_max: Any,
    gamma0: float = 0.0,
    *,
    names: tuple[str, str] = ("dgamma", "gamma_max"),
) -> int:
    """``M = round(γ_max / δγ)`` AQS steps from strain ``gamma0``; ``ValueError`` unless
    ``0 < δγ < γ_max``, ``M <= MAX_STEPS``, the last strain ``γ_0 + M δγ`` within ``MAX_STRAIN``
    and ``δγ`` is resolved at strain ``|γ_0| + γ_max``."""
    dg_name, gm_name = names
    dg = positive(dg_name, dgamma, maximum=MAX_STRAIN)
    gm = positive(gm_name, gamma_max, maximum=MAX_STRAIN)
    g0 = strain("the start strain", gamma0)
    if not gm > dg:
        raise ValueError(f"{dg_name} must be smaller than {gm_name}, got {dg!r} >= {gm!r}")
    ratio = gm / dg
    if not ratio <= MAX_STEPS:
        raise ValueError(
            f"{gm_name}/{dg_name} = {ratio:.3g} steps exceeds the limit of {MAX_STEPS} steps "
            "of one run"
        )
    end = g0 + round(ratio) * dg
    if not abs(end) <= MAX_STRAIN:
        raise ValueError(
            f"the run would end at strain {end:.10g}, beyond the limit |strain| <= "
            f"{MAX_STRAIN:g} (start strain {g0:.10g})"
        )
    scale = max(1.0, abs(g0) + gm)
    if dg < STRAIN_RESOLUTION * scale:
        raise ValueError(
            f"{dg_name} = {dg!r} is below the float64 resolution of strains near {scale:.3g} "
            f"(need {dg_name} >= {STRAIN_RESOLUTION * scale:.3g})"
        )
    return int(round(ratio))


def box_fits(n: int, dim: int, phi: float, sizes: str = "mono") -> None:
    """``ValueError`` unless ``N`` spheres (diameters ``sizes``) at ``φ`` in ``d`` dimensions
    give a valid box (``Packing``'s rule: side ``L > 2 max D``, twice the cut-off); checked
    before any computation."""
    from jamlab.spheres.box import Box
    from jamlab.spheres.state import box_length_for_diameters, check_box_side, size_distribution

    n = integer("N", n, minimum=2)
    dim = dimension("dim", dim)
    phi = packing_fraction("phi", phi)
    diam = size_distribution(n, sizes)
    # Packing's own rule; positions are irrelevant to it
    length = box_length_for_diameters(diam, dim, phi)
    check_box_side(Box(length, dim, 0.0), diam)


def sizes(name: str, value: Any) -> str:
    """A size specification ``mono | bidisperse | polydisperse[:w]`` (``SPEC.md`` §5)."""
    from jamlab.spheres.state import parse_sizes

    if not isinstance(value, str):
        raise ValueError(f"{name} must be mono, bidisperse or polydisperse[:w], got {value!r}")
    parse_sizes(value)
    return value.strip()


def pair_exponent(name: str, value: Any) -> float:
    """The pair exponent ``α`` of ``V = (1 − r/σ)^α``: a finite number ``> 1``."""
    from jamlab.spheres.pair import check_alpha

    if isinstance(value, bool):
        raise ValueError(f"{name} must be a number > 1, got {value!r}")
    return check_alpha(value)
