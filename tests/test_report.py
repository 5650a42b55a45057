"""Report assembly: verdict rules, number formatting, Markdown/HTML/JSON output."""

import json
import math
from html.parser import HTMLParser
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from jamlab.report import (  # noqa: E402
    AGREEMENT_SIGMAS,
    Comparison,
    Figure,
    ReportMeta,
    Row,
    format_value,
    target_verdict,
    verdict,
    write_report,
)

VOID = {"meta", "img", "br", "hr", "link", "input"}


class StrictParser(HTMLParser):
    """Checks that every non-void tag is closed in order; collects img sources and table rows."""

    def __init__(self):
        super().__init__()
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.images: list[str] = []
        self.cells: list[list[str]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        if tag == "tr":
            self.cells.append([])
        if tag in ("td", "th"):
            self._cell = []
        if tag not in VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unexpected </{tag}> with open {self.stack[-3:]}")
            return
        self.stack.pop()
        if tag in ("td", "th") and self._cell is not None:
            self.cells[-1].append("".join(self._cell))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def parse_html(text: str) -> StrictParser:
    p = StrictParser()
    p.feed(text)
    p.close()
    return p


def test_verdict_rule_against_hand_arithmetic():
    # |1.30 - 1.41269| = 0.11269; combined sigma sqrt(0.05^2 + 0) = 0.05 -> 2.25 sigma
    assert verdict(1.30, 0.05, 1.41269).startswith("differs (2.25σ)")
    # with the paper's 0.075: sqrt(0.05^2 + 0.075^2) = 0.0901 -> 1.25 sigma
    assert verdict(1.30, 0.05, 1.41269, 0.075).startswith("agrees (1.25σ)")
    # exactly on the boundary counts as agreement
    assert verdict(1.0 + AGREEMENT_SIGMAS * 0.1, 0.1, 1.0).startswith("agrees")
    assert verdict(math.nan, 0.1, 1.0) == "no data"
    assert verdict(1.0, 0.1, math.nan, 0.1) == "no data"  # a measured reference missing
    assert verdict(1.0, 0.1, 1.0, math.nan) == "no data"
    assert verdict(1.0, 0.0, 1.0) == "agrees (exact)"
    assert verdict(1.1, 0.0, 1.0).startswith("differs")


def test_a_window_as_wide_as_the_reference_is_inconclusive():
    # the quick report's θ_e: 0.074 with a 95 % interval [-0.796, 0.944] -> σ = 0.87/1.96 = 0.444;
    # |0.074 - 0.42311| = 0.349 = 0.79σ, but ±2σ = ±0.89 would also take in 0 and 0.85
    v = verdict(0.074, 0.87 / 1.96, 0.42311)
    assert v.startswith("inconclusive (0.79σ; ±2σ = ±0.89")
    # the boundary: ±2σ equal to |reference| is inconclusive, just below it agrees
    assert verdict(1.0, 0.5, 1.0).startswith("inconclusive (0.00σ")
    assert verdict(1.0, 0.49, 1.0) == "agrees (0.00σ)"
    assert verdict(-1.0, 0.5, -1.0).startswith("inconclusive")  # |reference|
    # a wide window does not hide a disagreement, and a zero reference keeps the plain rule
    assert verdict(5.0, 0.5, 1.0) == "differs (8.00σ)"
    assert verdict(0.1, 0.5, 0.0) == "agrees (0.20σ)"
    # the measured reference's σ counts in the window too: sqrt(0.3² + 0.4²) = 0.5
    assert verdict(1.0, 0.3, 1.0, 0.4).startswith("inconclusive")


def test_target_verdict():
    assert target_verdict(1.14, 1.0, 0.15).endswith(": met")
    assert target_verdict(1.16, 1.0, 0.15).endswith(": not met")
    assert target_verdict(math.nan, 1.0, 0.15).endswith("no data")


def test_comparison_labels_and_row_verdicts():
    row = Row("τ", "1", 1.09, 0.05, "1.09 ± 0.05", "3 samples",
              (Comparison("theory", 1.0), Comparison("|τ−1| ≤ 0.15", 1.0, tolerance=0.15)))
    v = row.verdicts
    assert v[0] == "theory: agrees (1.80σ)"
    assert v[1] == "target |τ−1| ≤ 0.15: met"


@pytest.mark.parametrize(
    "value,error,text",
    [(1.23456, 0.0567, "1.235 ± 0.057"), (0.63787, 0.00438, "0.6379 ± 0.0044"),
     (12.0, 3.0, "12.0 ± 3.0"), (math.nan, 1.0, "n/a"), (2.5, math.nan, "2.5")],
)
def test_format_value(value, error, text):
    assert format_value(value, error) == text


def _png(path: Path) -> None:
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("x (units)")
    fig.savefig(path)
    plt.close(fig)


def test_write_report_files_are_consistent(tmp_path):
    (tmp_path / "figures").mkdir()
    _png(tmp_path / "figures" / "a.png")
    rows = [
        Row("τ at φ = 0.75 | pipe", "1.11 ± 0.029", 1.05, 0.04, "1.05 ± 0.04 <b>", "10 samples",
            (Comparison("paper", 1.11, 0.029),)),
        Row("no data row", "1", math.nan, math.nan, "n/a", "0 samples",
            (Comparison("theory", 1.0),), note="too few"),
    ]
    figures = [Figure("a", "Fig. A & co", "figures/a.png", "caption <with> markup")]
    meta = ReportMeta("Title", "tiny", 12.3, {"k": "v"}, ["a **bold** note"])
    paths = write_report(tmp_path, rows, figures, meta, extra={"x": math.nan})
    html = paths["html"].read_text()
    p = parse_html(html)
    assert p.errors == [] and p.stack == []
    assert p.images == ["figures/a.png"]
    assert all((tmp_path / src).is_file() for src in p.images)
    body = [c for c in p.cells if c and c[0] != "quantity"]
    assert [c[0] for c in body] == [r.quantity for r in rows]
    assert body[0][2] == "1.05 ± 0.04 <b>"  # escaped in HTML, shown verbatim
    # 1.05 vs 1.11 +- sqrt(0.04^2 + 0.029^2) = 0.0494 -> 1.21 sigma
    assert "agrees (1.21σ)" in body[0][4]
    md = paths["markdown"].read_text()
    assert "τ at φ = 0.75 \\| pipe" in md and "![Fig. A & co](figures/a.png)" in md
    data = json.loads(paths["json"].read_text())
    assert data["rows"][1]["value"] is None and data["data"]["x"] is None
    assert data["rows"][0]["verdicts"] == rows[0].verdicts


def test_write_report_refuses_missing_figures(tmp_path):
    meta = ReportMeta("T", "tiny", 0.0)
    with pytest.raises(FileNotFoundError, match="missing"):
        write_report(tmp_path, [], [Figure("a", "A", "figures/none.png", "")], meta)
    assert not (tmp_path / "index.html").exists()


def test_sections_get_their_own_heading_and_table(tmp_path):
    rows = [
        Row("s1", "1", 1.0, 0.1, "1.0", "", section="Second"),
        Row("main1", "1", 1.0, 0.1, "1.0", ""),
        Row("s2", "1", 1.0, 0.1, "1.0", "", section="Second"),
        Row("t1", "1", 1.0, 0.1, "1.0", "", section="Third"),
    ]
    meta = ReportMeta("T", "tiny", 0.0, sections={"Second": "intro **text**"})
    paths = write_report(tmp_path, rows, [], meta)
    md = paths["markdown"].read_text()
    # the main table first, then the sections in order of appearance, each with its rows
    assert md.index("## Numbers") < md.index("| main1 |") < md.index("## Second") \
        < md.index("intro **text**") < md.index("| s1 |") < md.index("| s2 |") \
        < md.index("## Third") < md.index("| t1 |")
    html = paths["html"].read_text()
    p = parse_html(html)
    assert p.errors == [] and p.stack == []
    assert html.count("<table>") == 3 and "<h2>Second</h2>" in html
    assert "intro <strong>text</strong>" in html
    assert html.index("<h2>Numbers</h2>") < html.index(">main1<") < html.index("<h2>Second</h2>")
    assert json.loads(paths["json"].read_text())["rows"][0]["section"] == "Second"
