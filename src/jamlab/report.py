"""The reproduction report: a table of numbers against the paper and figures, as Markdown and HTML.

A report is a list of :class:`Row` (quantity, reference value, our value with its uncertainty,
sample counts, verdicts) and a list of :class:`Figure` (a PNG file relative to the report
directory and a caption). :func:`write_report` writes ``report.md``, ``index.html`` (plain HTML,
images linked relatively so the directory can be moved or served as is) and ``results.json``
(every number of the table, machine-readable).

Verdict rules (:func:`verdict`, :func:`target_verdict`), written once here and quoted in the
report:

- **agrees** if ``|ours − reference| ≤ 2·sqrt(σ_ours² + σ_ref²)`` (σ are 1σ uncertainties; a
  theoretical value has ``σ_ref = 0``), **differs** otherwise; the distance in units of the
  combined σ is printed with it;
- **inconclusive** instead of *agrees* when that window ``±2σ`` is at least as wide as the
  reference itself (``2σ ≥ |reference|``, reference ≠ 0): the number would also have "agreed"
  with 0 and with twice the reference, so the comparison says nothing about it (e.g. a
  small-force exponent ``0.07 [−0.80, 0.94]`` against 0.42);
- a **target** (the issue's acceptance windows, e.g. ``|τ − 1| ≤ 0.15``) is **met** if
  ``|ours − reference| ≤ tolerance``;
- **no data** when our value, or a measured reference, could not be computed (too few samples
  or events).
"""

from __future__ import annotations

import html
import json
import math
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from jamlab.files import atomic_write_text

__all__ = [
    "AGREEMENT_SIGMAS",
    "Comparison",
    "Figure",
    "Row",
    "VERDICT_RULES",
    "format_value",
    "json_safe",
    "target_verdict",
    "verdict",
    "write_report",
]

AGREEMENT_SIGMAS = 2.0
"""Agreement window in units of the combined 1σ uncertainty."""

VERDICT_RULES = (
    f"**agrees** if |ours − reference| ≤ {AGREEMENT_SIGMAS:g}·√(σ_ours² + σ_ref²) (1σ "
    "uncertainties; a theoretical value has σ_ref = 0), **differs** otherwise (the distance in "
    "units of the combined σ is given); **inconclusive** instead of agrees when that ±2σ window "
    "is at least as wide as the reference itself (it would also have agreed with 0 and with "
    "twice the reference); a **target** (the acceptance windows of issue 8) is "
    "**met** if |ours − reference| ≤ its tolerance; **no data** if our value could not be "
    "computed. Our σ: for fitted exponents, half the width of the 95 % bootstrap interval "
    "divided by 1.96; for means, the standard error over samples; for slopes, the fit's "
    "standard error."
)


@dataclass(frozen=True)
class Comparison:
    """One reference for a row: ``label`` (e.g. "theory"), ``value`` and its 1σ ``error``
    (0 for an exact theoretical value), or a ``tolerance`` window (a target) instead."""

    label: str
    value: float
    error: float = 0.0
    tolerance: float | None = None

    def judge(self, ours: float, ours_err: float) -> str:
        """The verdict of ``ours ± ours_err`` against this reference (module docstring)."""
        if self.tolerance is not None:
            return target_verdict(ours, self.value, self.tolerance, self.label)
        return f"{self.label}: {verdict(ours, ours_err, self.value, self.error)}"


@dataclass(frozen=True)
class Row:
    """A table row. ``value``/``error`` are ours (1σ; NaN when unavailable) and ``value_text``
    how the report prints them (e.g. with the bootstrap interval); ``reference_text`` is the
    paper's (or the theory's) value as quoted; ``comparisons`` produce the verdicts."""

    quantity: str
    reference_text: str
    value: float
    error: float
    value_text: str
    samples: str
    comparisons: tuple[Comparison, ...] = ()
    note: str = ""
    section: str = ""  # "" = the main table; otherwise a table of its own under this heading

    @property
    def verdicts(self) -> list[str]:
        return [c.judge(self.value, self.error) for c in self.comparisons]

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["verdicts"] = self.verdicts
        return d


@dataclass(frozen=True)
class Figure:
    """A figure of the report: ``path`` relative to the report directory, a ``title`` and a
    ``caption`` (what is plotted, from which data, with which parameters)."""

    key: str
    title: str
    path: str
    caption: str


@dataclass
class ReportMeta:
    """Header information: title, scale, wall time, parameters (free-form ``key: value``)."""

    title: str
    scale: str
    seconds: float
    parameters: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    sections: dict[str, str] = field(default_factory=dict)  # heading → introductory text


def _sections(rows: Sequence[Row]) -> list[tuple[str, list[Row]]]:
    """The rows grouped by section, the main table ("") first, then in order of appearance."""
    order = [""] + list(dict.fromkeys(r.section for r in rows if r.section))
    return [(name, [r for r in rows if r.section == name]) for name in order]


def verdict(value: float, error: float, reference: float, reference_err: float = 0.0) -> str:
    """``"agrees (1.2σ)"``, ``"differs (3.4σ)"``, ``"inconclusive (0.8σ; …)"`` or
    ``"no data"`` by the rules of the module docstring (``AGREEMENT_SIGMAS`` combined standard
    deviations)."""
    if not all(math.isfinite(x) for x in (value, error, reference, reference_err)):
        return "no data"  # ours or the reference (e.g. a fit that could not be made) missing
    sigma = math.hypot(error, reference_err)
    diff = abs(value - reference)
    if sigma == 0.0:
        return "agrees (exact)" if diff == 0.0 else "differs (σ = 0)"
    k = diff / sigma
    if k > AGREEMENT_SIGMAS:
        return f"differs ({k:.2f}σ)"
    window = AGREEMENT_SIGMAS * sigma
    if reference != 0.0 and window >= abs(reference):
        return (
            f"inconclusive ({k:.2f}σ; ±{AGREEMENT_SIGMAS:g}σ = ±{window:.2g} is as wide as the "
            "reference)"
        )
    return f"agrees ({k:.2f}σ)"


def target_verdict(value: float, reference: float, tolerance: float, label: str = "") -> str:
    """``"target |ours − 1| ≤ 0.15: met"`` or ``"... not met"`` (``"no data"`` for NaN)."""
    name = label or f"|ours − {reference:g}| ≤ {tolerance:g}"
    if not math.isfinite(value):
        return f"target {name}: no data"
    return f"target {name}: {'met' if abs(value - reference) <= tolerance else 'not met'}"


def format_value(value: float, error: float, digits: int = 2) -> str:
    """``"1.235 ± 0.057"`` with ``digits`` significant digits of the error (``"n/a"`` for NaN)."""
    if not math.isfinite(value):
        return "n/a"
    if not math.isfinite(error) or error <= 0:
        return f"{value:.6g}"
    decimals = max(0, digits - 1 - int(math.floor(math.log10(error))))
    decimals = min(decimals, 12)
    return f"{value:.{decimals}f} ± {error:.{decimals}f}"


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown(rows: Sequence[Row], figures: Sequence[Figure], meta: ReportMeta) -> str:
    """The report as Markdown (GitHub flavour): header, table, rules, figures."""
    lines = [f"# {meta.title}", "", f"Scale **{meta.scale}**, wall time {meta.seconds:.0f} s.", ""]
    for k, v in meta.parameters.items():
        lines.append(f"- {k}: {v}")
    for name, group in _sections(rows):
        if name and not group:
            continue
        lines += ["", f"## {name or 'Numbers'}", ""]
        if name and meta.sections.get(name):
            lines += [meta.sections[name], ""]
        lines += ["| quantity | paper / reference | ours | samples | verdict |",
                  "|---|---|---|---|---|"]
        for r in group:
            verdicts = "; ".join(r.verdicts) + (f" — {r.note}" if r.note else "")
            lines.append(
                "| " + " | ".join(_md_cell(c) for c in
                                 (r.quantity, r.reference_text, r.value_text, r.samples, verdicts))
                + " |"
            )
    lines += ["", f"Verdict rules: {VERDICT_RULES}", ""]
    for note in meta.notes:
        lines += [note, ""]
    lines += ["## Figures", ""]
    for f in figures:
        lines += [f"### {f.title}", "", f"![{f.title}]({f.path})", "", f.caption, ""]
    return "\n".join(lines)


_CSS = """
body { font-family: sans-serif; max-width: 1200px; margin: 2em auto; line-height: 1.4; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { border: 1px solid #999; padding: 4px 8px; vertical-align: top; font-size: 0.92em; }
th { background: #eee; }
td.agrees { background: #e6f4e6; } td.differs { background: #fbe9e7; }
figure { margin: 2em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.92em; color: #333; }
"""


def _strong(text: str) -> str:
    """Escape, then turn ``**x**`` into ``<strong>x</strong>`` (the rules use it)."""
    parts = html.escape(text).split("**")
    return "".join(f"<strong>{p}</strong>" if i % 2 else p for i, p in enumerate(parts))


def html_page(rows: Sequence[Row], figures: Sequence[Figure], meta: ReportMeta) -> str:
    """The report as one well-formed HTML5 page (relative image links, inline CSS)."""
    esc = html.escape
    out = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        f"<title>{esc(meta.title)}</title>",
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        f"<h1>{esc(meta.title)}</h1>",
        f"<p>Scale <strong>{esc(meta.scale)}</strong>, wall time {meta.seconds:.0f} s.</p>",
        "<ul>",
    ]
    out += [f"<li>{esc(k)}: {esc(v)}</li>" for k, v in meta.parameters.items()]
    out.append("</ul>")
    for name, group in _sections(rows):
        if name and not group:
            continue
        out.append(f"<h2>{esc(name or 'Numbers')}</h2>")
        if name and meta.sections.get(name):
            out.append(f"<p>{_strong(meta.sections[name])}</p>")
        out += [
            "<table>",
            "<thead><tr><th>quantity</th><th>paper / reference</th><th>ours</th><th>samples</th>"
            "<th>verdict</th></tr></thead>",
            "<tbody>",
        ]
        for r in group:
            v = r.verdicts
            cls = "differs" if any("differs" in s or "not met" in s for s in v) else (
                "agrees" if v and all("agrees" in s or ": met" in s for s in v) else "")
            verdict_html = "<br>".join(esc(s) for s in v) + (
                f"<br><em>{esc(r.note)}</em>" if r.note else "")
            out.append(
                f"<tr><td>{esc(r.quantity)}</td><td>{esc(r.reference_text)}</td>"
                f"<td>{esc(r.value_text)}</td><td>{esc(r.samples)}</td>"
                f'<td class="{cls}">{verdict_html}</td></tr>'
            )
        out += ["</tbody>", "</table>"]
    out.append(f"<p>Verdict rules: {_strong(VERDICT_RULES)}</p>")
    out += [f"<p>{_strong(n)}</p>" for n in meta.notes]
    out.append("<h2>Figures</h2>")
    for f in figures:
        out += [
            f'<figure id="{esc(f.key)}">',
            f"<h3>{esc(f.title)}</h3>",
            f'<img src="{esc(f.path)}" alt="{esc(f.title)}">',
            f"<figcaption>{esc(f.caption)}</figcaption>",
            "</figure>",
        ]
    out += ["</body>", "</html>", ""]
    return "\n".join(out)


def json_safe(x: Any) -> Any:
    """``x`` with every NaN or infinite float replaced by ``None`` (JSON ``null``), in nested dicts
    and lists (tuples become lists), so that ``json.dumps(..., allow_nan=False)`` writes valid
    JSON."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [json_safe(v) for v in x]
    return x


def write_report(
    out: str | os.PathLike,
    rows: Sequence[Row],
    figures: Sequence[Figure],
    meta: ReportMeta,
    extra: dict[str, Any] | None = None,
) -> dict[str, Path]:
    """Write ``report.md``, ``index.html`` and ``results.json`` into ``out``; return their paths.

    Every figure's file must exist (relative to ``out``): a report never links a missing image.
    ``extra`` (JSON-serialisable) is stored in ``results.json`` under ``"data"``.
    """
    out = Path(out)
    missing = [f.path for f in figures if not (out / f.path).is_file()]
    if missing:
        raise FileNotFoundError(f"figure file(s) missing in {out}: {', '.join(missing)}")
    paths = {"markdown": out / "report.md", "html": out / "index.html",
             "json": out / "results.json"}
    atomic_write_text(paths["markdown"], markdown(rows, figures, meta))
    atomic_write_text(paths["html"], html_page(rows, figures, meta))
    payload = {
        "title": meta.title,
        "scale": meta.scale,
        "seconds": meta.seconds,
        "parameters": meta.parameters,
        "verdict_rules": VERDICT_RULES,
        "rows": [r.as_dict() for r in rows],
        "figures": [asdict(f) for f in figures],
        "data": extra or {},
    }
    atomic_write_text(paths["json"], json.dumps(json_safe(payload), indent=1))
    return paths
