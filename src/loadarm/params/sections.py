"""The installation file's sections: every physical parameter of one arm at one berth declared exactly once, with
its unit, its valid range, a default (or, for customer data that must be given, the paper's example value) and the
source of that value (:func:`loadarm.params.declare.param`).

Lengths are metres, speeds m/s, accelerations m/s^2, voltages V. Angles are degrees in the file only, in keys
ending ``_deg``; the rest of loadarm works in radians (see :attr:`Alarms.first`)."""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from loadarm.files import read_toml  # noqa: F401 (re-exported: config.read_toml, its home before files)
from loadarm.params.declare import REQUIRED, Section, param

__all__ = ["Datasheet", "ArmSection", "ActuatorSection", "Alarms", "Slew", "Approach", "SizingBounds", "Masses",
           "Cylinders", "Pump", "Valve", "Encoder", "Controller", "Report", "Operability", "Sequence", "DesignDrift",
           "Accumulator", "Transfer"]

_DS = "customer datasheet; example value from paper Table 1"


class Datasheet(Section):
    """Customer datasheet distances (paper Table 1), metres, all >= 0."""

    A: float = param(REQUIRED, unit="m", ge=0, le=100, paper=2.5, source=_DS,
                     description="centre line of riser to jetty face")
    B: float = param(REQUIRED, unit="m", ge=0, le=100, paper=1.7, source=_DS,
                     description="jetty face to berthing line")
    C: float = param(REQUIRED, unit="m", ge=0, le=100, paper=1.0, source=_DS,
                     description="shortest distance berthing line to ship flange")
    D: float = param(REQUIRED, unit="m", ge=0, le=100, paper=4.6, source=_DS,
                     description="widest distance berthing line to ship flange")
    E: float = param(REQUIRED, unit="m", ge=0, le=100, paper=4.7, source=_DS,
                     description="drift range")
    F: float = param(REQUIRED, unit="m", ge=0, le=100, paper=3.8, source=_DS,
                     description="jetty level to high tide level (HTL)")
    G: float = param(REQUIRED, unit="m", ge=0, le=100, paper=2.4, source=_DS,
                     description="high tide level to low tide level (LTL)")
    H: float = param(REQUIRED, unit="m", ge=0, le=100, paper=1.5, source=_DS,
                     description="LTL to flange centre line, smallest ship loaded")
    I: float = param(REQUIRED, unit="m", ge=0, le=100, paper=15.0, source=_DS,  # noqa: E741
                     description="LTL to flange centre line, largest ship unloaded")
    K: float = param(0.0, unit="m", ge=0, le=100, paper=3.5, source=_DS + " (multi-arm only; 0 = single arm)",
                     description="riser centre line to riser centre line")
    L: float = param(0.0, unit="m", ge=0, le=100, paper=0.5, source=_DS + " (not used by the planar model)",
                     description="jetty level to connecting flange (land side)")
    M: float = param(0.0, unit="m", ge=0, le=100, paper=1.9, source=_DS + " (multi-arm only)",
                     description="smallest flange-to-flange distance")
    N: float = param(0.0, unit="m", ge=0, le=100, paper=5.0, source=_DS + " (multi-arm only)",
                     description="widest flange-to-flange distance")

    @model_validator(mode="after")
    def _ordered(self) -> "Datasheet":
        if self.D < self.C:
            raise ValueError(f"datasheet.D ({self.D} m) must be >= datasheet.C ({self.C} m): the widest "
                             "berthing-line-to-flange distance cannot be below the shortest")
        return self


class ArmSection(Section):
    """Arm lengths: riser a, inboard b, outboard c (paper Fig. 3)."""

    riser: float = param(REQUIRED, unit="m", gt=0, le=100, paper=7.0,
                         source="paper Section 2 (a = 7 m)", description="riser length a, jetty level to inboard hinge")
    inboard: float = param(REQUIRED, unit="m", gt=0, le=100, paper=12.0,
                           source="paper Section 2 (b = 12 m, from Eq. 3)", description="inboard arm length b")
    outboard: float = param(REQUIRED, unit="m", gt=0, le=100, paper=8.2,
                            source="paper Section 2 (c = 8.2 m, from Eq. 3)", description="outboard arm length c")


class ActuatorSection(Section):
    """Cylinder mounting distances (paper Fig. 5) and the valve command scale."""

    a1: float = param(REQUIRED, unit="m", gt=0, le=20, paper=1.0, source="paper Section 5",
                      description="cylinder 1 riser pin, distance below the inboard hinge")
    b1: float = param(REQUIRED, unit="m", gt=0, le=20, paper=1.0, source="paper Section 5",
                      description="cylinder 1 inboard pin, distance from the inboard hinge")
    b2: float = param(REQUIRED, unit="m", gt=0, le=20, paper=1.5, source="paper Section 5",
                      description="cylinder 2 inboard pin, distance from the elbow")
    c2: float = param(REQUIRED, unit="m", gt=0, le=20, paper=0.5, source="paper Section 5",
                      description="cylinder 2 outboard pin, distance from the elbow")
    volts_per_metre: float = param(1.0, unit="V/m", gt=0, le=1000,
                                   source="paper Section 5 ('a number equal to one')",
                                   description="displacement-to-voltage scale of the valve command")
    valve_range_V: float = param(10.0, unit="V", gt=0, le=24,
                                 source="common +/-10 V proportional-valve command input (ISO 10770-1 style)",
                                 description="symmetric valve command range; a plan needing more is refused")


class Alarms(Section):
    """Inboard-outboard angle (beta) thresholds of the alarm zones, degrees in the file."""

    first_deg: float = param(123.0, unit="deg", gt=0, lt=180, source="paper Section 2 example (customer-specified)",
                             description="first-stage alarm (ESD-1) above this beta")
    second_deg: float = param(143.0, unit="deg", gt=0, lt=180, source="paper Section 2 example (customer-specified)",
                              description="second-stage alarm above this beta")
    release_deg: float = param(150.0, unit="deg", gt=0, lt=180, source="paper Section 2 example (customer-specified)",
                               description="emergency release (ERS-2) at or above this beta")

    @model_validator(mode="after")
    def _ordered(self) -> "Alarms":
        if not (self.first_deg < self.second_deg < self.release_deg):
            raise ValueError(
                f"alarm angles must increase: first_deg ({self.first_deg}) < second_deg ({self.second_deg}) "
                f"< release_deg ({self.release_deg}), each in (0, 180) deg")
        return self

    @property
    def first(self) -> float:
        """First-alarm angle in radians."""
        return math.radians(self.first_deg)

    @property
    def second(self) -> float:
        """Second-alarm angle in radians."""
        return math.radians(self.second_deg)

    @property
    def release(self) -> float:
        """Release angle in radians."""
        return math.radians(self.release_deg)


class Slew(Section):
    """Slew joint (rotation of the arm about the riser axis): limits and alarms, degrees in the file."""

    limit_deg: float = param(40.0, unit="deg", gt=0, lt=180, source="typical slew range of a marine arm",
                             description="slew joint limit, +/- from the arm's centre line")
    first_deg: float = param(30.0, unit="deg", gt=0, lt=180, source="customer setting (example)",
                             description="slew first-stage alarm (ESD-1), +/-")
    second_deg: float = param(34.0, unit="deg", gt=0, lt=180, source="customer setting (example)",
                              description="slew second-stage alarm, +/-")
    release_deg: float = param(37.0, unit="deg", gt=0, lt=180, source="customer setting (example)",
                               description="slew release (ERS-2), +/-")
    max_rate_deg: float = param(2.0, unit="deg/s", gt=0, le=45, source="slew drive of a 20 m arm",
                                description="slew rate limit")

    @model_validator(mode="after")
    def _ordered(self) -> "Slew":
        if not (self.first_deg < self.second_deg < self.release_deg < self.limit_deg):
            raise ValueError("slew angles must increase: first_deg < second_deg < release_deg < limit_deg, got "
                             f"{self.first_deg}, {self.second_deg}, {self.release_deg}, {self.limit_deg}")
        return self


class Approach(Section):
    """Straight-line approach from the stored position to the ship flange (paper Fig. 5)."""

    stored: tuple[float, float] = param(REQUIRED, unit="m", paper=(3.82, 10.40), source="paper Section 3",
                                        description="coupler stored position (X0, Y0), from the riser base")
    flange: tuple[float, float] = param(REQUIRED, unit="m", paper=(14.0, 1.0), source="paper Section 3",
                                        description="ship flange position (Xf, Yf), from the riser base")
    max_speed: float = param(0.15, unit="m/s", ge=0.01, le=2.0,
                             source="paper Eq. 14 (0.15 m/s, attributed to OCIMF)",
                             description="coupler speed limit (horizontal for the paper law, along the path "
                                          "for the smooth law)")
    max_accel: float = param(0.05, unit="m/s^2", ge=0.001, le=5.0,
                             source="engineering choice: reaches 0.15 m/s in 3 s, well below what the "
                                     "cylinders of a 20 m arm deliver",
                             description="coupler acceleration limit of the smooth and optimal timing laws")
    max_cylinder_accel: float = param(0.01, unit="m/s^2", ge=0.0005, le=5.0,
                                      source="engineering choice: a cylinder reaches its peak approach speed "
                                              "(about 10 mm/s) in 1 s",
                                      description="cylinder acceleration limit of the optimal timing law")

    @model_validator(mode="after")
    def _finite_points(self) -> "Approach":
        for name in ("stored", "flange"):
            x, y = getattr(self, name)
            if not (math.isfinite(x) and math.isfinite(y) and abs(x) <= 1000 and abs(y) <= 1000):
                raise ValueError(f"approach.{name} must be two finite coordinates within [-1000, 1000] m, "
                                 f"got [{x}, {y}]")
        return self


class SizingBounds(Section):
    """Search bounds for paper Eq. 3, metres."""

    inboard: tuple[float, float] = param((8.0, 12.0), unit="m",
                                         source="chosen to reproduce the paper's b = 12 m (see docs/sizing.md)",
                                         description="lower and upper bound of the inboard length b")
    outboard: tuple[float, float] = param((4.0, 10.0), unit="m",
                                          source="chosen to reproduce the paper's c = 8.2 m (see docs/sizing.md)",
                                          description="lower and upper bound of the outboard length c")

    @model_validator(mode="after")
    def _ordered(self) -> "SizingBounds":
        for name in ("inboard", "outboard"):
            lo, hi = getattr(self, name)
            if not (0 < lo <= hi <= 100):
                raise ValueError(f"sizing.{name} must be [low, high] with 0 < low <= high <= 100 m, "
                                 f"got [{lo}, {hi}]")
        return self


_PIPE = ("16 in (DN400) standard-wall pipe, ASME B36.10M: OD 406.4 mm, wall 9.53 mm, 93.3 kg/m of steel; "
         "about 1.6x that with ribs, product-line supports and swivel flanges (engineering estimate)")


class Masses(Section):
    """Mass model of the arm (multibody verification, dynamics, balancing).

    The arm is lumped into rigid bodies: each pipe as a uniform slender rod
    (pipe steel plus the product it holds), point-like lumps for the apex
    (elbow) swivel, the coupler assembly and the two counterweights. The
    primary counterweight sits on the inboard arm's rear extension; the
    secondary one on a pantograph lever at the riser top that a parallelogram
    linkage keeps parallel to the outboard arm, pointing away from it (the
    double-counterweighted arm of paper Fig. 1).
    """

    inboard_kg_per_m: float = param(150.0, unit="kg/m", gt=0, le=5000, source=_PIPE,
                                    description="inboard arm mass per metre, empty")
    outboard_kg_per_m: float = param(120.0, unit="kg/m", gt=0, le=5000,
                                     source="as the inboard pipe, lighter structure (engineering estimate)",
                                     description="outboard arm mass per metre, empty")
    pipe_inner_diameter: float = param(0.3874, unit="m", gt=0, le=2.0, source="16 in standard wall: 406.4 - 2 x 9.53 mm",
                                       description="product bore of both arms")
    product_density: float = param(850.0, unit="kg/m^3", ge=0, le=2000,
                                   source="medium crude oil (LNG would be about 450 kg/m^3)",
                                   description="density of the product in the arm")
    fill: float = param(0.0, unit="1", ge=0, le=1,
                        source="the approach is made with the arm drained (OCIMF practice)",
                        description="fraction of the bore filled with product during the approach")
    elbow_kg: float = param(800.0, unit="kg", ge=0, le=1e5,
                            source="16 in apex swivel joint with its elbow (engineering estimate)",
                            description="lumped mass at the elbow (inboard arm's end)")
    coupler_kg: float = param(1500.0, unit="kg", ge=0, le=1e5,
                              source="16 in hydraulic QCDC + ERS + triple swivel (engineering estimate)",
                              description="lumped mass at the outboard tip")
    counterweight_inboard_kg: float = param(19600.0, unit="kg", ge=0, le=1e6,
                                            source="minimax balance of the default arm, drained and full "
                                                    "(loadarm balance, rounded; = exact balance half full)",
                                            description="primary counterweight on the inboard rear extension")
    counterweight_inboard_distance: float = param(3.0, unit="m", gt=0, le=50,
                                                  source="about a quarter of the inboard length (engineering choice)",
                                                  description="primary counterweight distance behind the inboard hinge")
    counterweight_outboard_kg: float = param(7200.0, unit="kg", ge=0, le=1e6,
                                             source="minimax balance of the default arm, drained and full "
                                                     "(loadarm balance, rounded; = exact balance half full)",
                                             description="secondary counterweight on the pantograph lever")
    counterweight_outboard_distance: float = param(2.5, unit="m", gt=0, le=50,
                                                   source="pantograph lever length (engineering choice)",
                                                   description="secondary counterweight distance from the riser top")
    lump_radius: float = param(0.3, unit="m", gt=0, le=5,
                               source="order of size of a swivel or counterweight block",
                               description="radius of the solid spheres used for the lumps' own inertia")
    balance_fills: tuple[float, ...] = param((0.0, 1.0), unit="1",
                                             source="an arm must stay near balance drained and full",
                                             description="fill fractions the counterweight balance is computed over")

    @model_validator(mode="after")
    def _fills(self) -> "Masses":
        if not self.balance_fills or not all(0.0 <= f <= 1.0 and math.isfinite(f) for f in self.balance_fills):
            raise ValueError(f"masses.balance_fills must be a non-empty list of fractions in [0, 1], "
                             f"got {list(self.balance_fills)}")
        return self


class Cylinders(Section):
    """Hydraulic cylinder sizes, for forces to pressures and speeds to flows."""

    bore: float = param(0.160, unit="m", gt=0, le=1.0, source="ISO 3320 preferred bore; sized by the actuator report",
                        description="piston (bore) diameter of both cylinders")
    rod: float = param(0.090, unit="m", gt=0, le=1.0, source="ISO 3320 preferred rod for a 160 mm bore",
                       description="rod diameter of both cylinders")
    return_pressure: float = param(2.0e5, unit="Pa", ge=0, le=5e6, source="typical tank-line back pressure (2 bar)",
                                   description="pressure in the chamber connected to tank")
    max_pressure: float = param(210e5, unit="Pa", gt=0, le=7e7, source="common industrial rating (210 bar)",
                                description="pressure above which the report flags a cylinder as undersized")

    bulk_modulus: float = param(1.0e9, unit="Pa", gt=1e7, le=2.5e9,
                                source="mineral oil 1.5-1.8 GPa, reduced by hose compliance and air (common design value)",
                                description="effective bulk modulus of oil, hoses and cylinder")
    dead_volume: float = param(1.0e-3, unit="m^3", gt=0, le=0.5,
                               source="hoses and ports between valve and cylinder, about 6 m of 1/2 in hose",
                               description="oil volume of each chamber's line at zero chamber stroke")
    viscous_friction: float = param(2.0e4, unit="N s/m", ge=0, le=1e8,
                                    source="seal friction of a 160 mm cylinder (engineering estimate)",
                                    description="viscous friction coefficient of each cylinder")
    coulomb_friction: float = param(2000.0, unit="N", ge=0, le=1e6,
                                    source="about 0.5 % of the cylinder's force at rated pressure",
                                    description="Coulomb (breakaway) friction force of each cylinder")
    stribeck_velocity: float = param(1e-3, unit="m/s", gt=0, le=1.0,
                                     source="smoothing of the Coulomb friction, tanh(v / v_s)",
                                     description="velocity scale of the Coulomb friction smoothing")
    leakage: float = param(1e-13, unit="m^3/(s Pa)", ge=0, le=1e-9,
                           source="worn-in piston seal, about 0.06 L/min at 100 bar",
                           description="internal leakage coefficient, chamber A to chamber B")
    length_range_1: tuple[float, float] = param((0.95, 1.99), unit="m",
                                                source="covers the paper arm's envelope (r_ac1 0.96-2.0 m)",
                                                description="pin-to-pin length of cylinder 1 fully retracted and "
                                                             "fully extended (end stops)")
    length_range_2: tuple[float, float] = param((0.98, 1.99), unit="m",
                                                source="covers the envelope and beta up to 167 deg, beyond the "
                                                        "release angle, so a drifting ship is released before "
                                                        "the cylinder bottoms out",
                                                description="pin-to-pin length of cylinder 2 fully retracted and "
                                                             "fully extended (end stops)")
    end_stop_stiffness: float = param(1e9, unit="N/m", gt=0, le=1e12,
                                      source="steel end cap and cushion (engineering estimate)",
                                      description="stiffness of the cylinder end stops")
    end_stop_damping: float = param(1e6, unit="N s/m", ge=0, le=1e10, source="end-of-stroke cushioning",
                                    description="damping of the cylinder end stops")

    @model_validator(mode="after")
    def _rod_in_bore(self) -> "Cylinders":
        if not self.rod < self.bore:
            raise ValueError(f"cylinders.rod ({self.rod} m) must be smaller than cylinders.bore ({self.bore} m)")
        for name in ("length_range_1", "length_range_2"):
            lo, hi = getattr(self, name)
            if not (0 < lo < hi <= 50):
                raise ValueError(f"cylinders.{name} must be [retracted, extended] with 0 < retracted < extended "
                                 f"<= 50 m, got [{lo}, {hi}]")
        return self


class Pump(Section):
    """Hydraulic power unit: pressure-compensated pump with a relief valve (paper Fig. 11)."""

    compensator_pressure: float = param(210e5, unit="Pa", gt=1e5, le=7e7,
                                        source="common industrial HPU setting (210 bar)",
                                        description="pressure at which the compensator destrokes the pump")
    regulation_band: float = param(10e5, unit="Pa", gt=0, le=1e7,
                                   source="typical compensator droop from full flow to zero (10 bar)",
                                   description="pressure band over which the pump goes from full flow to none")
    max_flow: float = param(6.67e-4, unit="m^3/s", gt=0, le=0.1,
                            source="40 L/min: a 15 kW loading-arm HPU (engineering estimate)",
                            description="pump flow at full displacement")
    relief_pressure: float = param(230e5, unit="Pa", gt=1e5, le=8e7,
                                   source="relief set 20 bar above the compensator",
                                   description="cracking pressure of the relief valve")
    relief_band: float = param(10e5, unit="Pa", gt=0, le=1e7,
                               source="relief passes the full pump flow 10 bar above cracking",
                               description="override pressure of the relief valve at full pump flow")
    supply_volume: float = param(5e-3, unit="m^3", gt=1e-6, le=1.0,
                                 source="pressure line and filter between pump and valves (5 L)",
                                 description="oil volume of the supply line")

    @model_validator(mode="after")
    def _relief_above_compensator(self) -> "Pump":
        if not self.relief_pressure > self.compensator_pressure:
            raise ValueError(f"pump.relief_pressure ({self.relief_pressure:g} Pa) must be above "
                             f"pump.compensator_pressure ({self.compensator_pressure:g} Pa)")
        return self


class Valve(Section):
    """4/3-way proportional valve, critical centre, one per cylinder (paper Fig. 11)."""

    nominal_flow: float = param(6.67e-4, unit="m^3/s", gt=0, le=0.1,
                                source="40 L/min size-10 proportional valve (ISO 4401-05)",
                                description="flow at full opening and nominal pressure drop")
    nominal_pressure_drop: float = param(70e5, unit="Pa", gt=1e4, le=5e7,
                                         source="ISO 10770-1 rating: 35 bar per land, 70 bar over both",
                                         description="pressure drop over both lands at which nominal_flow is rated")
    natural_frequency: float = param(30.0, unit="Hz", gt=0.1, le=500,
                                     source="-90 deg point of a size-10 valve with on-board electronics",
                                     description="spool natural frequency (second-order model)")
    damping: float = param(0.7, unit="1", gt=0, le=5, source="typical spool position loop",
                           description="spool damping ratio")
    overlap: float = param(0.0, unit="1", ge=0, lt=0.5, source="critical centre (zero lap)",
                           description="spool overlap (deadband) as a fraction of full stroke")
    laminar_pressure: float = param(1e5, unit="Pa", gt=0, le=1e7,
                                    source="regularisation of the square-root law near zero drop (1 bar)",
                                    description="pressure drop below which orifice flow turns laminar")


class Encoder(Section):
    """Displacement encoder on each cylinder (paper Fig. 11), and the joint-angle sensors' redundancy."""

    resolution: float = param(1e-5, unit="m", gt=0, le=0.01, source="10 um magnetostrictive position sensor",
                              description="quantisation step of the cylinder length reading")
    redundancy: Literal["none", "dual", "cylinder"] = Field(
        "cylinder", description="second channel of each joint angle, voted against the angle encoder: none; dual "
                                "(two angle encoders per axis); cylinder (alpha and beta from the cylinder-length "
                                "transducers through the pin geometry, two encoders on the slew)",
        json_schema_extra={"unit": "1", "source": "IEC 61508 / ISO 13849 practice: no single sensor failure may hide "
                                                  "the arm's position from its alarms; the cylinders "
                                                  "already carry length transducers (paper Fig. 11)"})
    discrepancy_deg: float = param(0.5, unit="deg", gt=0, le=10,
                                   source="engineering choice: 10x the cylinder channel's error from the 10 um "
                                           "resolution and pin tolerances, about 0.15 m at the coupler",
                                   description="largest difference between the two channels of an axis")
    discrepancy_time: float = param(0.5, unit="s", gt=0, le=10, source="engineering choice: five 10 Hz cycles",
                                    description="how long the channels may disagree before one is judged")
    frozen_time: float = param(2.0, unit="s", gt=0, le=60, source="engineering choice: 20 cycles unchanged while "
                                                                   "the other channel moves",
                               description="a channel unchanged this long while the other moves is frozen")


class Controller(Section):
    """Discrete PID with velocity feed-forward per cylinder (paper Fig. 11)."""

    rate: float = param(1000.0, unit="Hz", ge=10, le=20000, source="paper Fig. 11 servo loop; 1 kHz is usual for electro-hydraulic position control",
                        description="control loop rate")
    kp: float = param(60.0, unit="V/m", ge=0, le=1e6,
                      source="tuned below the arm's low hydraulic natural frequency (docs/hydraulics.md)",
                      description="proportional gain on the cylinder length error")
    ki: float = param(30.0, unit="V/(m s)", ge=0, le=1e7, source="removes the steady load-induced error",
                      description="integral gain")
    kd: float = param(0.0, unit="V s/m", ge=0, le=1e5, source="not needed with feed-forward",
                      description="derivative gain (on the measurement, filtered)")
    derivative_filter: float = param(0.02, unit="s", gt=0, le=10, source="20 ms first-order filter",
                                     description="time constant of the derivative filter")
    integral_limit: float = param(5.0, unit="V", gt=0, le=24, source="half the valve range",
                                  description="anti-windup clamp of the integral term")
    feedforward: Literal["none", "nominal", "model"] = Field(
        "model", description="valve feed-forward from the plan: none; nominal (velocity at the valve's rated drop); "
                             "model (steady-state valve-cylinder inverse under the planned force)",
        json_schema_extra={"unit": "1", "source": "velocity feed-forward of the planned motion; model-based inverse is standard practice"})
    substeps: int | Literal["auto"] = Field(
        "auto", description="plant integration steps per control step; auto: from the stability bound "
                                          "of the arm on its oil columns and end stops (docs/hydraulics.md)",
        json_schema_extra={"unit": "1", "source": "stability bound h omega_max <= 0.5 (hydraulics.simulate."
                                                  "stable_substeps); an integer overrides it"})

    @field_validator("substeps", mode="before")
    @classmethod
    def _substeps(cls, v: Any) -> Any:
        if v == "auto" or (type(v) is int and 1 <= v <= 100):
            return v
        raise ValueError(f"must be \"auto\" or an integer in [1, 100], got {v!r}")

    settle_time: float = param(10.0, unit="s", ge=0, le=600, source="engineering choice",
                               description="time simulated after the plan ends")
    following_error_limit: float = param(0.025, unit="m", gt=0, le=10.0,
                                         source="servo following-error trip; 10x the normal peak error",
                                         description="cylinder length error that stops the run as unstable")
    arrival_tolerance: float = param(0.005, unit="m", gt=0, le=1.0, source="within manual-connection reach",
                                     description="coupler distance from the flange counted as arrived")


class Report(Section):
    """What the HTML report runs besides the pipeline."""

    scenarios: tuple[str, ...] = Field(
        (), max_length=50,
        description="live-guidance scenario files run on this installation in the report, relative to this file",
        json_schema_extra={"unit": "path", "source": "installation owner's choice (the paper's case lists the examples)"})
    berth: str | None = Field(
        None, description="berth file (design ship, moorings, environment) whose moored ship and alarm design the "
                          "report shows, relative to this file (omit for none)",
        json_schema_extra={"unit": "path", "source": "installation owner's choice (the paper's case: the example "
                                                     "LNG carrier berth)"})
    metocean: str | None = Field(
        None, description="metocean record (CSV or NetCDF) whose operability at the berth the report shows, "
                          "relative to this file; needs berth (omit for none)",
        json_schema_extra={"unit": "path", "source": "installation owner's choice (the paper's case: the shipped "
                                                     "two-month sample)"})
    bank: str | None = Field(
        None, description="bank file (the arms on this jetty, the ship's manifold, the shared power unit) whose "
                          "clearance, swivels, loads on the manifold and emergency release the report shows, relative "
                          "to this file (omit for none)",
        json_schema_extra={"unit": "path", "source": "installation owner's choice (the paper's case: the example "
                                                     "four-arm LNG bank)"})
    document: str | None = Field(
        None, max_length=40, pattern=r"^[A-Za-z0-9][A-Za-z0-9._/-]*$",
        description="the report's document number, on its title page (omit: LA- and the first 8 hex digits of the "
                    "installation file's SHA-256)",
        json_schema_extra={"unit": "text", "source": "the owner's document control"})
    revision: str = Field(
        "0", max_length=8, pattern=r"^[A-Za-z0-9][A-Za-z0-9.-]*$",
        description="the report's revision, on its title page beside the document number",
        json_schema_extra={"unit": "text", "source": "the owner's document control"})

    @model_validator(mode="after")
    def _metocean_needs_berth(self) -> "Report":
        if self.metocean is not None and self.berth is None:
            raise ValueError("metocean needs a berth: the operability is the berth's ship in that weather")
        return self


class Operability(Section):
    """How ``loadarm operability`` judges each hourly sea state of a metocean record (issue 13)."""

    connect_motion_limit: float = param(
        1.0, unit="m", gt=0, le=5,
        source="the coupler's capture range with the guidance's tracking (engineering estimate; about Hs 2.5-3 m "
               "for the example ship)",
        description="largest significant flange motion (4 standard deviations, worst axis) at which the arm can "
                    "still connect")
    duration_per_state: float = param(3600.0, unit="s", ge=10, le=3600,
                                      source="a metocean record's hourly step (the whole hour)",
                                      description="seconds simulated per hourly sea state")
    line_limit: float = param(0.5, unit="1", gt=0, le=1.0,
                              source="OCIMF MEG4: working load limit 50 % of the ship design MBL for synthetic "
                                     "lines (55 % for steel wire)",
                              description="largest line tension, first-order motion included, as a fraction of "
                                          "the line's MBL")
    wind_limit: float = param(20.0, unit="m/s", gt=0, le=60,
                              source="terminal rules: arms disconnected at about 35-40 kn (example)",
                              description="largest 1-hour mean wind from any direction")
    wind_limit_off_berth: float = param(15.0, unit="m/s", gt=0, le=60,
                                        source="the example arm's design weather at the example berth "
                                               "(docs/ship-motion.md section 8)",
                                        description="largest 1-hour mean wind blowing off the berth (within "
                                                    "off_berth_sector_deg of berth +x)")
    off_berth_sector_deg: float = param(45.0, unit="deg", ge=0, le=90, source="engineering choice",
                                        description="half-width of the off-the-berth wind sector")
    fender_limit: float = param(1.0, unit="1", gt=0, le=1.2,
                                source="the manufacturer's rated deflection (the berth's fenders' rated_deflection; "
                                       "PIANC WG33, 2002: a fender is not to be deflected past its rating)",
                                description="largest fender deflection as a fraction of its rated deflection")
    surge_limit: float = param(2.0, unit="m", gt=0, le=20,
                               source="PIANC (1995) criteria for moored ships, gas tankers with loading arms: "
                                      "surge 2 m peak to peak",
                               description="largest surge, peak to peak")
    sway_limit: float = param(2.0, unit="m", gt=0, le=20,
                              source="PIANC (1995), gas tankers with loading arms: sway 2 m zero to peak (off "
                                     "the fenders)",
                              description="largest move off the berth from the calm position")
    roll_limit_deg: float = param(2.0, unit="deg", gt=0, le=30, source="PIANC (1995), gas tankers: roll 2 deg",
                                  description="largest roll, peak to peak")
    pitch_limit_deg: float = param(2.0, unit="deg", gt=0, le=30, source="PIANC (1995), gas tankers: pitch 2 deg",
                                   description="largest pitch, peak to peak")
    yaw_limit_deg: float = param(2.0, unit="deg", gt=0, le=30, source="PIANC (1995), gas tankers: yaw 2 deg",
                                 description="largest yaw, peak to peak")
    loading_hours: float = param(14.0, unit="h", gt=0, le=200,
                                 source="a 150 000 m^3 LNG cargo at about 12 000 m^3/h: 12-16 h connected",
                                 description="connected hours a loading needs")
    reconnect_hours: float = param(2.0, unit="h", ge=0, le=48,
                                   source="cool-down, reconnection and leak test after a disconnection "
                                          "(engineering estimate)",
                                   description="operable hours lost to reconnect after a disconnection")
    passing_ship: bool = Field(
        False, description="apply the berth file's [passing_ship] once in every hourly state (at its "
                           "closest_approach_time): the operability with a ship passing each hour; false: none",
        json_schema_extra={"unit": "1", "source": "passing ships are a documented cause of breakaways "
                                                 "(Wang 1975; loadarm.ship.passing)"})


class Sequence(Section):
    """The emergency shutdown and release sequence of the berth (ESD-1 -> ERS valves closed -> ERS-2), seconds.

    The connected-mode alarms are set from these times (see docs/guidance.md): the first alarm (ESD-1) must
    leave ``max(esd_time, ers_valve_time + ers_valve_timeout) + erc_release_time + margin`` before any limit of
    the arm, the release (ERS-2) what is left of ``ers_valve_time + ers_valve_timeout`` + ``erc_release_time +
    margin``: until their limit switches confirm, the valves count at the worst their timeout allows.
    """

    esd_time: float = param(30.0, unit="s", gt=0, le=60,
                            source="IGC Code 18.10 / SIGTTO ESD guidance: ship's ESD valves closed within 30 s",
                            description="ESD-1: transfer pumps stopped and the ESD valves of ship and shore closed "
                                         "within this time")
    ers_valve_time: float = param(10.0, unit="s", gt=0, le=60,
                                  source="conservative: suppliers quote about 5 s for the ERS double-block valves; "
                                          "EN 1474-1 / ISO 16904: closed before the coupling releases",
                                  description="from ESD-1 until the ERS valves' limit switches confirm them closed")
    ers_valve_timeout: float = param(5.0, unit="s", gt=0, le=60, source="engineering choice: half the closing time",
                                     description="ERS valves not confirmed closed this long after ers_valve_time: "
                                                  "valve fault alarm (the coupler stays closed)")
    erc_release_time: float = param(3.0, unit="s", gt=0, le=30,
                                    source="conservative: suppliers quote 1-2 s for the powered emergency release "
                                            "coupling (PERC)",
                                    description="ERS-2: from the release command to the coupler free")
    margin: float = param(2.0, unit="s", ge=0, le=60, source="engineering margin",
                          description="time margin added to every stage's lead time")
    pre_alarm_lead: float = param(30.0, unit="s", ge=0, le=600,
                                  source="the ESD-1 time (IGC Code 18.10: 30 s): time for the operator to stop the "
                                          "transfer in a controlled way before ESD-1 trips it (ISA-18.2 / EEMUA 191: "
                                          "an alarm leaves time for the operator's response); 0 = no pre-alarm",
                                  description="the pre-alarm (warning only) fires this long before ESD-1 would")
    ers_valves_close_at: Literal["esd1", "ers2"] = Field(
        "esd1", description="when the ERS valves are commanded closed: esd1 (with the ESD valves at ESD-1, OCIMF 1999 "
                            "loading-arm specification) or ers2 (only at the release, SIGTTO ESD guidance); with "
                            "ers2 the release stage leads by the whole valve time",
        json_schema_extra={"unit": "1", "source": "OCIMF, Design and Construction Specification for Marine Loading "
                                                  "Arms (1999); SIGTTO, ESD Arrangements and Linked Ship/Shore "
                                                  "Systems for Liquefied Gas Carriers (2009); docs/guidance.md"})
    drain_time: float = param(30.0, unit="s", gt=0, le=3600,
                              source="terminal's procedure (gravity drain or nitrogen purge of the outboard arm)",
                              description="controlled disconnection: draining the arm after the ERS valves close")
    unclamp_time: float = param(10.0, unit="s", gt=0, le=120, source="hydraulic QC/DC coupler clamps",
                                description="controlled disconnection: opening the coupler's clamps")
    lift_off: float = param(0.5, unit="m", gt=0, le=5, source="clear of the ship's flange before moving away",
                            description="controlled disconnection: the coupler first rises this far")


class DesignDrift(Section):
    """The berth's design drift (Lanquetin's combined method): a floor under the speed alarms, and what
    ``loadarm check`` proves the alarms absorb. OCIMF leaves the values to the owner, per berth."""

    speed: float = param(0.15, unit="m/s", gt=0, le=2,
                         source="owner's per-berth choice; the paper's example drift speed",
                         description="design drift speed of the ship, horizontal, any direction")
    acceleration: float = param(0.01, unit="m/s^2", gt=0, le=1,
                                source="owner's per-berth choice (break-out after a mooring failure); "
                                        "engineering estimate",
                                description="design break-out acceleration up to the design speed")
    vertical_speed: float = param(0.005, unit="m/s", ge=0, le=0.5,
                                  source="tide (about 2 m/h) plus loading, with margin",
                                  description="design vertical speed of the flange")


class Accumulator(Section):
    """The ERS accumulator: it closes the ERS valves, releases the coupler and retracts the arm clear of the
    manifold when the HPU has tripped."""

    volume: float = param(25.0e-3, unit="m^3", gt=0, le=1,
                          source="25 L bladder accumulator (a supplier's size): the ERS valves, the PERC and the "
                                  "arm's retraction clear of the manifold after an HPU trip (loadarm check)",
                          description="gas volume at precharge (nominal size)")
    precharge: float = param(90.0e5, unit="Pa", gt=0, le=500e5,
                             source="about 0.9 x the minimum working pressure (usual bladder practice)",
                             description="gas precharge pressure")
    charged_pressure: float = param(200.0e5, unit="Pa", gt=0, le=500e5, source="HPU pressure that charges it",
                                    description="pressure when charged (before the HPU trips)")
    min_pressure: float = param(100.0e5, unit="Pa", gt=0, le=500e5,
                                source="lowest pressure at which the PERC and the ERS valve actuators still work",
                                description="minimum working pressure")
    required_volume: float = param(1.5e-3, unit="m^3", gt=0, le=1,
                                   source="ERS valve actuators (about 1 L) plus the PERC's release stroke "
                                           "(about 0.5 L): supplier's figures",
                                   description="oil the ERS valves and the coupler's release need")
    safety_factor: float = param(1.5, unit="1", ge=1, le=10, source="engineering margin",
                                 description="usable volume must be at least this times the required volume")
    polytropic_index: float = param(1.4, unit="1", ge=1, le=1.67,
                                    source="adiabatic nitrogen (a fast discharge, seconds)",
                                    description="gas expansion exponent during the discharge")

    @model_validator(mode="after")
    def _pressures(self) -> "Accumulator":
        if not (self.precharge < self.min_pressure < self.charged_pressure):
            raise ValueError(
                f"accumulator pressures must satisfy precharge ({self.precharge:g}) < min_pressure "
                f"({self.min_pressure:g}) < charged_pressure ({self.charged_pressure:g}) Pa")
        return self


class Transfer(Section):
    """The product transfer through the arm: what the surge of the ERS valves' closure at design flow is checked
    with (``loadarm check``, :mod:`loadarm.design.surge`): the valves close with the ship's ESD valves still open and
    the shore pumps running (OCIMF 1999: the ERS valves close at ESD-1)."""

    design_flow: float = param(4000.0 / 3600.0, unit="m^3/s", gt=0, le=10,
                               source="a 16-inch LNG arm's rated flow, about 4000 m^3/h (supplier datasheets)",
                               description="design flow through the arm")
    bore: float = param(0.3968, unit="m", gt=0, le=2, source="16-inch Sch 10S stainless pipe (ASME B36.19M: "
                                                               "406.4 mm outside, 4.78 mm wall)",
                        description="inner diameter of the line and the arm")
    density: float = param(460.0, unit="kg/m^3", gt=0, le=2000,
                           source="LNG at -160 degC, 448-470 kg/m^3 by composition (GERG-2008)",
                           description="product density")
    wave_speed: float = param(1220.0, unit="m/s", gt=0, le=3000,
                              source="Korteweg: LNG's speed of sound 1370-1420 m/s (isentropic bulk modulus "
                                      "about 0.9 GPa, GERG-2008) in a 16-inch Sch 10S steel line anchored upstream",
                              description="pressure wave speed in the filled line")
    line_length: float = param(1000.0, unit="m", gt=0, le=20000,
                               source="engineering estimate: shore line from the tank pumps along the trestle",
                               description="length of the line upstream of the ERS valves")
    friction_factor: float = param(0.011, unit="1", ge=0, le=0.1,
                                   source="Colebrook at Re about 1.3e7, roughness 0.015-0.045 mm",
                                   description="Darcy friction factor of the line")
    operating_pressure: float = param(8.0e5, unit="Pa", ge=0, le=100e5,
                                      source="engineering estimate: 5-10 bar g at the arm during loading",
                                      description="gauge pressure at the ERS valves in steady flow")
    design_pressure: float = param(20.0e5, unit="Pa", gt=0, le=200e5,
                                   source="LNG loading arms are rated about 15-20 bar g (supplier datasheets, "
                                           "EN 1474-1 / ISO 16904); 20 bar g taken",
                                   description="the arm's design pressure (gauge)")
    closure_law: Literal["linear", "quadratic"] = Field(
        "linear", description="how the ERS valve's effective opening falls over its closing time (the larger peak "
                              "of the two for the defaults)",
        json_schema_extra={"unit": "1", "source": "Wylie & Streeter, Fluid Transients in Systems (1993); a full-bore "
                                                  "ball valve cuts the flow late in its travel: enter its own "
                                                  "characteristic (docs/guidance.md)"})
