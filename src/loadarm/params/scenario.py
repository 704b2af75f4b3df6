"""Scenario files: the ship, the sea, the flange sensor, the operator and the guidance settings.

A scenario TOML (see ``examples/scenarios/``) names an installation file and
describes one run. Every parameter is declared here once with unit, range,
default and source, like the installation's (:mod:`loadarm.params.config`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model, model_validator

from loadarm.arm.sequence import esd_lead
from loadarm.errors import ConfigError
from loadarm.params.berth import Berth, Environment, load_berth
from loadarm.params.compiler import compile_model
from loadarm.params.config import load_config, paper_installation, read_toml
from loadarm.params.declare import format_validation_error, param, toml_values, valid_range_text

if TYPE_CHECKING:
    from loadarm.arm.model import ArmModel

__all__ = ["resolve_berth", "scenario_environment", "EnvironmentOverride", "MooringFailure", "Ship", "Waves", "Drift", "Sensor", "Operator", "Guidance", "GuidanceSettings", "Faults", "Scenario", "load_scenario", "read_scenario", "parse_scenario_file",
           "parse_scenario", "check_scenario", "check_drift_window", "check_run_size", "run_memory", "MAX_RUN_MEMORY"]


class _S(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class Ship(_S):
    """Where the flange is, how it moves slowly (tide, loading), and which ship model moves it."""

    model: Literal["simple", "moored"] = Field(
        "simple", description="flange motion: simple (three wave gains, [waves] and [drift]) or moored (the "
                              "berth file's ship on its moorings, [environment] and [mooring_failure])",
        json_schema_extra={"unit": "", "source": "issue 12: the moored ship replaces the gains"})
    berth: str | None = Field(None, description="berth TOML for model = moored, relative to the scenario file",
                              json_schema_extra={"unit": "", "source": ""})

    flange: tuple[float, float, float] = param((14.0, 0.0, 1.0), unit="m", source="the paper's flange, on the arm's axis",
                                               description="flange position (x out, y along the berth, z up) at t = 0")
    tide_rate: float = param(0.0, unit="m/s", ge=-0.01, le=0.01, source="up to about 2 m per hour in tidal ports",
                             description="vertical speed of the water level")
    draft_rate: float = param(0.0, unit="m/s", ge=-0.01, le=0.01,
                              source="a ship loading 10 m of draft over 24 h sinks about 1e-4 m/s",
                              description="vertical speed of the flange from loading (negative: sinking)")
    history: float = param(0.0, unit="s", ge=0, le=7200,
                           source="a terminal's berth monitoring watches a moored ship from its mooring on, hours "
                                  "before the arm connects; 0 = the run starts with no track",
                           description="how long the flange's track before the run starts is known (the flange "
                                       "sensor's readings of the ship at its berth): the predictor is fitted and "
                                       "calibrated on it")
    line_load_monitoring: bool = Field(
        True, description="model = moored: the berth's mooring load monitoring (load cells on the quick-release "
                          "hooks) reports each line's load to the guidance once a second; the predictive alarms "
                          "hold a change detector's call only while it says the moorings hold "
                          "(loadarm.guidance.moorings)",
        json_schema_extra={"unit": "", "source": "OCIMF MEG4 recommends mooring load monitoring at "
                                                 "terminals (the judgement of its readings is loadarm's); false = "
                                                 "no link to it"})

    @model_validator(mode="after")
    def _finite(self) -> "Ship":
        if not all(math.isfinite(v) and abs(v) <= 1000 for v in self.flange):
            raise ValueError(f"ship.flange must be three finite coordinates within 1000 m, got {list(self.flange)}")
        return self


class Waves(_S):
    """Wave-induced flange motion from a JONSWAP sea (a simple documented response model)."""

    hs: float = param(0.0, unit="m", ge=0, le=8, source="0 = calm; berths operate up to about Hs 1.5-2 m",
                      description="significant wave height")
    tp: float = param(8.0, unit="s", gt=1, le=30, source="typical swell at an exposed berth",
                      description="peak period")
    gamma: float = param(3.3, unit="1", ge=1, le=10, source="JONSWAP mean peak enhancement (Hasselmann 1973)",
                         description="peak enhancement factor")
    surge_gain: float = param(0.3, unit="m/m", ge=0, le=5, source="moored tanker, beam seas (engineering estimate)",
                              description="flange surge (along the berth) per metre of wave elevation")
    sway_gain: float = param(0.5, unit="m/m", ge=0, le=5, source="moored tanker, beam seas (engineering estimate)",
                             description="flange sway (off the berth) per metre of wave elevation")
    heave_gain: float = param(0.6, unit="m/m", ge=0, le=5, source="moored tanker, beam seas (engineering estimate)",
                              description="flange heave per metre of wave elevation")
    cutoff_period: float = param(6.0, unit="s", gt=0, le=60,
                                 source="a large ship filters out waves much shorter than itself",
                                 description="period below which the ship's response rolls off (second order)")
    components: int = Field(200, ge=10, le=5000, description="number of wave components",
                            json_schema_extra={"unit": "1", "source": "enough for a smooth spectrum"})


class Drift(_S):
    """Drift-off of the ship away from the berth (mooring failure)."""

    start: float | None = param(None, unit="s", ge=0, source="none by default",
                                description="time the drift starts (omit for no drift)")
    speed: float = param(0.1, unit="m/s", gt=0, le=2, source="a tanker drifting off under wind, about 0.1-0.3 m/s",
                         description="drift speed")
    direction_deg: float = param(0.0, unit="deg", ge=-180, le=180, source="straight off the berth",
                                 description="drift direction in the horizontal plane, from +x towards +y")
    acceleration: float = param(0.01, unit="m/s^2", gt=0, le=1, source="engineering estimate",
                                description="how fast the drift reaches its speed")


class Sensor(_S):
    """Flange position sensor: rate, noise, latency, dropouts, outliers."""

    rate: float = param(10.0, unit="Hz", gt=0, le=1000, source="laser / radar flange tracker",
                        description="measurement rate")
    noise: float = param(0.01, unit="m", ge=0, le=1, source="laser tracker at 20 m", description="noise std per axis")
    latency: float = param(0.05, unit="s", ge=0, le=5, source="processing and network", description="delay")
    dropout_probability: float = param(0.0, unit="1", ge=0, lt=1, source="none by default",
                                       description="probability that one measurement is lost")
    dropouts: tuple[tuple[float, float], ...] = param((), unit="s", source="none by default",
                                                      description="windows [start, end] with no measurement at all")

    @model_validator(mode="after")
    def _dropout_windows(self) -> "Sensor":
        for w in self.dropouts:            # found: [[48, 40]] was silently ignored
            if not 0 <= w[0] < w[1]:
                raise ValueError(f"sensor.dropouts windows must be [start, end] with 0 <= start < end, got {list(w)}")
        return self
    outlier_probability: float = param(0.0, unit="1", ge=0, lt=1, source="none by default",
                                       description="probability that a measurement is an outlier")
    outlier_size: float = param(2.0, unit="m", gt=0, le=100, source="a reflection off the wrong target",
                                description="size of an outlier's error")


class Operator(_S):
    """What the operator does and when."""

    start: float = param(1.0, unit="s", ge=0, source="scenario choice", description="time the approach is started")
    connect_after: float = param(20.0, unit="s", ge=0, source="manual connection of the coupler on the ship",
                                 description="time in standoff before the operator connects")
    disconnect_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                        description="time of a normal disconnection (omit for none)")
    estop_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                   description="time the emergency stop is pressed (omit for none)")
    reset_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                   description="time the operator resets after an emergency stop (omit for none)")
    ack_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                 description="time the operator acknowledges the alarms (omit for none)")
    esd_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                 description="time the operator presses the manual ESD-1 (omit for none)")
    ers_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                 description="time the operator arms the manual ERS; it is confirmed "
                                              "ers_confirm_after later (omit for none)")
    ers_confirm_after: float | None = param(2.0, unit="s", ge=0, source="operator's reaction (omit: never confirmed)",
                                            description="delay from arming the manual ERS to confirming it")
    jog: tuple[tuple[float, float, float, float, float], ...] = param(
        (), unit="s, m/s", source="none by default",
        description="manual jog segments [start, end, vx, vy, vz]: the operator takes manual control at start, "
                    "holds the joystick at (vx, vy, vz) and hands back to automatic at end")

    @model_validator(mode="after")
    def _jog_segments(self) -> "Operator":
        for seg in self.jog:
            if not (0 <= seg[0] < seg[1] and all(math.isfinite(v) for v in seg)):
                raise ValueError(f"operator.jog segments must be [start, end, vx, vy, vz] with 0 <= start < end, "
                                 f"got {list(seg)}")
        return self


class Guidance(_S):
    """Guidance controller settings."""

    rate: float = param(50.0, unit="Hz", gt=0, le=5000, source="supervisory loop above the 1 kHz servo loops",
                        description="guidance cycle rate")
    standoff: float = param(1.0, unit="m", gt=0, le=10, source="clear of the flange for the manual connection",
                            description="distance the coupler holds from the flange, towards the jetty")
    arrive_tolerance: float = param(0.05, unit="m", gt=0, le=2, source="engineering choice",
                                    description="distance to the standoff point counted as arrived")
    max_estimate_age: float = param(0.5, unit="s", gt=0, le=10, source="5 sensor periods at 10 Hz",
                                    description="an estimate older than this is not fresh: motion stops")
    drift_window: float = param(60.0, unit="s", gt=5, le=600,
                                source="averages out waves and swell up to about 30 s periods (Hs 1.5 m: fitted "
                                        "speed within 0.01 m/s); at most twice the first alarm's lead",
                                description="window of the constant-acceleration drift fit behind the time-to-limit "
                                             "alarms")
    jog_speed: float = param(0.15, unit="m/s", gt=0, le=1, source="same as the approach speed limit",
                             description="coupler speed at full joystick deflection")
    prediction: Literal["online AR", "off"] = Field(
        "online AR", description="the flange predictor behind the predictive alarms (issue 30): the online "
                                 "autoregression, or off (the measured-drift routes alone, as before)",
        json_schema_extra={"unit": "", "source": "docs/guidance.md section 12"})

    def compile(self) -> "GuidanceSettings":
        """The section as the controller takes it: a frozen record, validated here once.

        Returns
        -------
        GuidanceSettings
        """
        return GuidanceSettings(**self.model_dump())


@dataclass(frozen=True, slots=True)
class GuidanceSettings:
    """The ``[guidance]`` section compiled (:meth:`Guidance.compile`): what the guidance controller takes. Units and
    ranges are :class:`Guidance`'s, where each is declared."""

    rate: float
    standoff: float
    arrive_tolerance: float
    max_estimate_age: float
    drift_window: float
    jog_speed: float
    prediction: str = "online AR"


class Faults(_S):
    """Faults injected into the run (plant side), to prove the safety chain."""

    ers_valve_stuck: bool = Field(False, description="the ERS valves never confirm closed (limit switches)",
                                  json_schema_extra={"unit": "", "source": "fault injection"})
    ers_valve_delay: float = param(0.0, unit="s", ge=0, le=600, source="fault injection (0 = none)",
                                   description="extra closing time of the ERS valves beyond ers_valve_time")
    hpu_trip_at: float | None = param(None, unit="s", ge=0, source="none by default",
                                      description="time the hydraulic power unit trips: the drives stop, the "
                                                   "ERS and the retraction run on its accumulator")
    ers_switch_false_closed_at: float | None = param(None, unit="s", ge=0, source="fault injection (none by default)",
                                                     description="from this time one of the two ERS valve closed "
                                                                  "limit switches reads closed whatever the valves do")
    encoder_fault: Literal["none", "frozen", "drift", "failed"] = Field(
        "none", description="fault of one joint-angle encoder (the primary channel of encoder_fault_axis): frozen "
                            "at its reading, drifting at encoder_drift_rate_deg, or failed (no reading)",
        json_schema_extra={"unit": "", "source": "fault injection"})
    encoder_fault_axis: Literal["slew", "alpha", "beta"] = Field(
        "beta", description="the axis whose encoder fails", json_schema_extra={"unit": "", "source": "fault injection"})
    encoder_fault_at: float = param(0.0, unit="s", ge=0, source="fault injection", description="time the encoder fails")
    encoder_drift_rate_deg: float = param(0.2, unit="deg/s", ge=-10, le=10, source="fault injection",
                                          description="how fast a drifting encoder's reading walks away")


class EnvironmentOverride(_S):
    """Changes to the berth file's [environment] for this run (model = moored); each key as there."""

    wind_speed: float | None = param(None, unit="m/s", source="the berth file's", description="1-hour mean wind "
                                                                                                "at 10 m")
    wind_direction_deg: float | None = param(None, unit="deg", source="the berth file's",
                                             description="direction the wind blows towards")
    current_speed: float | None = param(None, unit="m/s", source="the berth file's", description="current speed")
    current_direction_deg: float | None = param(None, unit="deg", source="the berth file's",
                                                description="direction the current flows towards")
    hs: float | None = param(None, unit="m", source="the berth file's", description="significant wave height")
    tp: float | None = param(None, unit="s", source="the berth file's", description="peak period")
    wave_direction_deg: float | None = param(None, unit="deg", source="the berth file's",
                                             description="direction the waves travel towards")
    spreading: float | None = param(None, unit="1", source="the berth file's", description="cos-2s exponent")


class MooringFailure(_S):
    """Mooring lines that part during the run (model = moored): the break-out case."""

    time: float | None = param(None, unit="s", ge=0, source="none by default",
                               description="time the lines part (omit for none)")
    lines: tuple[str, ...] = Field((), description="names of the lines that part (as in the berth file)",
                                   json_schema_extra={"unit": "", "source": ""})
    all_lines: bool = Field(False, description="every line parts (the ship breaks out)",
                            json_schema_extra={"unit": "", "source": ""})


class ScenarioHead(_S):
    """Name, length and seed of the run."""

    name: str = Field("scenario", description="scenario name", json_schema_extra={"unit": "", "source": ""})
    duration: float = param(300.0, unit="s", gt=0, le=86400, source="scenario choice", description="simulated time")
    seed: int = Field(1, ge=0, description="random seed (waves, sensor)", json_schema_extra={"unit": "", "source": ""})
    plant: str = Field("hydraulic", pattern="^(hydraulic|kinematic)$",
                       description="arm plant: hydraulic (the two servo drives on the arm's dynamics) or kinematic",
                       json_schema_extra={"unit": "", "source": "hydraulic: the realistic default; kinematic for fast studies"})
    installation: str | None = Field(None, description="installation TOML, relative to the scenario file "
                                                       "(default: the paper's case)",
                                     json_schema_extra={"unit": "", "source": ""})


class Scenario(_S):
    """One closed-loop run."""

    scenario: ScenarioHead = Field(default_factory=ScenarioHead)
    ship: Ship = Field(default_factory=Ship)
    waves: Waves = Field(default_factory=Waves)
    drift: Drift = Field(default_factory=Drift)
    sensor: Sensor = Field(default_factory=Sensor)
    operator: Operator = Field(default_factory=Operator)
    guidance: Guidance = Field(default_factory=Guidance)
    faults: Faults = Field(default_factory=Faults)
    environment: EnvironmentOverride = Field(default_factory=EnvironmentOverride)
    mooring_failure: MooringFailure = Field(default_factory=MooringFailure)

    @model_validator(mode="after")
    def _ship_model(self) -> "Scenario":
        mf = self.mooring_failure
        if self.ship.model == "moored":
            if self.ship.berth is None:
                raise ValueError("ship.model = 'moored' needs ship.berth, the berth file (relative to the scenario)")
            if self.waves.hs > 0:
                raise ValueError(f"waves.hs = {self.waves.hs:g} m: the moored ship takes its sea from the berth's "
                                 "[environment]; set [environment] hs in the scenario instead")
            if self.drift.start is not None:
                raise ValueError("drift.start: the moored ship drifts by its loads; part lines with "
                                 "[mooring_failure] time and lines (or all_lines = true) instead")
            if mf.time is not None and not (mf.lines or mf.all_lines):
                raise ValueError("mooring_failure.time is set but no line parts: give mooring_failure.lines or "
                                 "all_lines = true")
        else:
            used = [k for k, v in self.environment.model_dump().items() if v is not None]
            if used or mf.time is not None or mf.lines or mf.all_lines:
                raise ValueError("[environment] and [mooring_failure] apply to ship.model = 'moored' only "
                                 f"(ship.model is {self.ship.model!r})")
        return self


def parse_scenario(data: dict, *, source: str = "<scenario>") -> Scenario:
    """Validate a scenario mapping.

    Parameters
    ----------
    data : dict
        Parsed TOML.
    source : str
        Name for messages.

    Returns
    -------
    Scenario

    Raises
    ------
    ConfigError
        One line naming the key and the valid range.
    """
    try:
        return Scenario.model_validate(toml_values(data))
    except ValidationError as err:
        msg = format_validation_error(err, source, Scenario)
        raise ConfigError(msg, source=source, expected="scenario") from None


def parse_scenario_file(path: str | Path) -> Scenario:
    """A scenario file read at the edge and validated (:func:`parse_scenario`); it must also say how long its run
    is (found: an empty file ran 300 s of defaults and exited 0). A wrong value is reported before a missing key.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Scenario

    Raises
    ------
    ConfigError
        Naming the file, the key and its range.
    """
    data = read_toml(Path(path), "scenario")
    sc = parse_scenario(data, source=str(path))
    _require_duration(data, path)
    return sc


def _require_duration(data: dict, path) -> None:
    head = data.get("scenario")
    if not isinstance(head, dict) or "duration" not in head:
        raise ConfigError(f"{path}: missing required key 'scenario.duration' (simulated time, s); "
                          f"{valid_range_text(ScenarioHead, 'duration')}: a scenario file says at least how long "
                          "its run is, in its [scenario] table")


def load_scenario(path: str | Path) -> tuple[Scenario, "ArmModel"]:
    """Read a scenario file and the installation it names, compiled (scenario loading is an edge).

    Parameters
    ----------
    path : str or Path
        Scenario TOML.

    Returns
    -------
    scenario : Scenario
    model : ArmModel
        The named installation (default: the paper's case), compiled.

    Raises
    ------
    ConfigError
        Missing or invalid file.
    """
    sc, model, _ = read_scenario(path)
    return sc, model


def read_scenario(path: str | Path) -> tuple[Scenario, "ArmModel", Berth | None]:
    """:func:`load_scenario`, and the berth file a moored scenario names, read once (None for the simple ship):
    what :func:`loadarm.sim.spec.load_run` compiles the run from.

    Parameters
    ----------
    path : str or Path
        Scenario TOML.

    Returns
    -------
    scenario : Scenario
    model : ArmModel
    berth : Berth or None
    """
    p = Path(path)
    data = read_toml(p, "scenario")
    sc = parse_scenario(data, source=str(p))
    inst_path = None if sc.scenario.installation is None else p.parent / sc.scenario.installation
    inst = paper_installation() if inst_path is None else load_config(inst_path)
    model = compile_model(inst, source=str(p if inst_path is None else inst_path))
    sc, berth = _resolve_berth(sc, p)
    check_scenario(sc, model, source=str(p))
    _require_duration(data, p)                  # a wrong value or a cross-check first, a missing key last
    return sc, model, berth


def resolve_berth(sc: Scenario, scenario_path: str | Path) -> Scenario:
    """The scenario with its berth file's path made absolute (it is given relative to the scenario file), and
    the berth file validated, so that later stages need not know where the scenario was.

    Parameters
    ----------
    sc : Scenario
    scenario_path : str or Path

    Returns
    -------
    Scenario

    Raises
    ------
    ConfigError
        The berth file is missing or invalid, or a parted line is not one of its lines.
    """
    return _resolve_berth(sc, scenario_path)[0]


def _resolve_berth(sc: Scenario, scenario_path: str | Path) -> tuple[Scenario, Berth | None]:
    if sc.ship.model != "moored" or sc.ship.berth is None:
        return sc, None
    path = (Path(scenario_path).parent / sc.ship.berth).resolve()
    berth = load_berth(path)
    names = [m.name for m in berth.moorings]
    for n in sc.mooring_failure.lines:
        if n not in names:
            raise ConfigError(f"{scenario_path}: mooring_failure.lines: {n!r} is not a line of {path} "
                              f"(lines: {', '.join(names)})")
    scenario_environment(sc, berth.environment, source=f"{scenario_path} over {path}")
    return sc.model_copy(update={"ship": sc.ship.model_copy(update={"berth": str(path)})}), berth


def scenario_environment(sc: Scenario, base, *, source: str = "<scenario>"):
    """The berth's environment with the scenario's ``[environment]`` overrides, validated.

    Parameters
    ----------
    sc : Scenario
    base : Environment
        The berth file's.
    source : str
        Name for messages.

    Returns
    -------
    Environment

    Raises
    ------
    ConfigError
        An override out of its range (named ``environment.<key>``).
    """

    merged = base.model_dump() | {k: v for k, v in sc.environment.model_dump().items() if v is not None}
    wrap = create_model("_MergedEnvironment", environment=(Environment, ...))
    try:
        return wrap.model_validate({"environment": merged}).environment
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, wrap)) from None


def check_scenario(sc: Scenario, model: "ArmModel", *, source: str = "<scenario>") -> None:
    """Cross-checks between a scenario and the installation it runs on.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    model : ArmModel
        The installation, compiled.
    source : str
        Name for messages.

    Raises
    ------
    ConfigError
        The drift window is too long for the sequence (:func:`check_drift_window`), or the run would need more
        memory than :data:`MAX_RUN_MEMORY` (:func:`check_run_size`).
    """
    check_drift_window(sc.guidance, model.sequence, source=source)
    check_run_size(sc, source=source)


#: The most memory a run may take, bytes: a day at 50 Hz needs about 1 GB.
MAX_RUN_MEMORY = 2 * 1024 ** 3
#: Float64 values a run keeps per guidance cycle (its 20 recorded signals, the true flange, the time axis and the
#: cycle time: 25) and per sensor reading (two times, the position, the outlier flag, the mask and the noise: 10),
#: with room (tests/test_hostile.py measures the growth with tracemalloc).
RUN_FLOATS_PER_CYCLE = 28
RUN_FLOATS_PER_READING = 12


def run_memory(sc: Scenario) -> int:
    """Memory a run of the scenario needs, bytes (what grows with its duration and rates).

    Parameters
    ----------
    sc : Scenario

    Returns
    -------
    int
    """
    cycles = math.floor(sc.scenario.duration * sc.guidance.rate) + 1
    readings = math.ceil(sc.scenario.duration * sc.sensor.rate)
    return 8 * (cycles * RUN_FLOATS_PER_CYCLE + readings * RUN_FLOATS_PER_READING)


def check_run_size(sc: Scenario, *, source: str = "<scenario>") -> None:
    """Refuse a run that would need more than :data:`MAX_RUN_MEMORY` before anything is allocated.

    Parameters
    ----------
    sc : Scenario
    source : str
        Name for messages.

    Raises
    ------
    ConfigError
        With the figure and the limit (found: in-range scenarios needing 20-58 GB ended in a MemoryError or an
        OOM kill).
    """
    need = run_memory(sc)
    if need > MAX_RUN_MEMORY:
        raise ConfigError(
            f"{source}: scenario.duration = {sc.scenario.duration:g} s at guidance.rate = {sc.guidance.rate:g} Hz "
            f"and sensor.rate = {sc.sensor.rate:g} Hz needs about {need / 1024 ** 3:.1f} GB, more than the "
            f"{MAX_RUN_MEMORY / 1024 ** 3:g} GB a run may take: shorten the run or lower the rates")


def check_drift_window(g: Guidance, seq, *, source: str = "<guidance>") -> None:
    """The drift fit's window must be at most twice the first alarm's lead.

    Parameters
    ----------
    g : Guidance
        Guidance settings (``drift_window``).
    seq : record
        The installation's ``[sequence]``.
    source : str
        Name for messages.

    Raises
    ------
    ConfigError
        A drift would reach the limit before the time-to-limit alarm had fitted it (the design-drift floor
        covers only drifts within the design).
    """
    lead = esd_lead(seq)
    w = g.drift_window
    if w > 2 * lead:
        raise ConfigError(
            f"{source}: guidance.drift_window = {w:g} s is too slow for the sequence it protects (at most twice the "
            f"first alarm's lead, max(esd_time, ers_valve_time + ers_valve_timeout) + erc_release_time + margin = "
            f"{lead:g} s): a drift "
            f"would reach the limit before the fit saw it; valid range (5, {2 * lead:g}] s")
