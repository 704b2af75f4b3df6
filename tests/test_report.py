"""The report describes the installation it is given (found: `demo --config mine.toml` wrote a report about
the paper), names its input, date and version, and shows engineering units."""

import json
import math
import re
from datetime import datetime, timezone
from pathlib import Path

import pytest

from loadarm.params.config import load_config
from loadarm.present.report import build_report
from loadarm.testing.browser import CHROMIUM_HINT

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


@pytest.mark.slow  # 8-13 s: a whole report built once for these (make test's two minutes; CI runs it)
def test_report_names_its_input_date_and_version(own_report):
    import hashlib

    from loadarm import __version__

    files, html, summary = own_report
    digest = hashlib.sha256((files.html.parent.parent / "mine.toml").read_bytes()).hexdigest()
    assert "<th>date</th><td>2026-11-23 12:00 UTC</td>" in html and f"loadarm {__version__}" in html
    assert f"mine.toml (sha256 {digest[:16]}" in html and f"<code>{digest}</code>" in html
    assert summary["generated"] == "2026-11-23 12:00 UTC" and summary["input"].startswith("mine.toml")


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_own_installation_is_not_called_the_paper(own_report):
    files, html, summary = own_report
    assert "(paper: 12 m and 8.2 m)" not in html and "the paper's example does this too" not in html
    assert "configured arm (b = 12 m, c = 8.5 m)" in html
    assert list(summary["scenarios"]) == ["quick"]          # its own list, not the repository's examples
    assert "timeline_quick.png" in {p.name for p in files.figures.values()}


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_no_wall_clock_numbers_in_the_report(own_report):
    _, html, summary = own_report
    assert "cycle p99" not in html and "[us]" not in html
    assert all(not k.startswith("cycle_us") for s in summary["scenarios"].values() for k in s)


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_parameters_in_engineering_units_left_aligned_text(own_report):
    _, html, _ = own_report
    row = re.search(r"<tr><td>cylinders\.max_pressure</td><td[^>]*>([^<]*)</td><td>([^<]*)</td>", html)
    assert row and row.groups() == ("210", "bar"), row and row.groups()
    assert "21000000.0" not in html
    assert re.search(r"<tr><td>cylinders\.coulomb_friction</td><td[^>]*>2</td><td>kN</td>", html)
    assert "td.num{text-align:right" in html and "text-align:left" in html
    assert not re.search(r"\bissue \d", html)               # no tracker references in user-facing text


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_a_document_an_engineer_can_sign(own_report, tmp_path):
    """The title page: the document number and revision, the date, the input's SHA-256, an approval block
    (prepared, checked, approved: blank name, signature and date) and a table of contents whose every entry links
    to a section heading that is there; page numbers in print ("page n of N", the document's number beside)."""
    import hashlib

    from loadarm.present.report import document_identity, report_sections

    files, html, _ = own_report
    title_page = html.split("</header>")[0]
    digest = hashlib.sha256((files.html.parent.parent / "mine.toml").read_bytes()).hexdigest()
    assert f"<th>document</th><td>LA-{digest[:8].upper()}</td><th>revision</th><td>0</td>" in title_page
    assert f"<code>{digest}</code>" in title_page
    for role in ("prepared", "checked", "approved"):
        assert f"<tr><th>{role}</th><td></td><td></td><td></td></tr>" in title_page
    toc = re.findall(r'<li><a href="#([^"]+)">([^<]+)</a></li>', title_page)
    assert [t for _, t in toc] == [x["heading"] for x in report_sections(False, False)]
    for anchor, heading in toc:
        assert f'<h2 id="{anchor}">{heading}</h2>' in html
    assert 'counter(page) " of " counter(pages)' in html and f"LA-{digest[:8].upper()} rev 0" in html
    # the owner's document control, from the file
    cfg = tmp_path / "doc.toml"
    cfg.write_text(PAPER_TOML.read_text().replace("[report]", '[report]\ndocument = "TRM-0042"\nrevision = "B"'))
    assert document_identity(load_config(cfg), cfg)["number"] == "TRM-0042"
    assert document_identity(load_config(cfg), cfg)["revision"] == "B"


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_every_range_in_the_unit_of_its_value_and_the_file_s_unit_beside(own_report):
    """Found: ``valve.laminar_pressure 1 bar ... (0, 1e+07] Pa``: a value in bar beside its range in Pa, and a user
    who copied the value into the file was refused. Each range is now in the value's unit (pint converts the
    declaration's bounds) and the value as the file takes it (SI) stands beside it."""
    from loadarm.params.config import parameter_table
    from loadarm.present.report import parameter_rows

    _, html, _ = own_report
    row = re.search(r"<tr><td>valve\.laminar_pressure</td>((?:<td[^>]*>[^<]*</td>){5})", html)
    cells = re.findall(r"<td[^>]*>([^<]*)</td>", row.group(1))
    assert cells == ["1", "bar", "1", "(0, 100] bar", "100000 Pa"], cells
    declared = {r["key"]: r for r in parameter_table()}
    inst = load_config(PAPER_TOML)
    converted = 0
    for r in parameter_rows(inst):
        section, key = r["key"].split(".", 1)
        raw = getattr(getattr(inst, section), key)
        if re.match(r"[\[(]", r["range"]):                        # a numeric range: in the unit of the value
            assert r["range"].endswith(f" {r['unit']}") or r["unit"] in ("", "1"), r
        if isinstance(raw, float):                                 # the file column reads back as the value
            assert float(r["file"].split()[0]) == raw, r
        converted += r["unit"] != declared[r["key"]]["unit"]
    assert converted == 18                                         # every Pa, N and m^3/s parameter


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_summary_json_rounds_as_documented_and_the_sized_corner_sounds(own_report):
    """docs/cli-and-report.md: JSON rounds floats to 12 significant digits (found: summary.json had
    123.00000000000003 and -4.699999999999999; --json rounded, the report did not); one function rounds both.
    The sized arm's first-alarm corner is at 123 deg, where the first alarm sounds (found: labelled normal)."""
    from loadarm.results import round_floats
    from loadarm.vocab import Severity

    files, _, summary = own_report
    text = files.summary.read_text()
    assert "123.00000000000003" not in text and "-4.699999999999999" not in text
    assert summary == round_floats(summary)                     # every float already at 12 significant digits
    corner = summary["sizing"]["corners_sized_arm"][3]
    assert corner["beta_deg"] == 123.0 and corner["y_m"] == -4.7 and corner["zone"] == int(Severity.ESD1)


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_arrive_is_said_to_be_the_first_time_within_the_tolerance(own_report):
    """Found: "arrive 67.85 s" beside "final 44.57 mm" read as a contradiction: arrive is the first time within the
    5 mm tolerance, final the distance when the run ends; the report says so under the table."""
    _, html, _ = own_report
    assert "arrive: the first time within 5 mm of the flange (the arrival tolerance);" in html
    assert "final: the distance from the flange when the run ends" in html


@pytest.mark.slow
def test_paper_case_keeps_its_comparison(tmp_path):
    from loadarm.params.config import parse_config

    d = load_config(PAPER_TOML).model_dump()
    d["report"]["scenarios"] = []
    files = build_report(parse_config(d), tmp_path, source=PAPER_TOML)
    html = files.html.read_text()
    assert "(paper: 12 m and 8.2 m)" in html and "No scenarios" in html


@pytest.mark.slow           # the report's 6 s fixture again on another worker (make test's budget; CI runs it)
def test_report_html_is_a_template_that_escapes_user_text(own_report, tmp_path):
    """The HTML layer is an autoescaped Jinja2 template: a file name or title cannot inject markup."""
    from loadarm.present.report import _template

    files, html, _ = own_report
    assert _template().environment.autoescape("report.html.j2") is True
    assert html.startswith("<!doctype html>") and html.count('<h2 id="s-') == 10  # no [report] berth: no berth section
    text = _template().render(**{**_render_minimal(), "title": "<script>alert(1)</script>"})
    assert "<script>alert(1)</script>" not in text and "&lt;script&gt;alert(1)&lt;/script&gt;" in text
    assert "<i>bad</i>" not in text and "&lt;i&gt;bad&lt;/i&gt;" in text           # the check's reasons too


def _render_minimal():
    """Smallest context the template needs (to test escaping without running the pipeline)."""
    from types import SimpleNamespace as NS

    empty = {"headers": [], "rows": []}
    fig = {"uri": "data:,", "caption": "c"}
    inst = load_config(PAPER_TOML)
    from loadarm.present.report import APPROVALS, report_sections

    sections = report_sections(False, False)
    return dict(doc={"number": "LA-1", "revision": "0", "sha256": "0"}, sections=sections,
                section={x["key"]: x for x in sections}, approvals=APPROVALS, mark="[loadarm ",
                css="", stamp="now", version="0", input_line="in", notes=["<b>note</b>"], berth=None, berth_file="",
                design=None, oper=None, oper_settings=None,
                sizing=NS(corner=(1.0, -1.0), r_alarm=1.0, inboard=1.0, outboard=1.0, active_bound="x"), inst=inst,
                paper=False, arm=NS(b=1.0, c=1.0), tables={k: empty for k in (
                    "corners_sized", "corners_configured", "endpoints", "plans", "loads", "simulation", "scenarios",
                    "parameters", "check", "reconciliation")}, verdict=NS(status="refused", reason="<i>bad</i>"),
                figures={k: fig for k in ("sizing.png", "envelope.png", "alpha_beta.png", "angles_paper.png", "angles_smooth.png",
                                          "timing.png", "cylinders.png", "voltages.png", "verification.png",
                                          "loads.png", "residual_torque.png", "deviation_by_timing.png",
                                          "simulation_smooth.png", "check.png")},
                local_minima="", paper_peak_speed=0.2, csv_names=[], vs=NS(samples=1, max_alpha_diff_deg=0.0,
                max_beta_diff_deg=0.0, max_r_ac1_diff_mm=0.0, max_r_ac2_diff_mm=0.0),
                bs=NS(poses=1, fills=[0.0], counterweight_inboard_kg=1.0, moment_inboard_kgm=1.0,
                      counterweight_outboard_kg=1.0, moment_outboard_kgm=1.0, max_residual_torque_alpha_Nm=1.0,
                      max_residual_torque_beta_Nm=1.0, configured_max_torque_alpha_Nm=1.0,
                      configured_max_torque_beta_Nm=1.0),
                mass_text="m", scenario_files="", timelines=[], arrival_note="a", verify_samples=201,
                check=NS(esd_lead=1.0, release_lead=1.0, design_speed=0.1, design_accel=0.01,
                         design_vertical_speed=0.0, ok=False, problems=["<i>bad</i>"], accumulator_usable=1e-3,
                         accumulator_needed=1e-3),
                seq=NS(esd_time=1.0, ers_valve_time=1.0, erc_release_time=1.0, margin=1.0))


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
def test_the_report_plans_each_timing_law_once(monkeypatch, tmp_path):
    """Found: build_report planned seven times. Now one plan per law serves every section."""
    import loadarm.present.report as rep
    from loadarm.params.compiler import compile_model
    from loadarm.params.config import parse_config

    calls = []
    real = rep.plan_approach
    monkeypatch.setattr(rep, "plan_approach", lambda *a, **k: calls.append(k.get("timing")) or real(*a, **k))
    d = load_config(PAPER_TOML).model_dump()
    d["report"]["scenarios"] = []
    data = rep.ReportData(parse_config(d), PAPER_TOML)
    data.plans, data.verification, data.simulations, data.loads
    assert sorted(calls) == ["optimal", "paper", "smooth"]
    assert data.model == compile_model(parse_config(d))


def test_a_moored_scenario_at_the_report_s_berth_takes_the_report_s_ship(monkeypatch):
    """Found: the demo compiled the example ship twice, once for the berth section and again for the moored
    break-out scenario at the same berth. Now the scenario takes the report's ship (one compilation); a
    scenario of the simple ship takes none."""
    import loadarm.present.report as rep
    from loadarm.params.config import parse_config

    compiled, runs = [], {}
    monkeypatch.setattr(rep, "compile_ship", lambda *a, **k: compiled.append(object()) or compiled[-1])
    monkeypatch.setattr(rep, "run_scenario", lambda sc, model, ship=None: runs.setdefault(sc.scenario.name, ship))
    d = load_config(PAPER_TOML).model_dump()
    d["report"]["scenarios"] = ["scenarios/breakout.toml", "scenarios/calm.toml"]
    data = rep.ReportData(parse_config(d), PAPER_TOML)
    data.scenarios
    assert len(compiled) == 1 and len(runs) == 2
    moored = [name for name, ship in runs.items() if ship is not None]
    assert len(moored) == 1 and runs[moored[0]] is data.ship is compiled[0] and len(compiled) == 1


@pytest.mark.slow
def test_report_with_a_berth_has_the_moored_ship_and_its_alarm_design(tmp_path):
    """An installation naming a [report] berth: the report's berth section (ship summary, RAOs, the alarm
    design with the blocks to paste) and summary.json's "berth"; the demo's paper case does this."""
    text = PAPER_TOML.read_text()
    text = re.sub(r"\[report\].*", '[report]\nberth = "berths/lng150k.toml"\n', text, flags=re.S)
    (tmp_path / "berths").mkdir()
    (tmp_path / "berths" / "lng150k.toml").write_text((ROOT / "examples" / "berths" / "lng150k.toml").read_text())
    cfg = tmp_path / "mine.toml"
    cfg.write_text(text)
    files = build_report(load_config(cfg), tmp_path / "out", source=cfg)
    html = files.html.read_text()
    summary = json.loads(files.summary.read_text())
    assert "8b. The berth: moored ship and alarm design" in html and "[alarms]" in html
    # one verdict, configured against recommended side by side (found: section 8 passed, 8b recommended others)
    assert summary["verdict"]["status"] == "conditional" and "Verdict: CONDITIONAL" in html
    assert "<th>configured [deg]</th>" in html and "<th>recommended [deg]</th>" in html
    assert "Pre-alarm: recommended from" in html and "Verdict: <b>holds" not in html
    assert {"rao.png", "alarm_design.png"} <= {p.name for p in files.figures.values()}
    rec = summary["berth"]["alarm_design"]["recommended"]
    assert rec["first_beta_deg"] < rec["second_beta_deg"] < rec["release_beta_deg"]
    assert summary["berth"]["ship"]["roll_period_s"] == pytest.approx(22.7, abs=0.1)


def test_report_pdf_without_chromium_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    """``loadarm report --pdf`` with no Chromium: refused before any work, one line with the install hint, exit 2;
    ``loadarm demo`` without one says in one line that it skipped the PDF."""
    from loadarm.cli import main
    from loadarm.present.report import ReportFiles

    monkeypatch.setenv("LOADARM_CHROMIUM", str(tmp_path / "no-such-chromium"))
    assert main(["report", "--config", str(PAPER_TOML), "--out", str(tmp_path / "r"), "--pdf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("loadarm: error: --pdf needs Chromium: no Chromium found: install")
    assert not (tmp_path / "r").exists()                              # nothing computed, nothing written
    import loadarm.cli.demo as demo

    def fake_build(inst, out_dir, **kw):
        assert kw["pdf"] is False
        return ReportFiles(html=Path(out_dir) / "report.html", summary=Path(out_dir) / "summary.json", csv={},
                           figures={})
    monkeypatch.setattr(demo, "build_report", fake_build)
    assert main(["demo", "--out", str(tmp_path / "d")]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("pdf")]
    assert lines == [f"pdf: skipped ({CHROMIUM_HINT})"]


@pytest.mark.slow
def test_the_pdf_has_every_section_and_page_numbers(tmp_path):
    """Chromium's print to PDF of the report: every section of the HTML is in the PDF (its outline, written from
    the headings Chromium laid out), more pages than sections (each starts a page), the document number in the
    title, and the file carries loadarm's mark (rerun without --force)."""
    from loadarm.files import written_by_loadarm
    from loadarm.present.pdf import pdf_outline
    from loadarm.present.report import report_sections
    from loadarm.testing.browser import find_chromium

    if find_chromium() is None:
        pytest.skip(f"the PDF test needs Chromium: {CHROMIUM_HINT}")
    from loadarm.params.config import parse_config

    d = load_config(PAPER_TOML).model_dump()
    d["report"] = {"scenarios": [], "document": "TRM-0042", "revision": "B"}
    files = build_report(parse_config(d), tmp_path, title="pdf test", pdf=True)
    outline = pdf_outline(files.pdf)
    assert outline[0].startswith("pdf test, TRM-0042 rev B [loadarm ")
    headings = [x["heading"] for x in report_sections(False, False)]
    assert [t for t in outline if t in headings] == headings and "Contents" in outline
    data = files.pdf.read_bytes()
    assert data.count(b"/Type /Page\n") > len(headings) and written_by_loadarm(files.pdf)


@pytest.mark.slow
def test_every_table_fits_the_printed_page(own_report):
    """Found in the second trial of issue 29: in report.pdf the parameter table ran 390 px past the A4 page's
    text width and Chromium cut it at the margin (its "source" column lost, e.g. "customer datasheet; example v"):
    the PDF did not have the HTML's content. Laid out as printed (print media, the width between @page's margins),
    every table lies within the text width, no cell's text runs out of its cell, and every section's heading (the
    bank's too) is one line (Chromium builds the PDF's outline from it: found, "8d. ... emergencyrelease")."""
    from loadarm.present.report import report_sections
    from loadarm.testing.browser import find_chromium, launch

    if find_chromium() is None:
        pytest.skip(f"the print layout test needs Chromium: {CHROMIUM_HINT}")
    from playwright.sync_api import sync_playwright

    files, html, _ = own_report
    margins = re.search(r"@page\{size:A4;margin:(\d+)mm (\d+)mm", html)
    width = (210 - 2 * int(margins.group(2))) / 25.4 * 96                # px between the left and right margins
    with sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": math.floor(width), "height": 1000})
            page.emulate_media(media="print")
            page.goto(files.html.resolve().as_uri())
            headings = [x["heading"] for x in report_sections(True, True, True)]       # every one a report has
            found = page.evaluate("""(headings) => {
              const W = document.documentElement.clientWidth, out = {wide: [], cut: [], tables: 0};
              for (const t of document.querySelectorAll('table')) {
                out.tables += 1;
                const r = t.getBoundingClientRect();
                if (r.left < -0.5 || r.right > W + 0.5) out.wide.push(t.rows[0].innerText.slice(0, 60) + ' ' + r.right);
              }
              for (const c of document.querySelectorAll('td, th'))
                if (c.scrollWidth > c.clientWidth + 1) out.cut.push(c.textContent.slice(0, 60));
              const h = document.querySelector('h2[id]');
              out.wrapped = headings.filter((text) => {
                h.textContent = text;
                const r = document.createRange(); r.selectNodeContents(h);
                return new Set([...r.getClientRects()].map((x) => Math.round(x.top))).size > 1;
              });
              return out;
            }""", headings)
        finally:
            browser.close()
    assert found["tables"] > 10 and not found["wide"] and not found["cut"], found
    # a heading on two lines reaches the PDF's outline without the space at its break ("Section5")
    assert not found["wrapped"], found["wrapped"]
