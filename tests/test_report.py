"""The report describes the installation it is given (found: `demo --config mine.toml` wrote a report about
the paper), names its input, date and version, and shows engineering units."""

import json
import re
from datetime import datetime, timezone

import pytest

from loadarm.config import load_config
from loadarm.report import build_report

from .conftest import PAPER_TOML, ROOT


@pytest.fixture(scope="module")
def own_report(tmp_path_factory):
    d = tmp_path_factory.mktemp("own")
    (d / "scen").mkdir()
    calm = (ROOT / "examples" / "scenarios" / "calm.toml").read_text()
    calm = re.sub(r"duration = [0-9.]+", "duration = 40.0", calm).replace('name = "calm"', 'name = "quick"')
    (d / "scen" / "quick.toml").write_text(calm)
    text = PAPER_TOML.read_text().replace("outboard = 8.2", "outboard = 8.5")
    text = re.sub(r"\[report\].*", '[report]\nscenarios = ["scen/quick.toml"]\n', text, flags=re.S)
    cfg = d / "mine.toml"
    cfg.write_text(text)
    inst = load_config(cfg)
    files = build_report(inst, d / "out", title="my berth", source=cfg,
                         now=datetime(2026, 11, 23, 12, 0, tzinfo=timezone.utc))
    return files, files.html.read_text(), json.loads(files.summary.read_text())


def test_report_names_its_input_date_and_version(own_report):
    import hashlib

    from loadarm import __version__

    files, html, summary = own_report
    digest = hashlib.sha256((files.html.parent.parent / "mine.toml").read_bytes()).hexdigest()
    assert "Generated 2026-11-23 12:00 UTC" in html and f"loadarm {__version__}" in html
    assert f"mine.toml (sha256 {digest[:16]}" in html
    assert summary["generated"] == "2026-11-23 12:00 UTC" and summary["input"].startswith("mine.toml")


def test_own_installation_is_not_called_the_paper(own_report):
    files, html, summary = own_report
    assert "(paper: 12 m and 8.2 m)" not in html and "the paper's example does this too" not in html
    assert "configured arm (b = 12 m, c = 8.5 m)" in html
    assert list(summary["scenarios"]) == ["quick"]          # its own list, not the repository's examples
    assert "timeline_quick.png" in {p.name for p in files.figures.values()}


def test_no_wall_clock_numbers_in_the_report(own_report):
    _, html, summary = own_report
    assert "cycle p99" not in html and "[us]" not in html
    assert all(not k.startswith("cycle_us") for s in summary["scenarios"].values() for k in s)


def test_parameters_in_engineering_units_left_aligned_text(own_report):
    _, html, _ = own_report
    row = re.search(r"<tr><td>cylinders\.max_pressure</td><td[^>]*>([^<]*)</td><td>([^<]*)</td>", html)
    assert row and row.groups() == ("210", "bar"), row and row.groups()
    assert "21000000.0" not in html
    assert re.search(r"<tr><td>cylinders\.coulomb_friction</td><td[^>]*>2</td><td>kN</td>", html)
    assert "td.num{text-align:right" in html and "text-align:left" in html
    assert not re.search(r"\bissue \d", html)               # no tracker references in user-facing text


@pytest.mark.slow
def test_paper_case_keeps_its_comparison(tmp_path):
    from loadarm.config import parse_config

    d = load_config(PAPER_TOML).model_dump()
    d["report"]["scenarios"] = []
    files = build_report(parse_config(d), tmp_path, source=PAPER_TOML)
    html = files.html.read_text()
    assert "(paper: 12 m and 8.2 m)" in html and "No scenarios" in html
