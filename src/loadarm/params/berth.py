"""The berth file: the design ship, the jetty, its moorings and fenders, and the environment (issue 12, item 1).

One TOML file per berth and design ship (``examples/berths/``), read and validated at the edge like the
installation (:mod:`loadarm.params.declare`): every parameter declared once with its unit, range, default and
source; strict types; one-line errors naming the file, the key, the value and the range. The ship's compiler
(:func:`loadarm.ship.model.compile_ship`) takes the validated :class:`Berth`.

Frames (SI units, angles in degrees only in keys ending ``_deg``):

* **ship**: x forward from midships (half the length between perpendiculars), y to port, z up from the keel;
* **berth**: x out from the fender line towards the sea (the installation's x direction), y along the berth, z up
  from the still-water level; the ship lies alongside with the side given by ``[berth] side`` against the
  fenders, its midships at ``[berth] ship_y``.

Lines and fenders are given as a terminal knows them: a line is a main line of a material (HMPE, polyester,
nylon, steel wire: :data:`ROPE_MATERIALS`, or the berth's own ``[materials.NAME]``) with its MBL, on a winch
whose brake renders at a fraction of it, and a tail of another material; a fender pushes only (a load-deflection
curve through the origin that never falls, past its rated deflection), rubs along the hull with its friction and
gives back on unloading a fraction of its loading reaction (hysteresis).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, Field, ValidationError, model_validator

from loadarm.errors import ConfigError
from loadarm.params.config import parameter_markdown, read_toml
from loadarm.params.declare import Section, format_validation_error, param, toml_values

__all__ = ["ShipSection", "BerthSection", "RopeMaterial", "ROPE_MATERIALS", "MooringLine", "Fender", "Environment",
           "PassingShip", "PassingShipRangeError", "check_passing_range", "Berth", "parse_berth", "load_berth",
           "berth_parameter_markdown", "RHO_SEA"]

#: Density of sea water, kg/m^3 (ITTC 7.5-02-01-03, 15 deg C, 35 g/kg: 1025.9; 1025 is the usual design value).
RHO_SEA = 1025.0

_LNG = "typical particulars of 145 000-155 000 m^3 membrane LNG carriers (published yard and class data)"
_MEG = "OCIMF Mooring Equipment Guidelines (MEG4) typical LNG carrier arrangement; example values"


class ShipSection(Section):
    """The design ship: hull, loading condition, mass distribution, manifold and windage."""

    kind: Literal["lng_carrier", "tanker"] = Field(
        "lng_carrier", description="ship type (selects the open wind coefficients of Blendermann)",
        json_schema_extra={"unit": "", "source": "Blendermann (1994, 1996) ship types"})
    length_pp: float = param(278.0, unit="m", ge=50, le=400, source=_LNG, description="length between perpendiculars")
    beam: float = param(43.4, unit="m", ge=10, le=70, source=_LNG, description="moulded beam")
    depth: float = param(26.0, unit="m", ge=5, le=40, source=_LNG, description="moulded depth to the main deck")
    draft: float = param(11.5, unit="m", ge=2, le=25, source=_LNG + " (design draft, loaded)",
                         description="mean draft of the loading condition")
    displacement: float = param(105_000e3, unit="kg", ge=1e6, le=5e8,
                                source="rho L B T Cb with Cb = 0.74 at the design draft",
                                description="displacement (mass) of the loading condition")
    kg: float = param(12.4, unit="m", ge=0, le=40,
                      source="GM about 2.5 m, a loaded LNG carrier's order (stability book), on the parametric "
                              "hull (KM 14.9 m at the example's draft)",
                      description="centre of gravity above the keel")
    lcg: float = param(0.0, unit="m", ge=-50, le=50, source="even keel", description="centre of gravity forward of "
                                                                                        "midships")
    r_xx: float = param(16.5, unit="m", ge=1, le=40, source="about 0.38 B (roll)", description="roll radius of gyration")
    r_yy: float = param(69.5, unit="m", ge=5, le=150, source="about 0.25 L (pitch)",
                        description="pitch radius of gyration")
    r_zz: float = param(69.5, unit="m", ge=5, le=150, source="about 0.25 L (yaw)", description="yaw radius of gyration")
    manifold: tuple[float, float, float] = param(
        (0.0, 18.4, 28.0), unit="m", source="SIGTTO/OCIMF manifold recommendations: near midships, about 3 m inboard "
                                            "of the side, about 2 m above the main deck",
        description="presentation flange on the ship (x forward of midships, y to port, z above the keel)")
    lateral_windage: float = param(5500.0, unit="m^2", ge=0, le=50_000,
                                   source="L (D - T) plus trunk deck and accommodation",
                                   description="lateral projected area above water (Blendermann A_L)")
    frontal_windage: float = param(1150.0, unit="m^2", ge=0, le=10_000,
                                   source="B (D - T) plus accommodation", description="frontal projected area above "
                                                                                       "water (Blendermann A_F)")

    windage_centroid_x: float = param(-15.0, unit="m", ge=-200, le=200,
                                      source="accommodation aft moves the lateral area's centroid aft of midships",
                                      description="centroid of the lateral windage forward of midships "
                                                   "(Blendermann s_L)")
    propeller_area: float = param(45.0, unit="m^2", ge=0, le=300,
                                  source="expanded blade area of an 8.6 m propeller, blade-area ratio 0.78",
                                  description="propeller expanded area (UFC 4-159-03 locked-propeller drag)")
    roll_damping_ratio: float = param(0.05, unit="1", ge=0, le=0.5,
                                      source="viscous roll damping of a large ship at small angles, a few % of "
                                              "critical (ITTC 7.5-02-07-04.5); potential flow has almost none",
                                      description="roll damping added to the BEM's, fraction of critical")
    lf_damping_ratio: float = param(0.05, unit="1", ge=0, le=0.5,
                                    source="low-frequency damping of moored ships (wave drift, viscous hull, "
                                            "lines): 5-10 % of critical (Faltinsen 1990, ch. 5)",
                                    description="surge, sway and yaw damping at the mooring natural periods, "
                                                 "fraction of critical (current drag comes on top)")

    @model_validator(mode="after")
    def _consistent(self) -> "ShipSection":
        cb = self.displacement / (RHO_SEA * self.length_pp * self.beam * self.draft)
        if not 0.5 <= cb <= 0.9:
            raise ValueError(f"ship.displacement = {self.displacement:g} kg gives a block coefficient of {cb:.3f} for "
                             f"{self.length_pp:g} x {self.beam:g} x {self.draft:g} m; a ship lies in [0.5, 0.9]")
        if self.draft >= self.depth:
            raise ValueError(f"ship.draft = {self.draft:g} m must be below ship.depth = {self.depth:g} m")
        x, y, z = self.manifold
        if abs(x) > self.length_pp / 2 or abs(y) > self.beam / 2 or not self.draft < z <= self.depth + 10:
            raise ValueError(f"ship.manifold = {list(self.manifold)} m must lie on the hull, above the waterline: "
                             f"|x| <= {self.length_pp / 2:g}, |y| <= {self.beam / 2:g}, "
                             f"{self.draft:g} < z <= {self.depth + 10:g} m")
        return self


class BerthSection(Section):
    """The jetty: water depth, which side the ship lies on, where it lies."""

    water_depth: float = param(20.0, unit="m", gt=0, le=200, source="issue 12: a jetty in about 20 m of water",
                               description="still-water depth at the berth")
    side: Literal["port", "starboard"] = Field(
        "port", description="side of the ship against the fenders (its manifold faces the arm)",
        json_schema_extra={"unit": "", "source": "example"})
    ship_y: float = param(0.0, unit="m", ge=-500, le=500, source="midships abreast of the arm",
                          description="position of the ship's midships along the berth (berth y)")
    deck_height: float = param(8.0, unit="m", ge=0, le=40, source="example jetty deck above still water",
                               description="jetty deck above the still-water level (the installation's z = 0)")
    x_bearing_deg: float = param(270.0, unit="deg", ge=0, le=360,
                                 source="example: a berth open to the west (metocean records give compass "
                                         "directions)",
                                 description="compass bearing of berth +x (off the berth, towards the sea), "
                                              "clockwise from true north")
    bound_long_waves: bool = Field(
        True, description="the set-down (second-order long waves bound to the wave groups) loads the moored ship "
                          "besides Newman's slow drift (false: Newman alone, as in deep water)",
        json_schema_extra={"unit": "", "source": "Longuet-Higgins & Stewart (1962); Hasselmann (1962); "
                                                  "loadarm.ship.longwave"})
    manifold_tolerance: float = param(1.5, unit="m", ge=0, le=20,
                                      source="the mooring master places the manifold within about 1-2 m of the "
                                              "arm's centre line (terminal procedure; example)",
                                      description="how far along the berth from the arm's centre line the ship's "
                                                   "manifold may lie when connected (the flanging area's width)")


class RopeMaterial(Section):
    """A rope material's load-extension curve: strain ``eps = strain_at_break (T / MBL) ** exponent`` (new, wet
    rope after bedding in; an exponent below 1 makes the rope soft at low load and stiffer as it is loaded, as
    fibre ropes are)."""

    strain_at_break: float = param(..., unit="1", gt=0, le=0.6, source="rope makers' published curves",
                                   description="strain at the minimum breaking load")
    exponent: float = param(..., unit="1", ge=0.3, le=1.5, source="rope makers' published curves",
                            description="shape of the curve: strain grows as (T / MBL) to this power")
    source: str = Field("the berth file", max_length=300, description="where the curve comes from",
                        json_schema_extra={"unit": "", "source": ""})


_ROPE = ("typical new, wet rope, fitted to load-elongation curves published by rope makers (order of magnitude; "
         "OCIMF MEG4 2018 ch. 5 describes the materials): take the certified curve of the berth's own lines")

#: The rope materials a berth file may name, with their curves (a berth's ``[materials.NAME]`` adds or replaces).
#: Strains at break: steel wire about 1.5 % (elastic, plus constructional stretch), HMPE 3-4 %, polyester
#: 12-15 %, nylon (polyamide, wet) 20-25 %.
ROPE_MATERIALS: dict[str, RopeMaterial] = {
    "steel_wire": RopeMaterial(strain_at_break=0.015, exponent=0.9, source=_ROPE + " (6x36 IWRC)"),
    "hmpe": RopeMaterial(strain_at_break=0.035, exponent=0.85, source=_ROPE + " (12-strand HMPE)"),
    "polyester": RopeMaterial(strain_at_break=0.13, exponent=0.7, source=_ROPE + " (8-strand polyester)"),
    "nylon": RopeMaterial(strain_at_break=0.22, exponent=0.6, source=_ROPE + " (8-strand polyamide, wet)"),
}


class MooringLine(Section):
    """One mooring line: from a fairlead on the ship to a bollard or hook on the jetty; a main line on the ship's
    winch and, at its shore end, a tail of a softer material (MEG4: tails on HMPE and wire lines)."""

    name: str = Field(..., min_length=1, max_length=40, description="line name (e.g. head 1, fwd breast 2)",
                      json_schema_extra={"unit": "", "source": "example"})
    fairlead: tuple[float, float, float] = param(..., unit="m", source=_MEG, description="fairlead in the ship "
                                                                                          "frame")
    bollard: tuple[float, float, float] = param(..., unit="m", source=_MEG, description="bollard or hook in the "
                                                                                         "berth frame")
    material: str = Field("hmpe", min_length=1, max_length=40,
                          description="main line's material (a name of [materials] or the built-in table)",
                          json_schema_extra={"unit": "", "source": "MEG4: HMPE is the usual LNG carrier line"})
    mbl: float = param(1.0e6, unit="N", gt=0, le=1e8, source="ship design MBL of LNG carrier lines, about 1000 kN",
                       description="main line's minimum breaking load (the ship design MBL)")
    tail_material: str = Field("nylon", min_length=1, max_length=40, description="tail's material",
                               json_schema_extra={"unit": "", "source": "MEG4: nylon or polyester tails"})
    tail_length: float = param(11.0, unit="m", ge=0, le=100, source="MEG4: tails of about 11 m (0: no tail)",
                               description="tail's length, unstretched (0: no tail)")
    tail_mbl: float = param(1.25e6, unit="N", gt=0, le=1e8,
                            source="MEG4: a tail's MBL 125-130 % of the line's ship design MBL",
                            description="tail's minimum breaking load")
    brake: float = param(0.6, unit="1", ge=0, le=1.0,
                         source="MEG4: winch brakes set to render at 60 % of the ship design MBL",
                         description="winch brake holding load, fraction of the main line's MBL; above it the "
                                      "brake renders (pays out); 0: the line is on bitts and holds until it parts")
    pretension: float = param(100e3, unit="N", ge=0, le=1e7, source="about 10 % of the MBL (MEG4 practice)",
                              description="tension at the initial position")

    @model_validator(mode="after")
    def _below_breaking(self) -> "MooringLine":
        if self.pretension >= 0.55 * self.mbl:
            raise ValueError(f"moorings line {self.name!r}: pretension = {self.pretension:g} N must be below 55 % of the "
                             f"MBL ({0.55 * self.mbl:g} N, MEG4's working load limit for synthetic lines)")
        if 0 < self.brake * self.mbl <= self.pretension:
            raise ValueError(f"moorings line {self.name!r}: brake = {self.brake:g} of the MBL "
                             f"({self.brake * self.mbl:g} N) must hold more than the pretension "
                             f"({self.pretension:g} N)")
        return self

    @property
    def breaking_load(self) -> float:
        """The line's breaking load, N: its weaker segment's."""
        return min(self.mbl, self.tail_mbl) if self.tail_length > 0 else self.mbl


#: Where the example fender's shape comes from (the percentages of the generic curve, scaled to one size).
_CONE = ("shape of a cone fender's published generic curve (Trelleborg Marine Systems, Safe Berthing and Mooring, "
         "M1100-S01, Super Cone: reaction rising to its peak near 35-40 % deflection and held to the rated 72 %; "
         "the slight dip between left out, so the curve never falls), 1.6 m high, 2.0 MN rated; the rise past "
         "the rating (bottoming out) a loadarm assumption, no steeper than the curve's first slope (4.75 MN/m) so "
         "that the low-frequency step stays 1 s")


class Fender(Section):
    """One fender on the fender line: pushes only, along berth x; rubs along the berth (friction) and gives back
    less than it took (hysteresis) while the ship moves."""

    name: str = Field(..., min_length=1, max_length=40, description="fender name",
                      json_schema_extra={"unit": "", "source": "example"})
    y: float = param(..., unit="m", ge=-500, le=500, source="example", description="position along the berth")
    z: float = param(2.0, unit="m", ge=-20, le=40, source="example", description="height above still water")
    deflection: tuple[float, ...] = param((0.0, 0.08, 0.16, 0.24, 0.32, 0.4, 0.48, 0.56, 0.64, 1.152, 1.24, 1.35),
                                          unit="m", source=_CONE,
                                          description="deflections of the load curve, from 0, increasing, past the "
                                                      "rated deflection (bottoming out)")
    load: tuple[float, ...] = param((0.0, 3.8e5, 7.6e5, 1.1e6, 1.42e6, 1.68e6, 1.86e6, 1.96e6, 2.0e6, 2.0e6, 2.4e6,
                                     2.9e6), unit="N", source=_CONE,
                                    description="reaction at each deflection on loading, from 0, never falling")
    rated_deflection: float = param(1.152, unit="m", gt=0, le=20, source=_CONE + " (72 % of 1.6 m)",
                                    description="the manufacturer's rated deflection: the fender criterion's "
                                                "reference, inside the curve")
    friction: float = param(0.2, unit="1", ge=0, le=0.6, source="OCIMF MEG4 (fender friction 0.15-0.3); PIANC "
                                                                   "WG33 (2002), UHMW-PE face pads against steel",
                            description="coefficient of friction between the fender's face and the hull")
    unload_ratio: float = param(0.8, unit="1", gt=0, le=1, source="rubber fenders' hysteresis (PIANC WG33, 2002: "
                                                                    "energy returned less than absorbed); example: "
                                                                    "set from the manufacturer's test",
                                description="reaction on unloading as a fraction of the reaction on loading at "
                                            "the same deflection (1: no hysteresis)")

    @model_validator(mode="after")
    def _curve(self) -> "Fender":
        d, f = self.deflection, self.load
        if len(d) != len(f) or len(d) < 2:
            raise ValueError(f"fenders {self.name!r}: deflection and load need the same number (>= 2) of points, "
                             f"got {len(d)} and {len(f)}")
        if (d[0] != 0 or f[0] != 0 or any(b <= a for a, b in zip(d, d[1:])) or any(b < a for a, b in zip(f, f[1:]))
                or f[1] <= 0):
            raise ValueError(f"fenders {self.name!r}: the load curve must start at (0, 0), increase in deflection "
                             f"and never fall in load (rising from 0), got deflection {list(d)}, load {list(f)}")
        if self.rated_deflection > d[-1]:
            raise ValueError(f"fenders {self.name!r}: rated_deflection {self.rated_deflection:g} m lies past the "
                             f"load curve's last deflection {d[-1]:g} m (allowed (0, {d[-1]:g}] m)")
        return self

    @property
    def rated_load(self) -> float:
        """The reaction at the rated deflection (on the loading curve), N."""
        d, f = self.deflection, self.load
        for j in range(1, len(d)):
            if self.rated_deflection <= d[j]:
                return f[j - 1] + (f[j] - f[j - 1]) * (self.rated_deflection - d[j - 1]) / (d[j] - d[j - 1])
        return f[-1]


class Environment(Section):
    """The design condition the alarms are set for (directions: where the wind, current or waves go *to*,
    measured from berth +x (off the berth) towards +y)."""

    wind_speed: float = param(20.0, unit="m/s", ge=0, le=60, source="connected-operation limit of the order of "
                                                                     "40 kn (terminal rules; example)",
                              description="1-hour mean wind speed at 10 m (gusts from the NPD spectrum)")
    wind_direction_deg: float = param(0.0, unit="deg", ge=-180, le=180, source="off the berth: the break-out case",
                                      description="direction the wind blows towards")
    current_speed: float = param(0.5, unit="m/s", ge=0, le=5, source="example sheltered jetty",
                                 description="depth-averaged current speed")
    current_direction_deg: float = param(90.0, unit="deg", ge=-180, le=180, source="along the berth (example)",
                                         description="direction the current flows towards")
    hs: float = param(1.0, unit="m", ge=0, le=8, source="berths operate up to about Hs 1.5-2 m",
                      description="significant wave height")
    tp: float = param(8.0, unit="s", gt=1, le=30, source="example swell", description="peak period")
    wave_direction_deg: float = param(30.0, unit="deg", ge=-180, le=180, source="example",
                                      description="mean direction the waves travel towards")
    spreading: float = param(4.0, unit="1", ge=1, le=100, source="cos-2s spreading, s = 4 for wind sea (DNV-RP-C205)",
                             description="directional spreading exponent s of cos^2s")
    tide: float = param(0.0, unit="m", ge=-10, le=10,
                        source="the lines tended at the reference level (MEG4: lines are tended over the tide)",
                        description="water level above the level at which the lines were last tended (the ship "
                                     "and its fairleads rise with it; the bollards stay)")
    draft_change: float = param(0.0, unit="m", ge=-15, le=15, source="the loading condition of [ship] draft",
                                description="draft above the one at which the lines were last tended (loading "
                                             "lowers the fairleads)")


#: The passing-ship model's range of validity (:mod:`loadarm.ship.passing`): separation in moored-ship lengths,
#: depth over either draft, depth Froude number; gravity, m/s^2.
SEPARATION_MIN_LENGTHS, SEPARATION_MAX_LENGTHS = 0.2, 5.0
DEPTH_DRAFT_MIN = 1.5
DEPTH_FROUDE_MAX = 0.5
GRAVITY = 9.81


class PassingShipRangeError(ConfigError):
    """A passing-ship input outside the range of validity of Wang's slender-body model
    (:mod:`loadarm.ship.passing`)."""


def _refuse(key: str, value: float, lo: float, hi: float, unit: str, why: str, *, open_lo: bool = False) -> None:
    if not (lo < value if open_lo else lo <= value) or not value <= hi:
        raise PassingShipRangeError(f"{key} = {value:g} {unit} is outside the passing-ship model's range "
                                    f"{'(' if open_lo else '['}{lo:.4g}, {hi:.4g}] {unit} ({why})")


def check_passing_range(moored: tuple[float, float, float], passing: tuple[float, float, float], speed: float,
                        separation: float, depth: float) -> None:
    """Refuse inputs outside the range of validity of the passing-ship model (:mod:`loadarm.ship.passing`: Wang's
    slender bodies a gap apart, keel clearance for the images' source lines, no waves).

    Parameters
    ----------
    moored, passing : tuple of float
        Length, beam and draft of the moored and of the passing ship, m.
    speed : float
        Passing speed, m/s.
    separation : float
        Between the two centre lines, m.
    depth : float
        Water depth, m.

    Raises
    ------
    PassingShipRangeError
        One line naming the parameter, its value and the allowed range.
    """
    (l1, b1, t1), (_, b2, t2) = moored, passing
    lo = max(SEPARATION_MIN_LENGTHS * l1, b1 + b2)
    _refuse("passing_ship.separation", separation, lo, SEPARATION_MAX_LENGTHS * l1, "m",
            "Wang's slender bodies: at least the two beams and 0.2 moored-ship lengths apart, at most 5 lengths")
    _refuse("passing_ship.draft", t2, 0.0, depth / DEPTH_DRAFT_MIN, "m",
            f"water depth {depth:g} m at least {DEPTH_DRAFT_MIN:g} drafts: keel clearance for the images' source "
            "lines")
    _refuse("berth.water_depth", depth, DEPTH_DRAFT_MIN * t1, math.inf, "m",
            f"at least {DEPTH_DRAFT_MIN:g} times the moored ship's draft {t1:g} m")
    _refuse("passing_ship.speed", speed, 0.0, DEPTH_FROUDE_MAX * math.sqrt(GRAVITY * depth), "m/s",
            f"depth Froude number at most {DEPTH_FROUDE_MAX:g} in {depth:g} m: no waves, Wang's zero Froude number",
            open_lo=True)


_PASS = "example: a 300 m container ship (48 m beam, 12 m draft) at 6 kn, 150 m off the moored ship's centre line"


class PassingShip(Section):
    """A ship passing along the berth (optional ``[passing_ship]``; absent: none): its hull, speed and track, for
    Wang's (1975) slender-body loads in the berth's water depth (:mod:`loadarm.ship.passing`, which refuses
    inputs outside its range of validity)."""

    length: float = param(300.0, unit="m", ge=50, le=450, source=_PASS, description="passing ship's length between "
                                                                                       "perpendiculars")
    beam: float = param(48.0, unit="m", ge=5, le=70, source=_PASS, description="passing ship's moulded beam")
    draft: float = param(12.0, unit="m", gt=0, le=25, source=_PASS, description="passing ship's draft")
    midship_coefficient: float = param(0.97, unit="1", ge=0.8, le=1.0,
                                       source="midship section coefficients of merchant ships 0.95-0.995 (container "
                                               "ships about 0.97)",
                                       description="passing ship's midship section area over beam x draft (Wang's "
                                                   "parabolic sectional area curve peaks at it)")
    speed: float = param(3.09, unit="m/s", gt=0, le=10, source=_PASS + " (6 kn; port speed limits 5-8 kn)",
                         description="passing speed through the water")
    separation: float = param(150.0, unit="m", ge=10, le=2000, source=_PASS,
                              description="lateral distance of the passing ship's centre line from the moored ship's, "
                                          "on the sea side")
    heading: Literal["same", "opposite"] = Field(
        "same", description="passing ship's direction: the way the moored ship's bow points (same: it overtakes "
                            "from astern) or against it (opposite)",
        json_schema_extra={"unit": "", "source": "example"})
    closest_approach_time: float = param(600.0, unit="s", ge=0, le=86400,
                                         source="example: ten minutes into a run",
                                         description="time from the start of a run at which the two ships are "
                                                     "abreast, midships to midships")


class Berth(BaseModel):
    """A berth file, validated."""

    model_config = Section.model_config

    ship: ShipSection = Field(default_factory=ShipSection)
    berth: BerthSection = Field(default_factory=BerthSection)
    moorings: tuple[MooringLine, ...] = Field(..., min_length=4, description="mooring lines ([[moorings]] tables)")
    fenders: tuple[Fender, ...] = Field(..., min_length=2, description="fenders ([[fenders]] tables)")
    environment: Environment = Field(default_factory=Environment)
    materials: dict[str, RopeMaterial] = Field(default_factory=dict, max_length=32,
                                              description="rope materials added to or replacing the built-in ones "
                                                          "([materials.NAME] tables)")
    passing_ship: PassingShip | None = Field(None, description="a ship passing along the berth ([passing_ship]; "
                                                               "absent: none)")

    def material(self, name: str) -> RopeMaterial:
        """A rope material by name: the berth's own, else the built-in table's.

        Parameters
        ----------
        name : str

        Returns
        -------
        RopeMaterial
        """
        return self.materials.get(name) or ROPE_MATERIALS[name]

    @model_validator(mode="after")
    def _fits(self) -> "Berth":
        s, b = self.ship, self.berth
        if s.draft >= b.water_depth:
            raise ValueError(f"ship.draft = {s.draft:g} m leaves no water under the keel at berth.water_depth = "
                             f"{b.water_depth:g} m")
        for kind, items in (("moorings", self.moorings), ("fenders", self.fenders)):
            names = [i.name for i in items]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"{kind}: names must be unique, {', '.join(dup)} repeated")
        for line in self.moorings:
            x, y, z = line.fairlead
            if abs(x) > s.length_pp / 2 + 20 or abs(y) > s.beam / 2 or not 0 <= z <= s.depth + 10:
                raise ValueError(f"moorings line {line.name!r}: fairlead {list(line.fairlead)} m lies off the ship "
                                 f"(|x| <= {s.length_pp / 2 + 20:g}, |y| <= {s.beam / 2:g}, 0 <= z <= "
                                 f"{s.depth + 10:g} m)")
            known = sorted(set(ROPE_MATERIALS) | set(self.materials))
            for key in ("material", "tail_material"):
                if getattr(line, key) not in known:
                    raise ValueError(f"moorings line {line.name!r}: {key} = {getattr(line, key)!r} is not a rope "
                                     f"material (known: {', '.join(known)}; add one as [materials.NAME])")
            if line.bollard[0] > 0:
                raise ValueError(f"moorings line {line.name!r}: bollard {list(line.bollard)} m lies on the water side "
                                 "of the fender line (berth x must be <= 0)")
        if self.passing_ship is not None:
            p = self.passing_ship
            check_passing_range((s.length_pp, s.beam, s.draft), (p.length, p.beam, p.draft), p.speed, p.separation,
                        b.water_depth)
        return self


def parse_berth(data: dict[str, Any], *, source: str = "<berth>") -> Berth:
    """Validate a berth mapping (as read from TOML).

    Parameters
    ----------
    data : dict
    source : str
        Name for messages.

    Returns
    -------
    Berth

    Raises
    ------
    ConfigError
        One line naming the file, the key, the value and the valid range.
    """
    try:
        return Berth.model_validate(toml_values(data))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, Berth), source=source, expected="berth") from None


def load_berth(path: str | Path) -> Berth:
    """Read and validate a berth file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Berth

    Raises
    ------
    ConfigError
    """
    return parse_berth(read_toml(path, "berth"), source=str(path))


def berth_parameter_markdown() -> str:
    """The berth file's parameters as a markdown table (key, unit, default, range, description, source), for
    docs/ship-motion.md (the installation's table maker, :func:`loadarm.params.config.parameter_markdown`).

    Returns
    -------
    str
    """
    return parameter_markdown([("ship", ShipSection), ("berth", BerthSection), ("moorings[]", MooringLine),
                               ("fenders[]", Fender), ("environment", Environment),
                               ("materials.NAME", RopeMaterial), ("passing_ship", PassingShip)])
