"""Self-contained HTML report of an installation: sizing, envelope, approach, cylinders, valves.

:class:`ReportData` runs the pipeline on an installation once (each result computed on first use);
:data:`FIGURES` lists every figure with its builder and caption, shared by the report and by
``make docs`` (:mod:`loadarm.present.docsgen`); :func:`build_report` writes ``report.html`` (figures embedded as
base64 PNG, so the one file can be mailed), the figures as PNG, one CSV per timing law and
``summary.json``. The report describes the installation it is given: the paper comparison appears only
for the paper's case, the scenarios are the installation's own ``[report] scenarios``.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from functools import cached_property
from pathlib import Path

from loadarm import __version__
from loadarm.arm.envelope import berth_box, zone_radii
from loadarm.design.alarm_design import alarm_verdict, design_alarms
from loadarm.design.balancing import balance_counterweights
from loadarm.design.check import design_check
from loadarm.design.loads import CYLINDER_LOAD_METRICS, actuator_loads
from loadarm.design.manifold import LOAD_LABELS, berth_wind, motion_manifold_loads
from loadarm.design.multibody import VERIFY_SAMPLES, verify_kinematics
from loadarm.design.plots import (
    alpha_beta_figure,
    angles_time_figure,
    cylinders_figure,
    envelope_figure,
    loads_figure,
    residual_torque_figure,
    timing_comparison_figure,
    timing_figure,
    verification_figure,
    voltages_figure,
)
from loadarm.design.sizing import size_installation, sizing_summary
from loadarm.design.timing import TIMING_LAWS
from loadarm.design.trajectory import Plan, plan_approach
from loadarm.figures import save
from loadarm.files import PDF_TITLE_MARK, SIGNATURE, atomic_write, guard_outputs
from loadarm.hydraulics.plots import simulation_figure
from loadarm.hydraulics.simulate import SIMULATION_METRICS, arrival_note, simulate_approach
from loadarm.design.bank import check_bank_approaches
from loadarm.params.bank import load_bank
from loadarm.studies.bank_check import check_bank
from loadarm.params.berth import load_berth
from loadarm.params.compiler import compile_model
from loadarm.params.config import Installation, paper_installation, parameter_table
from loadarm.params.declare import range_text
from loadarm.present.pdf import chromium_or_fail, print_pdf
from loadarm.params.scenario import parse_scenario_file, resolve_berth
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import simulate
from loadarm.ship.summary import ship_summary
from loadarm.sim.loop import run_scenario
from loadarm.results import round_floats
from loadarm.sim.result import RUN_METRICS
from loadarm.studies.operability import headline_rows, run_operability, write_parquet
from loadarm.vocab import Severity

__all__ = ["ReportFiles", "ReportData", "FIGURES", "SECTIONS", "APPROVALS", "build_report", "summary_dict",
           "is_paper_case", "parameter_rows", "report_sections", "document_identity"]


@dataclass(frozen=True)
class ReportFiles:
    """Paths written by :func:`build_report`."""

    html: Path
    summary: Path
    csv: dict[str, Path]
    figures: dict[str, Path]
    pdf: Path | None = None


_NUMBER = re.compile(r"[+-]?\d+(\.\d*)?([eE][+-]?\d+)?( / [+-]?\d+(\.\d*)?)?")


def _table(rows: list[dict], columns: list[tuple[str, str]], fmt: dict[str, str] | None = None) -> dict:
    """A table for the template: headers, and rows of ``(text, numeric)`` cells (numbers right-aligned)."""
    fmt = fmt or {}
    out = []
    for row in rows:
        cells = []
        for key, _ in columns:
            v = row.get(key)
            numeric = (isinstance(v, (int, float)) and not isinstance(v, bool)) or (
                isinstance(v, str) and _NUMBER.fullmatch(v) is not None)
            if isinstance(v, float):
                text = "n/a" if math.isnan(v) else format(v, fmt.get(key, ".3f"))
            elif v is None:
                text = "n/a"
            else:
                text = str(v)
            cells.append((text, numeric))
        out.append(cells)
    return {"headers": [title for _, title in columns], "rows": out}


def summary_dict(inst: Installation, plans: dict[str, Plan], sizing: dict | None = None, model=None) -> dict:
    """Every headline number of the report, JSON-friendly.

    Parameters
    ----------
    inst : Installation
        The installation.
    plans : dict of str to Plan
        Plans by timing-law name.
    sizing : dict, optional
        An already computed :func:`loadarm.design.sizing.sizing_summary`.
    model : ArmModel, optional
        The compiled installation (default: compiled here).

    Returns
    -------
    dict
        Sizing, corner tables, zone radii and plan summaries.
    """
    sz = sizing_summary(inst) if sizing is None else sizing
    model = compile_model(inst) if model is None else model
    keep = ("inboard_m", "outboard_m", "r_alarm_m", "first_alarm_corner_m", "active_bound", "local_minima_m")
    return {
        "loadarm_version": __version__,
        "sizing": {**{k: sz[k] for k in keep}, "corners_sized_arm": sz["corners"],
                   "corners_configured_arm": sz["corners_configured_arm"]},
        "zone_radii_m": zone_radii(model.arm, model.alarms),
        "plans": {name: p.summary() for name, p in plans.items()},
    }


# The parameter table is laid out in fixed columns, its long keys and sources wrapped (found: it ran past the printed
# page and Chromium cut its last column from the PDF, the whole document shrunk to fit); in print a section's heading
# keeps to one line (Chromium's outline of the PDF joins a heading's lines without their space).
_CSS = """
body{font-family:system-ui,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;color:#222;padding:0 1em}
h1{font-size:1.6em} h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.8em 0;font-size:.9em} th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;vertical-align:top}
th{background:#f3f3f3} td.num{text-align:right;font-variant-numeric:tabular-nums}
.meta{color:#555;font-size:.9em}
figure{margin:1em 0} figure img{max-width:100%;border:1px solid #eee} figcaption{font-size:.85em;color:#555}
.note{background:#fff8e1;border-left:4px solid #f0c000;padding:.5em 1em;font-size:.9em}
.refused{border-left:4px solid #b00020;padding:.1em 1em;margin:1em 0}
code{background:#f4f4f4;padding:0 .2em}
.titlepage table{width:100%} .titlepage th{width:9em} .approval td{height:2.6em;width:28%}
.toc ol{list-style:none;padding-left:0;columns:2} .toc li{margin:.15em 0} .toc a{color:#222;text-decoration:none}
.params table{table-layout:fixed;width:100%} .params td,.params th{overflow-wrap:anywhere}
.params th:nth-child(1){width:22%} .params th:nth-child(2){width:10%} .params th:nth-child(3){width:6%}
.params th:nth-child(4){width:8%} .params th:nth-child(5){width:10%} .params th:nth-child(6){width:11%}
.params th:nth-child(7){width:17%} .params th:nth-child(8){width:16%}
@page{size:A4;margin:15mm 14mm 18mm;
 @bottom-left{content:"__DOCID__";font:8pt system-ui,sans-serif;color:#555}
 @bottom-right{content:"page " counter(page) " of " counter(pages);font:8pt system-ui,sans-serif;color:#555}}
@media print{body{max-width:none;margin:0;padding:0;font-size:10pt} .titlepage{break-after:page} h2{font-size:1.15em}
 h2{break-before:page;break-after:avoid} h3{break-after:avoid} figure,tr,pre,.note,.refused{break-inside:avoid}
 figure img{max-height:150mm;object-fit:contain} a{color:inherit;text-decoration:none}
 table{font-size:8pt}}
"""


def _figure(path: Path, caption: str) -> dict:
    """A figure for the template: its PNG as a data URI (the report is one mailable file) and its caption."""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return {"uri": f"data:image/png;base64,{data}", "caption": caption}


def is_paper_case(inst: Installation) -> bool:
    """Whether ``inst`` is the paper's case (its ``[report]`` list aside).

    Parameters
    ----------
    inst : Installation
        Any installation.

    Returns
    -------
    bool
        True when every section but ``report`` equals :func:`loadarm.params.config.paper_installation`.
    """
    return inst.model_dump(exclude={"report"}) == paper_installation().model_dump(exclude={"report"})


#: Closed-loop metrics the report's table shows (declared once in hydraulics.simulate.SIMULATION_METRICS).
_REPORT_SIM_KEYS = ("timing", "plan_duration_s", "arrival_time_s", "max_deviation_mm", "rms_deviation_mm",
                    "final_position_error_mm", "max_chamber_pressure_bar", "peak_pump_flow_L_min", "pump_energy_kJ")

#: Guidance-run metrics the report's scenario table shows (declared once in sim.result.RUN_METRICS).
_REPORT_RUN_KEYS = ("alarm1_s", "alarm2_s", "release_s", "release_complete_s", "release_margin_s", "overstretched_s",
                    "max_beta_deg")

#: Display units of the parameter table: the file's SI unit -> the unit an engineer reads it in (pint converts).
_DISPLAY_UNITS = {"Pa": "bar", "N": "kN", "m^3/s": "L/min"}


@functools.cache
def _converter(unit: str) -> tuple[str, Callable[[float], float]]:
    """The unit a value of declared ``unit`` is shown in, and its conversion (pint; the identity for a unit
    shown as it is declared)."""
    disp = _DISPLAY_UNITS.get(unit)
    if disp is None:
        return unit, lambda v: v
    import pint

    q = pint.get_application_registry().Quantity
    return disp, lambda v: float(q(v, unit).to(disp).magnitude)


def _display(value, unit: str) -> tuple[str, str]:
    """A parameter value and unit as an engineer reads them (bar, kN, L/min)."""
    disp, convert = _converter(unit)

    def one(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return str(v)
        return f"{convert(v):.6g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(one(v) for v in value) + "]", disp
    return one(value), disp


def _file_value(value) -> str:
    """A value as the file takes it (SI), exactly: it reads back as the same number."""
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_file_value(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.0f}" if value.is_integer() and abs(value) < 1e15 else repr(value)
    return str(value)


def parameter_rows(inst: Installation) -> list[dict]:
    """The report's parameter table: every declared parameter with this installation's value, its default and
    its valid range, all three in the unit the value is shown in (:data:`_DISPLAY_UNITS`), and the value as the
    file takes it (SI). Found: values in bar beside a range in Pa (``1 bar ... (0, 1e+07] Pa``).

    Parameters
    ----------
    inst : Installation

    Returns
    -------
    list of dict
        Keys ``key``, ``value``, ``unit``, ``default``, ``range``, ``file``, ``description``, ``source``.
    """
    rows = []
    for row in parameter_table():
        section, key = row["key"].split(".", 1)
        model = type(getattr(inst, section))
        raw = getattr(getattr(inst, section), key)
        value, unit = _display(raw, row["unit"])
        default = row["default"]
        if not default.startswith("required"):
            default = _display(model.model_fields[key].get_default(call_default_factory=True), row["unit"])[0]
        rng = range_text(model, key, _converter(row["unit"])) or row["range"]
        file = _file_value(raw) + (f" {row['unit']}" if row["unit"] not in ("", "1", "path") else "")
        rows.append({**row, "value": value, "unit": unit, "default": default, "range": rng, "file": file})
    return rows


#: Seconds of the moored ship's motion the bank section's manifold loads run through (the berth's design
#: environment, seed 1; docs/bank.md's figure is the same record, ``docsgen.BANK_RECORD``).
BANK_RECORD_S = 300.0

#: Samples of each timing law's plan: one plan per law serves the tables, the CSV, the figures, the MuJoCo check
#: and the closed loop (whose references need this density).
PLAN_SAMPLES = 2001


@dataclass
class ReportData:
    """Everything the report shows, computed once on first use.

    Attributes
    ----------
    inst : Installation
        The installation.
    source : Path or None
        The installation file (None for the built-in paper case); scenario paths are relative to it.
    """

    inst: Installation
    source: Path | None = None
    _progress: Callable[[str], None] = field(default=lambda _msg: None, repr=False)

    @cached_property
    def model(self):
        """The compiled :class:`~loadarm.arm.model.ArmModel` every computation below takes."""
        return compile_model(self.inst)

    @cached_property
    def sizing(self):
        """:class:`loadarm.design.sizing.SizingResult` of the datasheet."""
        self._progress("sizing the arm (Eqs 1-3)")
        return size_installation(self.inst)

    @cached_property
    def sizing_table(self) -> dict:
        """:func:`loadarm.design.sizing.sizing_summary`."""
        return sizing_summary(self.inst, self.sizing)

    @cached_property
    def plans(self) -> dict[str, Plan]:
        """One plan per timing law (``PLAN_SAMPLES`` samples), shared by every section."""
        out = {}
        for law in TIMING_LAWS:
            self._progress(f"planning the approach, {law} timing")
            out[law] = plan_approach(self.model, timing=law, samples=PLAN_SAMPLES)
        return out

    @cached_property
    def verification(self):
        """MuJoCo verification of the paper-timing plan."""
        self._progress("verifying the kinematics in MuJoCo")
        return verify_kinematics(self.model, self.plans["paper"])

    @cached_property
    def loads(self) -> dict:
        """Actuator loads by timing law."""
        self._progress("actuator loads")
        return {law: actuator_loads(self.model, p) for law, p in self.plans.items()}

    @cached_property
    def balance(self):
        """Counterweight balance over the envelope."""
        self._progress("counterweight balance")
        return balance_counterweights(self.model)

    @cached_property
    def simulations(self) -> dict:
        """Closed-loop runs by timing law."""
        self._progress("simulating the electro-hydraulic closed loop, three timing laws")
        return {law: simulate_approach(self.model, plan) for law, plan in self.plans.items()}

    @cached_property
    def check(self):
        """:func:`loadarm.design.check.design_check` of the installation."""

        self._progress("design check: drift absorbed per direction")
        return design_check(self.model)

    @cached_property
    def scenario_files(self) -> list[Path]:
        """The installation's ``[report] scenarios``, resolved against its file."""
        base = self.source.parent if self.source is not None else Path.cwd()
        return [(base / f) for f in self.inst.report.scenarios]

    @cached_property
    def scenarios(self) -> dict:
        """``name -> RunResult`` of each listed scenario, run on this installation (a moored scenario at the
        report's own berth takes the ship the report compiled: found, the demo compiled it twice)."""

        out = {}
        for f in self.scenario_files:
            self._progress(f"scenario {f.stem}")
            sc = resolve_berth(parse_scenario_file(f), f)
            same_berth = (sc.ship.model == "moored" and self.berth_file is not None
                          and Path(sc.ship.berth).resolve() == self.berth_file.resolve())
            out[f.stem] = run_scenario(sc, self.model, ship=self.ship if same_berth else None)
        return out

    @cached_property
    def berth_file(self) -> Path | None:
        """The installation's ``[report] berth``, resolved against its file."""
        if self.inst.report.berth is None:
            return None
        base = self.source.parent if self.source is not None else Path.cwd()
        return base / self.inst.report.berth

    @cached_property
    def berth(self):
        """:class:`loadarm.params.berth.Berth` of the report's berth (None without one)."""

        return None if self.berth_file is None else load_berth(self.berth_file)

    @cached_property
    def ship(self):
        """The berth's ship, compiled (:func:`loadarm.ship.model.compile_ship`)."""

        self._progress("the moored ship: hydrodynamics and moorings")
        return compile_ship(self.berth, source=str(self.berth_file))

    @cached_property
    def ship_summary(self):
        """:func:`loadarm.ship.summary.ship_summary` under the berth's design environment."""

        return ship_summary(self.ship, self.berth.environment)

    @cached_property
    def alarm_design(self):
        """:func:`loadarm.design.alarm_design.design_alarms` of this arm at the berth."""

        self._progress("alarm design: mooring analysis, intact and break-out")
        return design_alarms(self.model, self.ship, self.berth.environment)

    @cached_property
    def bank_file(self) -> Path | None:
        """The installation's ``[report] bank``, resolved against its file."""
        if self.inst.report.bank is None:
            return None
        base = self.source.parent if self.source is not None else Path.cwd()
        return base / self.inst.report.bank

    @cached_property
    def bank(self) -> dict | None:
        """The bank's checks, as ``check --bank`` makes them (None without a ``[report] bank``): ``file``, the read
        ``bank``, the ``order`` of its approaches and that schedule's ``clearance`` (at the design flanges), the
        ``corners`` of the flanging area (their least clearance, where, their orders:
        :func:`~loadarm.design.bank.order_over_flanging_area`), the ``swivels``' margins at the design case and
        their ``envelope`` over the flanging area and the ship's motions, its ``release``, its ``loads`` on the
        manifold and, with a berth, their ``record`` through :data:`BANK_RECORD_S` of the moored ship in the
        berth's design environment (seed 1). (Found by review: the report had drifted from the check, the design
        flanges only.)"""

        if self.bank_file is None:
            return None
        self._progress("the bank: clearance, manifold loads, emergency release")
        bank = load_bank(self.bank_file)
        record = None
        if self.berth is not None:
            env = self.berth.environment
            record = motion_manifold_loads(bank, simulate(self.ship, env, BANK_RECORD_S, seed=1),
                                           wind=berth_wind(env))
        checks = check_bank(bank)                  # as check --bank: every check and its refusals, in one place
        order = checks.order
        # without an order (refused), the clearance of every arm approaching at once: where they meet
        clearance = order.clearance if order is not None else check_bank_approaches(bank)
        return {"file": self.bank_file, "bank": bank, "checks": checks, "refusals": list(checks.refusals),
                "order": order, "clearance": clearance, "corners": checks.corners(),
                "swivels": checks.swivel_margins, "envelope": checks.swivels, "release": checks.release,
                "loads": checks.loads, "record": record}

    @cached_property
    def operability(self):
        """``loadarm operability`` of this arm at the report's berth over its ``[report] metocean`` (the local
        cluster; its chunks in a scratch folder), or None without a record or an installation file."""
        import tempfile

        if self.inst.report.metocean is None or self.source is None:
            return None
        self._progress("operability over the metocean record (Dask)")
        with tempfile.TemporaryDirectory(prefix="loadarm-operability-") as tmp:
            return run_operability(self.source, self.berth_file, self.source.parent / self.inst.report.metocean,
                                   Path(tmp) / "operability.parquet", ship=self.ship)


def _operability_rows(od: dict) -> list[dict]:
    """The operability section's headline table from its summary (the rows ``loadarm operability`` prints)."""

    rows = [("metocean record", od["metocean"])] + headline_rows(od)
    return [{"k": k, "v": v} for k, v in rows]


def _reconciliation_rows(stages) -> list[dict]:
    """Configured against recommended, per face and stage, side by side (the alarm design's :class:`StageFit`)."""
    pairs: dict[tuple, dict] = {}
    for f in stages:
        row = pairs.setdefault((f.direction, f.stage), {"dir": f.direction, "face": f.face, "stage": f.stage})
        key = "c" if f.settings == "configured" else "r"
        row.update({f"{key}_deg": f.angle_deg, f"{key}_at": f.fires_at_m if f.fires_at_m is not None else "not before",
                    f"{key}_margin": f.margin_m, f"{key}_case": f.governs + ("" if f.ok else " (SHORT)")})
    return list(pairs.values())


def _timeline(name: str):
    return lambda d: d.scenarios[name].plot()      # the run carries its own thresholds


#: Every fixed figure of the report: ``file name -> (builder, caption)``. Scenario timelines are added per
#: scenario. ``make docs`` draws the ones the docs show from the paper's case with the same builders.
FIGURES: dict[str, tuple[Callable[[ReportData], object], str]] = {
    "sizing.png": (lambda d: d.sizing.plot(),
                   "Eq. 3 in the (b, c) plane: the first-alarm ellipse, the bounds, the local minima and the optimum."),
    "envelope.png": (lambda d: envelope_figure(d.model, d.plans["smooth"]),
                     "Zones as bands of beta around the riser top, datasheet flange box, stored position, flange and "
                     "the straight approach with arm snapshots."),
    "alpha_beta.png": (lambda d: alpha_beta_figure({"straight line": d.plans["paper"]}),
                       "Fig. 6 equivalent: alpha versus beta along the straight line."),
    "angles_paper.png": (lambda d: angles_time_figure(d.model, d.plans["paper"]),
                         "Fig. 8 equivalent, paper timing: closed form (lines) against the paper's literal Eqs 7-11 "
                         "(markers)."),
    "angles_smooth.png": (lambda d: angles_time_figure(d.model, d.plans["smooth"]),
                          "Fig. 8 equivalent, smooth timing."),
    "timing.png": (lambda d: timing_figure(d.plans, d.model.approach.max_speed),
                   "Coupler speed for the three timing laws (paper, smooth, optimal)."),
    "cylinders.png": (lambda d: cylinders_figure(d.plans), "Fig. 9 equivalent: cylinder pin-to-pin lengths."),
    "voltages.png": (lambda d: voltages_figure(d.plans), "Fig. 10 equivalent: valve voltages."),
    "verification.png": (lambda d: verification_figure(d.verification),
                         "Closed form (lines) against MuJoCo (markers), and their differences."),
    "loads.png": (lambda d: loads_figure(d.loads), "Cylinder forces and working pressures along the approach."),
    "residual_torque.png": (lambda d: residual_torque_figure(d.balance),
                            "Residual static torque over the envelope, worst fill case."),
    "deviation_by_timing.png": (lambda d: timing_comparison_figure(d.simulations),
                                "Deviation of the simulated coupler from the straight line, by timing law."),
    "simulation_smooth.png": (lambda d: simulation_figure(d.simulations["smooth"]),
                              "Smooth timing: deviation, tracking errors, pressures, valve commands, pump."),
    "check.png": (lambda d: d.check.plot(),
                  "Design check: per drift direction, the distance to the first face of the envelope (grey), the "
                  "design drift's distance during the first alarm's lead (hatched), where the first alarm fires at "
                  "the latest (bar) and the customer's first-alarm angle (triangle; red past the bar: late on its "
                  "own, the floor fires first, and the verdict is never a plain pass)."),
}


#: The berth section's figures (drawn when the installation names a ``[report] berth``).
BERTH_FIGURES: dict[str, tuple[Callable[[ReportData], object], str]] = {
    "rao.png": (lambda d: d.ship_summary.plot(),
                "Motion RAOs of the design ship at its centre of gravity (capytaine; moored, with viscous roll "
                "damping) for beam (90 deg), quartering (135 deg) and head (180 deg) seas."),
    "alarm_design.png": (lambda d: d.alarm_design.plot(),
                         "Alarm design: the flanging area, the intact drift allowance and each stage's beta zone "
                         "(left); the break-out drift with the sequence's stages (right)."),
}


#: The bank section's figures (drawn when the installation names a ``[report] bank``; the record's with a berth).
BANK_FIGURES: dict[str, tuple[Callable[[ReportData], object], str]] = {
    "bank_clearance.png": (lambda d: d.bank["clearance"].plot(),
                           "The bank's arms approaching their flanges all at once: the clearance of each pair, the "
                           "smallest marked, the required clearance dashed."),
    "bank_manifold_loads.png": (lambda d: d.bank["loads"].plot(),
                                "Each arm's worst load on its flange as a share of the allowable, over the design "
                                "case, the flange box's corners, the wind from 12 directions and calm and the "
                                "friction's extremes (bars); the design case alone, calm, without friction (dark)."),
    "bank_release.png": (lambda d: d.bank["release"].plot(),
                         "One emergency release for all on the shared power unit's accumulators, the pumps lost."),
}
BANK_RECORD_FIGURE = ("bank_manifold_record.png",
                      "The arms' loads on their flanges through the moored ship's motion in the berth's design "
                      "environment, as shares of the allowable (allowable dashed).")


#: The operability section's figure (drawn when the installation names a ``[report] metocean``).
OPERABILITY_FIGURE = ("operability.png", "Operability over the metocean record: downtime per month, over Hs and Tp "
                                         "(hours per cell), and the worst week in time.")


def figure_builders(data: ReportData) -> dict[str, tuple[Callable[[ReportData], object], str]]:
    """:data:`FIGURES` plus one timeline per scenario of the installation.

    Parameters
    ----------
    data : ReportData
        The report's data (its scenario list).

    Returns
    -------
    dict
        ``file name -> (builder, caption)``.
    """
    figs = dict(FIGURES)
    if data.inst.report.berth is not None:
        figs.update(BERTH_FIGURES)
    if data.inst.report.bank is not None:
        figs.update(BANK_FIGURES)
        if data.inst.report.berth is not None:
            figs[BANK_RECORD_FIGURE[0]] = (lambda d: d.bank["record"].plot(), BANK_RECORD_FIGURE[1])
    if data.inst.report.metocean is not None and data.source is not None:
        figs[OPERABILITY_FIGURE[0]] = (lambda d: d.operability.plot(), OPERABILITY_FIGURE[1])
    for f in data.scenario_files:
        figs[f"timeline_{f.stem}.png"] = (_timeline(f.stem), f"Timeline of scenario {f.stem}.")
    return figs


@functools.cache
def _template():
    """The report's HTML template (package data), autoescaped."""
    from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

    env = Environment(loader=PackageLoader("loadarm.present", "templates"), autoescape=select_autoescape(["html", "j2"]),
                      undefined=StrictUndefined, keep_trailing_newline=True)
    return env.get_template("report.html.j2")


#: The report's sections in order: ``key -> (number, title, shown when)``; the template's headings and its table
#: of contents both read them here. ``when``: always, or only with a ``[report] berth``, ``metocean`` or ``bank``.
SECTIONS = {
    "sizing": ("1", "Arm sizing (paper Eqs 1-3, Table 1)", "always"),
    "envelope": ("2", "Operating envelope and alarm zones (paper Fig. 4)", "always"),
    "approach": ("3", "Straight-line approach (paper Eqs 4-11, 14)", "always"),
    "cylinders": ("4", "Cylinders and valve commands (paper Eqs 12-13, Section 5)", "always"),
    "mujoco": ("5", "Multibody verification in MuJoCo (paper Section 4, Fig. 8)", "always"),
    "dynamics": ("6", "Dynamics, counterweights and actuator sizing", "always"),
    "closed_loop": ("7", "Electro-hydraulic closed loop (paper Fig. 11)", "always"),
    "check": ("8", "Connected-mode safety: the design check", "always"),
    "berth": ("8b", "The berth: moored ship and alarm design", "berth"),
    "operability": ("8c", "Operability over the metocean record", "metocean"),
    "bank": ("8d", "The bank of arms: clearance, loads on the manifold, emergency release", "bank"),
    "scenarios": ("9", "Live guidance to a moving ship (scenarios)", "always"),
    "parameters": ("10", "Parameters", "always"),
}


def report_sections(berth: bool, metocean: bool, bank: bool = False) -> list[dict]:
    """The sections a report shows, in order, each with its anchor, number and title.

    Parameters
    ----------
    berth, metocean : bool
        Whether the installation names a ``[report] berth`` and a ``metocean`` (run).
    bank : bool
        Whether it names a ``[report] bank``.

    Returns
    -------
    list of dict
        ``{"key", "id", "number", "title", "heading"}``.
    """
    shown = {"always": True, "berth": berth, "metocean": metocean, "bank": bank}
    return [{"key": k, "id": f"s-{k.replace('_', '-')}", "number": n, "title": t, "heading": f"{n}. {t}"}
            for k, (n, t, when) in SECTIONS.items() if shown[when]]


#: The approval block of the title page: who signs, in order.
APPROVALS = ("prepared", "checked", "approved")


def _input_digest(source: Path | None, inst: Installation) -> str:
    """SHA-256 of the installation file (of its canonical JSON for the built-in case)."""
    data = source.read_bytes() if source is not None else inst.model_dump_json().encode()
    return hashlib.sha256(data).hexdigest()


def document_identity(inst: Installation, source: Path | None) -> dict:
    """The document number and revision of the title page (``[report] document`` and ``revision``; the number
    defaults to ``LA-`` and the first 8 hex digits of the input's SHA-256, so a changed file is another document).

    Parameters
    ----------
    inst : Installation
    source : Path or None
        The installation file.

    Returns
    -------
    dict
        ``number``, ``revision``, ``sha256``.
    """
    digest = _input_digest(source, inst)
    return {"number": inst.report.document or f"LA-{digest[:8].upper()}", "revision": inst.report.revision,
            "sha256": digest}


def _input_line(source: Path | None) -> str:
    if source is None:
        return "input: the built-in paper case (loadarm.params.config.paper_installation)"
    digest = hashlib.sha256(source.read_bytes()).hexdigest()
    return f"input: {source.name} (sha256 {digest[:16]}…)"


def report_outputs(inst: Installation, out_dir: str | Path, source: str | Path | None = None, *,
                   pdf: bool = False) -> tuple[list[Path], list[Path]]:
    """Every file :func:`build_report` writes, known before anything is computed, and the scenario files it reads.

    Parameters
    ----------
    inst : Installation
    out_dir : str or Path
    source : str or Path, optional
        The installation file (its ``[report] scenarios`` are relative to it).
    pdf : bool
        With ``report.pdf``.

    Returns
    -------
    outputs, scenario_inputs : list of Path
    """
    out = Path(out_dir)
    base = Path(source).parent if source is not None else Path.cwd()
    oper = inst.report.metocean is not None and source is not None
    names = list(FIGURES) + (list(BERTH_FIGURES) if inst.report.berth is not None else []) + [
        f"timeline_{Path(f).stem}.png" for f in inst.report.scenarios] + ([OPERABILITY_FIGURE[0]] if oper else [])
    if inst.report.bank is not None:
        names += list(BANK_FIGURES) + ([BANK_RECORD_FIGURE[0]] if inst.report.berth is not None else [])
    inputs = ([base / f for f in inst.report.scenarios] + ([base / inst.report.berth] if inst.report.berth else [])
              + ([base / inst.report.metocean] if oper else []) + ([base / inst.report.bank] if inst.report.bank else []))
    return ([out / "report.html", out / "summary.json"] + ([out / "report.pdf"] if pdf else [])
            + [out / f"plan_{law}.csv" for law in TIMING_LAWS]
            + [out / "figures" / n for n in names] + ([out / "operability.parquet"] if oper else [])), inputs


def _bank_summary(b: dict | None) -> dict | None:
    """summary.json's ``bank``: the bank file and each check's numbers (None without a ``[report] bank``)."""
    if b is None:
        return None
    return {"file": b["file"].name, **b["checks"].to_dict(),
            "clearance": b["clearance"].to_dict(),          # without an order: every arm approaching at once
            "clearance_all_at_once": b["order"] is None,
            # the allowable loads' standing: the document that confirms them, or the keys left at OCIMF's
            # figures as commonly quoted (the verdict on them is unconfirmed)
            "allowables_confirmed_by": b["bank"].file.manifold_loads.confirmed_by,
            "allowables_unconfirmed": list(b["bank"].file.manifold_loads.as_quoted()),
            "manifold_record": None if b["record"] is None else b["record"].to_dict()}


def _bank_rows(b: dict | None) -> list[dict]:
    """The bank section's table: per arm, its flange, its nearest arm on the approach, its worst load on the
    manifold and its share of the allowable (the design check and the ship's record), its release."""
    if b is None:
        return []
    bank, clearance, loads, release, record = b["bank"], b["clearance"], b["loads"], b["release"], b["record"]
    pairs = None if clearance is None else clearance.pair_minimum.min(axis=1)
    rows = []
    for i, name in enumerate(bank.names):
        near = math.nan if pairs is None else \
            min(float(g) for (p, q), g in zip(clearance.pairs, pairs, strict=True) if i in (p, q))
        j = int(loads.utilisation[i].argmax())
        rows.append({"arm": name, "flange": f"{bank.flanges[i].name} ({bank.flanges[i].product})", "near": near,
                     "wave": "-" if b["order"] is None else b["order"].wave_of(name) + 1, "swivel": math.degrees(float(b["swivels"][i].min())),
                     "moving": math.degrees(float(b["envelope"].by_arm()[i])),
                     "load": LOAD_LABELS[j], "use": float(loads.utilisation[i, j]),
                     "rec": "-" if record is None else f"{float((record.worst[i] / record.allowable).max()):.2f}",
                     "clear": float(release.end[i, 2])})
    return rows


def build_report(inst: Installation, out_dir: str | Path, *, title: str = "loadarm report",
                 source: str | Path | None = None, now: datetime | None = None,
                 progress: Callable[[str], None] | None = None, force: bool = False,
                 pdf: bool = False) -> ReportFiles:
    """Run sizing, envelope, the three timing laws, dynamics, the closed loop and the scenarios; write the report.

    Parameters
    ----------
    inst : Installation
        The installation.
    out_dir : str or Path
        Output directory, created if needed.
    title : str
        Report title.
    source : str or Path, optional
        The installation file: named and hashed in the report; ``[report] scenarios`` are relative to it.
    now : datetime, optional
        Time stamp printed in the report (default: the current UTC time; injected for reproducible output).
    progress : callable, optional
        Called with a short description before each step (for a progress bar).
    force : bool
        Replace existing files of the same names that loadarm did not write (:func:`loadarm.files.guard_outputs`).
    pdf : bool
        Print ``report.pdf`` from the HTML with Chromium as well (:func:`loadarm.present.pdf.print_pdf`; without
        Chromium refused before any work).

    Returns
    -------
    ReportFiles
        The files written (each atomically).

    Raises
    ------
    OutputError
        Before anything is computed: an output would replace an input or a file loadarm did not write.
    """
    outputs, scenario_files = report_outputs(inst, out_dir, source, pdf=pdf)
    guard_outputs([("--out", p) for p in outputs], [*scenario_files, *([Path(source)] if source is not None else [])],
                  force=force)
    chromium = chromium_or_fail() if pdf else None
    step = progress or (lambda _msg: None)
    src = Path(source) if source is not None else None
    stamp = (now or datetime.now(timezone.utc)).strftime("%Y-%m-%d %H:%M UTC")
    paper = is_paper_case(inst)
    out = Path(out_dir)
    figdir = out / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    d = ReportData(inst, src, step)

    sizing, sz = d.sizing, d.sizing_table
    arm = d.model.arm
    corners_sized, corners_conf = sz["corners"], sz["corners_configured_arm"]
    plans = d.plans
    csvs = {law: p.write_csv(out / f"plan_{law}.csv") for law, p in plans.items()}
    verification, loads, balance, sims, scen_runs = d.verification, d.loads, d.balance, d.simulations, d.scenarios
    check = d.check
    berth = d.berth
    if berth is not None:
        ship_sum, design = d.ship_summary, d.alarm_design
    oper = d.operability
    bank = d.bank
    if oper is not None:

        write_parquet(oper.table, out / "operability.parquet")

    step("drawing figures")
    builders = figure_builders(d)
    figs = {name: save(build(d), figdir / name) for name, (build, _caption) in builders.items()}

    step("writing report")
    summary = {"generator": f"{SIGNATURE} {__version__}", **summary_dict(inst, plans, sz, d.model)}
    summary["generated"] = stamp
    summary["input"] = _input_line(src).removeprefix("input: ")
    summary["verification"] = verification.summary()
    summary["loads"] = {law: ld.summary() for law, ld in loads.items()}
    summary["balance"] = balance.summary()
    summary["simulation"] = {law: r.summary() for law, r in sims.items()}
    summary["check"] = check.to_dict()
    if berth is not None:
        summary["berth"] = {"file": str(d.berth_file.name), "ship": ship_sum.to_dict(),
                            "alarm_design": design.to_dict()}
    if bank is not None:
        summary["bank"] = _bank_summary(bank)
    verdict = alarm_verdict(check, design if berth is not None else None)
    summary["verdict"] = {"status": verdict.status, "reason": verdict.reason}
    if oper is not None:
        od = oper.to_dict()
        od.pop("wall_s", None)                # wall time and workers depend on the machine: not in the report
        od.pop("workers", None)
        summary["operability"] = {"metocean": Path(inst.report.metocean).name, **od}
    # wall-clock cycle times depend on the machine and its load: they belong to `loadarm run`, not the report
    summary["scenarios"] = {name: {k: v for k, v in rr.summary().items() if not k.startswith("cycle_us")}
                            for name, rr in scen_runs.items()}
    summary_path = atomic_write(out / "summary.json", json.dumps(round_floats(summary), indent=2))

    box = berth_box(inst.datasheet)
    fx, fy = inst.approach.flange
    notes = []
    if not (box.x_near <= fx <= box.x_far and box.y_low <= fy <= box.y_high):
        notes.append(f"The configured flange ({fx:g}, {fy:g}) m lies outside the datasheet's flange box "
                     f"x in [{box.x_near:g}, {box.x_far:g}] m, y in [{box.y_low:g}, {box.y_high:g}] m"
                     + (" (the paper's example does this too)." if paper else "."))
    bad_conf = [c for c in corners_conf if c["zone"] != int(Severity.NORMAL)]
    if bad_conf:
        notes.append("With the configured arm (b = {:.3g} m, c = {:.3g} m) these corners are not in the normal zone: ".format(
            arm.b, arm.c) + "; ".join(f"{c['corner']}: {c['zone_label']}" for c in bad_conf) + ".")

    plan_rows = []
    for name, p in plans.items():
        s = p.summary()
        plan_rows.append({
            "law": name, "duration": s["duration_s"], "vmax": s["peak_path_speed_m_s"],
            "s1": s["stroke_ac1_m"], "s2": s["stroke_ac2_m"],
            "u1": f"{s['u1_range_V'][0]:+.3f} .. {s['u1_range_V'][1]:+.3f}",
            "u2": f"{s['u2_range_V'][0]:+.3f} .. {s['u2_range_V'][1]:+.3f}",
            "zone": s["worst_zone"],
        })
    p0 = plans["paper"]
    endpoint_rows = [
        {"pt": "start (stored)", "x": float(p0.x[0]), "y": float(p0.y[0]), "a": math.degrees(p0.alpha[0]),
         "b": math.degrees(p0.beta[0]), "r1": float(p0.r_ac1[0]), "r2": float(p0.r_ac2[0])},
        {"pt": "end (flange)", "x": float(p0.x[-1]), "y": float(p0.y[-1]), "a": math.degrees(p0.alpha[-1]),
         "b": math.degrees(p0.beta[-1]), "r1": float(p0.r_ac1[-1]), "r2": float(p0.r_ac2[-1])},
    ]
    params = parameter_rows(inst)
    vs = summary["verification"]
    bs = summary["balance"]
    ms = inst.masses
    mass_text = (f"pipes {ms.inboard_kg_per_m:g} / {ms.outboard_kg_per_m:g} kg/m, fill {ms.fill:g} of a "
                 f"{ms.pipe_inner_diameter * 1e3:g} mm bore at {ms.product_density:g} kg/m^3, elbow {ms.elbow_kg:g} kg, "
                 f"coupler {ms.coupler_kg:g} kg, counterweights {ms.counterweight_inboard_kg:g} kg at "
                 f"{ms.counterweight_inboard_distance:g} m and {ms.counterweight_outboard_kg:g} kg at "
                 f"{ms.counterweight_outboard_distance:g} m")
    scen_cols = [m for m in RUN_METRICS if m.key in _REPORT_RUN_KEYS]
    scen_rows = [{"name": name, "seq": " > ".join(ss["mode_sequence"]),
                  **{m.key: m.format(ss.get(m.key), unit=False) for m in scen_cols}}
                 for name, ss in summary["scenarios"].items()]
    sim_cols = [m for m in SIMULATION_METRICS if m.key in _REPORT_SIM_KEYS]
    sim_rows = [{**{m.key: m.format(sm.get(m.key), unit=False) for m in sim_cols},
                 "warnings": "; ".join(sm["warnings"]) or "none"} for sm in summary["simulation"].values()]
    load_rows = [{"law": law, "cyl": str(i), **{m.key: m.format(ld[f"cylinder{i}"][m.key], unit=False)
                                                for m in CYLINDER_LOAD_METRICS},
                  "ok": "yes" if ld[f"cylinder{i}"]["pressure_ok"] else "NO"}
                 for law, ld in summary["loads"].items() for i in (1, 2)]
    corner_cols = [("corner", "corner"), ("x_m", "x [m]"), ("y_m", "y [m]"), ("r_m", "r [m]"),
                   ("alpha_deg", "alpha [deg]"), ("beta_deg", "beta [deg]"), ("zone_label", "zone")]
    tables = {
        "corners_sized": _table(corners_sized, corner_cols),
        "corners_configured": _table(corners_conf, corner_cols),
        "endpoints": _table(endpoint_rows, [("pt", "point"), ("x", "x [m]"), ("y", "y [m]"), ("a", "alpha [deg]"),
                                            ("b", "beta [deg]"), ("r1", "r_ac1 [m]"), ("r2", "r_ac2 [m]")]),
        "plans": _table(plan_rows, [("law", "timing law"), ("duration", "duration [s]"),
                                    ("vmax", "peak path speed [m/s]"), ("s1", "stroke 1 [m]"), ("s2", "stroke 2 [m]"),
                                    ("u1", "u1 [V]"), ("u2", "u2 [V]"), ("zone", "worst zone")],
                        {"duration": ".2f", "vmax": ".4f"}),
        "loads": _table(load_rows, [("law", "timing law"), ("cyl", "cylinder")]
                        + [(m.key, m.header) for m in CYLINDER_LOAD_METRICS] + [("ok", "within rating")]),
        "simulation": _table(sim_rows, [(m.key, m.header) for m in sim_cols] + [("warnings", "warnings")]),
        "check": _table([{"dir": r.direction, "face": r.face or "-", "avail": r.available, "alarm": r.alarm_at,
                          "needed": r.needed, "vmax": r.max_speed, "ok": "yes" if r.ok else "NO"} for r in check.rows],
                        [("dir", "direction"), ("face", "first face"), ("avail", "available [m]"),
                         ("alarm", "first alarm at [m]"), ("needed", "design drift needs [m]"),
                         ("vmax", "absorbs [m/s]"), ("ok", "ok")],
                        {"avail": ".2f", "alarm": ".2f", "needed": ".2f", "vmax": ".3f"}),
        "berth": _table([{"k": label, "v": text} for label, text in ship_sum.summary().rows()]
                        if berth is not None else [], [("k", "quantity"), ("v", "value")]),
        "alarm_design": _table([
            {"dir": r.direction, "face": r.face or "-", "case": r.short_case, "allow": r.allowance_m,
             "esd": r.esd_m, "rel": r.release_m, "lead": r.lead_m, "avail": r.available_m,
             "angles": "-" if r.first is None else " / ".join(f"{math.degrees(v):.1f}" for v in (r.first, r.second,
                                                                                                  r.release)),
             "ok": "yes" if r.ok else "NO"} for r in (design.rows if berth is not None else ())],
            [("dir", "direction"), ("face", "face"), ("case", "design case"), ("allow", "drift allowance [m]"),
             ("esd", "ESD-1 at [m]"), ("rel", "ERS-2 at [m]"), ("lead", "ESD-1 lead reaches [m]"),
             ("avail", "face at [m]"), ("angles", "first / second / release [deg]"), ("ok", "ok")],
            {"allow": ".2f", "esd": ".2f", "rel": ".2f", "lead": ".2f", "avail": ".2f"}),
        "reconciliation": _table(_reconciliation_rows(design.stages if berth is not None else ()), [
            ("dir", "direction"), ("face", "face"), ("stage", "stage"), ("c_deg", "configured [deg]"),
            ("c_at", "fires at [m]"), ("c_margin", "margin [m]"), ("c_case", "governs"),
            ("r_deg", "recommended [deg]"), ("r_at", "fires at [m]"), ("r_margin", "margin [m]"),
            ("r_case", "governs")], {"c_deg": ".1f", "r_deg": ".1f", "c_at": ".2f", "r_at": ".2f",
                                     "c_margin": "+.2f", "r_margin": "+.2f"}),
        "operability": _table(_operability_rows(summary["operability"]) if oper is not None else [],
                              [("k", "quantity"), ("v", "value")]),
        "operability_stages": _table(
            [{"stage": k, "n": v} for k, v in summary["operability"]["states_by_stage"].items()]
            if oper is not None else [], [("stage", "most severe stage reached"), ("n", "hourly states")]),
        "bank_summary": _table([{"k": label, "v": text} for r in (("order", "clearance", "envelope", "loads",
                                                                   "release") if bank else ())
                                if bank[r] is not None
                                for label, text in bank[r].summary().rows()], [("k", "quantity"), ("v", "value")]),
        "bank": _table(_bank_rows(bank), [("arm", "arm"), ("flange", "flange"), ("wave", "approach wave"),
                                          ("near", "nearest arm on approach [m]"),
                                          ("swivel", "swivel margin, design case [deg]"),
                                          ("moving", "swivel margin, flanging area and ship's motions [deg]"),
                                          ("load", "governing load"), ("use", "load / allowable, design check"),
                                          ("rec", "load / allowable, ship's record"), ("clear", "release: clear at [s]")],
                       {"near": ".2f", "swivel": ".1f", "moving": ".1f", "use": ".2f", "clear": ".2f"}),
        "scenarios": _table(scen_rows, [("name", "scenario"), ("seq", "modes")]
                            + [(m.key, m.header) for m in scen_cols]),
        "parameters": _table(params, [("key", "key"), ("value", "value"), ("unit", "unit"), ("default", "default"),
                                      ("range", "valid range"), ("file", "in the file (SI)"),
                                      ("description", "description"), ("source", "source")]),
    }
    figure_data = {name: _figure(path, builders[name][1]) for name, path in figs.items()}
    doc = document_identity(inst, src)
    sections = report_sections(berth is not None, oper is not None, bank is not None)
    text = _template().render(
        doc=doc, sections=sections, verdict=verdict, section={x["key"]: x for x in sections}, approvals=APPROVALS, mark=PDF_TITLE_MARK,
        title=title, css=_CSS.replace("__DOCID__", f"{doc['number']} rev {doc['revision']}"), stamp=stamp, version=__version__, input_line=_input_line(src), notes=notes,
        sizing=sizing, inst=inst, paper=paper, arm=arm, tables=tables, figures=figure_data,
        local_minima=", ".join(f"({b:.3f}, {c:.3f})" for b, c in sizing.local_minima),
        paper_peak_speed=plans["paper"].summary()["peak_path_speed_m_s"], csv_names=[p.name for p in csvs.values()],
        vs=vs, bs=bs, mass_text=mass_text, scenario_files=", ".join(f.name for f in d.scenario_files),
        timelines=[f"timeline_{n}.png" for n in scen_runs], check=check, seq=d.model.sequence,
        berth=berth, berth_file=d.berth_file.name if berth is not None else "",
        design=design if berth is not None else None, oper=summary.get("operability"),
        oper_settings=inst.operability, verify_samples=VERIFY_SAMPLES, bank=bank,
        arrival_note=arrival_note(next(iter(summary["simulation"].values()))["arrival_tolerance_mm"]))
    html_path = atomic_write(out / "report.html", text)
    pdf_path = None
    if chromium is not None:
        step("printing report.pdf (Chromium)")
        pdf_path = print_pdf(html_path, out / "report.pdf", chromium=chromium)
    return ReportFiles(html=html_path, summary=summary_path, csv=csvs, figures=figs, pdf=pdf_path)
