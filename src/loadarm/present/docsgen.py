"""``make docs``: regenerate everything in the docs that the code produces.

* the figures in ``docs/img`` that the docs show, drawn from the paper's case with the report's own
  builders (:data:`loadarm.present.report.FIGURES`), so a figure in the docs is the figure the report draws;
* the parameter tables of ``docs/configuration.md`` and ``docs/ship-motion.md`` (the berth file) and
  ``examples/full.toml``, from the declarations.

Console blocks are not generated: ``tests/test_docs.py`` runs every one and compares. ``tests/test_docs.py``
also redraws every figure and compares it with the committed PNG (``--check`` does the same here).

Run ``python -m loadarm.present.docsgen [--check]`` from the repository root.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from loadarm.arm.swivel import swivel_track
from loadarm.design.bank import check_bank_approaches
from loadarm.design.manifold import berth_wind, check_manifold_loads, motion_manifold_loads
from loadarm.figures import save
from loadarm.hydraulics.bank_release import simulate_release
from loadarm.opcua.bank import bank_address_space_markdown
from loadarm.opcua.plc import tags_markdown
from loadarm.opcua.server import address_space_markdown
from loadarm.params.bank import bank_parameter_markdown, load_bank
from loadarm.params.berth import berth_parameter_markdown, load_berth
from loadarm.params.config import example_toml, load_config, packaged_example, parameter_markdown
from loadarm.present.report import ReportData, build_report, figure_builders
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import simulate
from loadarm.studies.forecast import run_forecast
from loadarm.studies.hold_limit import hold_limit_basis
from loadarm.studies.metocean import synthetic_metocean
from loadarm.studies.prediction import calibrate_predictors
from loadarm.studies.plots import weather_figure
from loadarm.testing.bank_screen import BANK_SCREENSHOT, bank_screenshot
from loadarm.testing.browser import SCREENSHOTS, find_chromium, launch, screenshots

__all__ = ["DOC_FIGURES", "HMI_SCREENSHOTS", "REPORT_PAGES", "report_page", "STUDY_FIGURES", "render_doc_figures", "hmi_screenshots",
           "study_figures", "shipped_forecast", "regenerate", "compare_figures"]

#: The figures the docs show (file names in docs/img); the paper's case draws them.
DOC_FIGURES = ("sizing.png", "envelope.png", "alpha_beta.png", "angles_paper.png", "timing.png", "cylinders.png",
               "voltages.png", "verification.png", "loads.png", "residual_torque.png", "deviation_by_timing.png",
               "simulation_smooth.png", "timeline_driftoff.png", "check.png", "rao.png", "alarm_design.png",
               "operability.png", "weather.png", "bank_clearance.png", "bank_swivels.png", "bank_release.png",
               "bank_manifold_loads.png", "bank_manifold_record.png", "hold_limit.png")

#: Figures of studies that take minutes (the predictors over their hold-out records, a forecast ensemble): drawn by
#: ``make docs`` and by the slow tests that run the same studies and compare (:func:`study_figures`), not by
#: :func:`render_doc_figures`.
STUDY_FIGURES = ("prediction.png", "forecast.png")

#: Years of synthetic weather drawn for docs/img/weather.png (seed 1).
WEATHER_YEARS = 10

#: The operator's screen in docs/hmi.md: screenshots a real browser takes of the scripted drift-off
#: (:func:`hmi_screenshots`; not compared pixel by pixel: a live screen's clock and noise differ each run).
HMI_SCREENSHOTS = SCREENSHOTS + (BANK_SCREENSHOT,)      # and the bank's screen in docs/bank.md (regenerate)

#: The report's title page as printed (docs/cli-and-report.md): drawn by :func:`report_page` from the paper's
#: report in Chromium with the print stylesheet (not compared pixel by pixel: its date and hash change).
REPORT_PAGES = ("report-page.png",)

#: Root-mean-square difference (0-255 grey levels) tolerated between a committed and a redrawn figure:
#: anti-aliasing may differ by a pixel across FreeType builds; any change of a curve, label or legend is far
#: above it (a one-line change of a legend measured 2-6).
FIGURE_TOLERANCE = 0.5


def _paper_data():

    source = packaged_example("paper.toml")
    return ReportData(load_config(source), source)


def _weather(_data):
    return weather_figure(synthetic_metocean(WEATHER_YEARS * 8760, seed=1))


#: The example bank of docs/bank.md, and the ship's rotation its swivel figure shows: roll, pitch, yaw amplitudes
#: (rad) and periods (s), an illustrative moored LNG carrier's (not the moored-ship model's output).
BANK_EXAMPLE = "banks/lng150k_bank.toml"
#: The ship the bank's screenshot (docs/bank.md) is connected to: the moored LNG carrier in Hs 1.5 m.
BANK_SCREEN_SCENARIO = "scenarios/hs15_moored.toml"
BANK_SHIP_TURNING = ((0.0524, 14.0), (0.0087, 9.0), (0.0175, 60.0))


def _bank_clearance(_data):
    return check_bank_approaches(load_bank(packaged_example(BANK_EXAMPLE))).plot()


def _bank_swivels(_data):
    bank = load_bank(packaged_example(BANK_EXAMPLE))
    t = np.linspace(0.0, 120.0, 1201)
    roll, pitch, yaw = (a * np.sin(2 * np.pi * t / period) for a, period in BANK_SHIP_TURNING)
    return swivel_track(t, bank.connected[0], roll, pitch, yaw, bank.file.swivels.limits()).plot()


def _bank_release(_data):
    return simulate_release(load_bank(packaged_example(BANK_EXAMPLE))).plot()


#: The moored ship's record of docs/bank.md's manifold-load figure: the example berth's design environment,
#: duration (s) and seed.
BANK_RECORD = ("berths/lng150k.toml", 300.0, 1)


def _bank_manifold_loads(_data):
    return check_manifold_loads(load_bank(packaged_example(BANK_EXAMPLE))).plot()


def _bank_manifold_record(_data):
    berth_file, duration, seed = BANK_RECORD
    berth = load_berth(packaged_example(berth_file))
    motion = simulate(compile_ship(berth), berth.environment, duration, seed=seed)
    return motion_manifold_loads(load_bank(packaged_example(BANK_EXAMPLE)), motion,
                                 wind=berth_wind(berth.environment)).plot()


#: The stored campaign the hold limit's figure shows (docs/campaigns, from the repository's root): its runs file and
#: its candidates' reruns.
HOLD_LIMIT_CASE = ("hs15_tracked_hs1.5-2.0_runs.jsonl", "hs15_tracked_hs1.5-2.0_held_runs.jsonl")


def _hold_limit(_data):
    camp = Path("docs") / "campaigns"
    return hold_limit_basis(camp / HOLD_LIMIT_CASE[0], camp / HOLD_LIMIT_CASE[1],
                            scenarios=packaged_example("scenarios")).plot()


def study_figures(dest: str | Path, names=STUDY_FIGURES, *, prediction=None, forecast=None) -> dict[str, Path]:
    """Draw :data:`STUDY_FIGURES` into ``dest``: the flange predictors' calibration on their hold-out records,
    and the connect windows of the shipped forecast ensemble.

    Parameters
    ----------
    dest : str or Path
    names : sequence of str
        Which of them.
    prediction : PredictionCalibration, optional
        The calibration study's result, when the caller has run it (default: run here, a few minutes).
    forecast : ForecastResult, optional
        The ensemble's (default: :func:`shipped_forecast`, run here).

    Returns
    -------
    dict of str to Path
    """
    written = {}
    if "prediction.png" in names:
        if prediction is None:
            berth = load_berth(packaged_example("berths/lng150k.toml"))
            prediction = calibrate_predictors(compile_ship(berth), berth.environment)
        written["prediction.png"] = save(prediction.plot(), Path(dest) / "prediction.png")
    if "forecast.png" in names:
        written["forecast.png"] = save((forecast or shipped_forecast()).plot(), Path(dest) / "forecast.png")
    return written


def shipped_forecast():
    """The connect windows of ``examples/metocean/forecast/`` (five members, 72 hours, one seed) for the paper's
    arm at the example berth: docs/img/forecast.png.

    Returns
    -------
    ForecastResult
    """
    members = sorted(packaged_example("metocean/forecast").glob("member-*.csv"))
    return run_forecast(packaged_example("paper.toml"), packaged_example("berths/lng150k.toml"), members)


def render_doc_figures(dest: str | Path, names=DOC_FIGURES) -> dict[str, Path]:
    """Draw the docs' figures from the paper's case into ``dest``.

    Parameters
    ----------
    dest : str or Path
        Output folder.
    names : sequence of str
        Which figures (default: all of :data:`DOC_FIGURES`).

    Returns
    -------
    dict of str to Path
        The files written.
    """

    data = _paper_data()
    builders = {**figure_builders(data), "weather.png": (_weather, ""), "bank_clearance.png": (_bank_clearance, ""),
                "bank_swivels.png": (_bank_swivels, ""), "bank_release.png": (_bank_release, ""),
                "bank_manifold_loads.png": (_bank_manifold_loads, ""),
                "bank_manifold_record.png": (_bank_manifold_record, ""), "hold_limit.png": (_hold_limit, "")}
    out = {}
    for name in names:
        out[name] = save(builders[name][0](data), Path(dest) / name)
    return out


def compare_figures(committed: str | Path, fresh: dict[str, Path], tol: float = FIGURE_TOLERANCE) -> list[str]:
    """Names of the figures that differ from the committed ones (or are missing), with the RMS difference.

    Parameters
    ----------
    committed : str or Path
        Folder of the committed figures (``docs/img``).
    fresh : dict of str to Path
        Freshly drawn figures by name.
    tol : float
        RMS tolerance, grey levels.

    Returns
    -------
    list of str
        One line per figure that does not match; empty when all match.
    """
    from matplotlib.testing.compare import compare_images

    bad = []
    for name, path in fresh.items():
        ref = Path(committed) / name
        if not ref.exists():
            bad.append(f"{name}: not committed")
            continue
        res = compare_images(str(ref), str(path), tol, in_decorator=True)
        if res is not None:
            bad.append(f"{name}: RMS {res['rms']:.2f} > {tol}")
    return bad


def hmi_screenshots(dest: str | Path, *, speedup: float = 4.0) -> list[Path]:
    """The screenshots of docs/hmi.md (:data:`loadarm.testing.browser.SCREENSHOTS`, at a 1920x1080 console): each
    mode of the scripted drift-off live (the hydraulic plant, at ``speedup``), then the same run replayed and its alarm
    journal, taken in Debian's Chromium (:func:`loadarm.testing.browser.screenshots`).

    Parameters
    ----------
    dest : str or Path
        Where they go.
    speedup : float
        Run seconds per wall second.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    FileNotFoundError
        No Chromium (the message says how to install it).
    """
    return screenshots(packaged_example("scenarios/driftoff.toml"), dest, speedup=speedup)


def report_page(dest: str | Path) -> Path:
    """The title page of the paper's report as printed (A4, the print stylesheet), taken in Chromium:
    ``report-page.png`` (:data:`REPORT_PAGES`).

    Parameters
    ----------
    dest : str or Path
        Where it goes.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    FileNotFoundError
        No Chromium (the message says how to install it).
    """
    import tempfile

    from playwright.sync_api import sync_playwright

    source = packaged_example("paper.toml")
    out = Path(dest) / REPORT_PAGES[0]
    with tempfile.TemporaryDirectory() as tmp:
        files = build_report(load_config(source), tmp, title="loadarm: the paper's case end to end", source=source)
        with sync_playwright() as p:
            browser = launch(p)
            # A4 at 96 px/in less the page's margins (210 x 297 mm, 14 and 15/18 mm): the printed page's content box
            page = browser.new_page(viewport={"width": 688, "height": 998}, device_scale_factor=1.5)
            page.emulate_media(media="print")
            page.goto(files.html.resolve().as_uri())
            out.parent.mkdir(parents=True, exist_ok=True)
            # the title page: it ends after the table of contents (the print stylesheet breaks the page there)
            bottom = page.evaluate("document.querySelector('header.titlepage').getBoundingClientRect().bottom")
            page.screenshot(path=str(out), clip={"x": 0, "y": 0, "width": 688, "height": min(998, bottom + 16)})
            browser.close()
    return out


def regenerate(root: str | Path = ".") -> list[Path]:
    """Rewrite the generated parts of the docs under ``root``.

    Parameters
    ----------
    root : str or Path
        Repository root.

    Returns
    -------
    list of Path
        Files written.
    """

    root = Path(root)
    written = list(render_doc_figures(root / "docs" / "img").values())
    written += study_figures(root / "docs" / "img").values()

    if find_chromium() is not None:
        written += hmi_screenshots(root / "docs" / "img")
    else:
        print("docs/img/hmi-*.png kept: no Chromium to take them (apt-get install chromium)")
    if find_chromium() is not None:
        written.append(bank_screenshot(packaged_example(BANK_EXAMPLE), packaged_example(BANK_SCREEN_SCENARIO),
                                       root / "docs" / "img"))
    else:
        print(f"docs/img/{BANK_SCREENSHOT} kept: no Chromium to take it (apt-get install chromium)")
    if find_chromium() is not None:
        written.append(report_page(root / "docs" / "img"))
    else:
        print("docs/img/report-page.png kept: no Chromium to take it (apt-get install chromium)")

    return [*written, *regenerate_tables(root)]


def regenerate_tables(root: str | Path = ".") -> list[Path]:
    """Rewrite the docs' generated tables and ``examples/full.toml`` (no figures: seconds, not minutes).

    Parameters
    ----------
    root : str or Path
        Repository root.

    Returns
    -------
    list of Path
        Files written.
    """

    root = Path(root)
    variables, methods = address_space_markdown()
    plant = root / "docs" / "plant-integration.md"
    tables = [(root / "docs" / "configuration.md", parameter_markdown(), "| key | unit | default |"),
              (root / "docs" / "ship-motion.md", berth_parameter_markdown(), "| key | unit | default |"),
              (root / "docs" / "bank.md", bank_parameter_markdown(), "| key | unit | default |"),
              (plant, variables, "| variable | unit | range |"), (plant, methods, "| method | arguments |"),
              (plant, tags_markdown(), "| tag | direction |"),
              (plant, bank_address_space_markdown(), "| node | type | unit | what |")]
    for page, table, header in tables:
        text = page.read_text(encoding="utf-8")
        a = text.index(header)
        b = text.find("\n\n", a)
        text = text[:a] + table.rstrip("\n") + (text[b:] if b >= 0 else "\n")
        page.write_text(text, encoding="utf-8")
    full = root / "examples" / "full.toml"
    full.write_text(example_toml(), encoding="utf-8")
    return [*dict.fromkeys(page for page, _, _ in tables), full]


def main(argv: list[str] | None = None) -> int:
    """``python -m loadarm.present.docsgen [--check | --tables]``.

    Parameters
    ----------
    argv : list of str, optional
        ``["--check"]`` compares the figures instead of writing; ``["--tables"]`` rewrites only the tables.

    Returns
    -------
    int
        0 when written (or, with ``--check``, when everything matches), 1 otherwise.
    """
    import tempfile

    args = sys.argv[1:] if argv is None else argv
    if "--check" in args:
        with tempfile.TemporaryDirectory() as tmp:
            bad = compare_figures(Path("docs") / "img", render_doc_figures(tmp))
        for line in bad:
            print(line)
        return 1 if bad else 0
    for p in (regenerate_tables(".") if "--tables" in args else regenerate(".")):
        print(f"wrote {p}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
