"""Surge pressure (water hammer) when the ERS valve closes at the arm's design flow.

The case checked: the shore pumps keep running while the ERS valve, at the downstream end of the shore line
that feeds the arm, closes over ``closure_time``; the ship's ESD valves are still open, so the valve discharges
into the arm's outboard side and the ship at a constant pressure (``downstream_pressure``, gauge, 0 by
default). The liquid column from the pumps to the valve is stopped, and the pressure upstream of the valve, in
the arm, rises.

Model (Wylie & Streeter 1993, *Fluid Transients in Systems*, ch. 1-3; Chaudhry 2014, *Applied Hydraulic
Transients*, ch. 2-3):

* one uniform pipe, length ``L``, bore ``D``, wave speed ``a``, Darcy friction factor ``f``, liquid density
  ``rho``; upstream a constant-pressure reservoir (the running pump, ``p_up``; a real centrifugal pump's head
  rises towards its shut-off head as the flow falls, which comes on top); downstream the valve;
* steady flow at the design velocity before the closure: the line's pressure falls linearly by Darcy-Weisbach's
  ``f L/D rho v^2/2``; the valve's initial loss is what is left at its inlet, ``dp0 = p_up - drop -
  downstream_pressure``, so the steady state holds;
* the valve's orifice law ``Q = tau Q0 sqrt(dp/dp0)`` with the effective opening ``tau(t)`` falling from 1 to
  0 over the closure (:data:`CLOSURE_LAWS`). By default the whole ``dp0`` is the valve's, as in Wylie &
  Streeter's reservoir-pipe-valve system; with ``valve_loss`` only that part is the valve's own (fully open, at
  the design flow) and the rest is a fixed loss in series (the arm's outboard, the ship's piping and its
  tank's head), which makes ``Q = tau Q0 sqrt(dp / (valve_loss + tau^2 (dp0 - valve_loss)))``. A full-bore ball
  valve's own loss is of the order of 0.01 bar at 9 m/s (an estimate: ``K = 3 f_T``, about 0.04 at 16 inch,
  Crane TP-410): it then destroys the flow only in the last part of its travel, and the surge is far larger
  than the lumped law says;
* the method of characteristics: ``N`` reaches, ``dt = dx/a``, the C+ and C- compatibility equations with the
  friction term taken at the foot of each characteristic, the valve's boundary solved in closed form with
  C+. Without friction the scheme is exact at its grid times: it reproduces Allievi's chain equations.

Bounds used (observed to rounding over random lines and laws, and asserted by the tests' properties): with a
closing valve and no column separation the pressure never exceeds ``p_up + rho a v`` (Joukowsky's rise on top of the pump's pressure; without friction ``p_up`` is the
operating pressure at the valve, with friction the line packs up to the pump's pressure) and never falls below
``operating - rho a v``. :func:`surge_check` passes on that bound alone when it is below the design pressure
and the low bound stays above the vapour pressure, and runs the model otherwise.

Not modelled: column separation and cavity collapse (flagged, and then the check fails: the liquid-only model
no longer bounds the peak), the pump's head curve, fluid-structure interaction, branches and changes of bore
(a header larger than the arm carries a lower velocity: the single pipe of the arm's bore is conservative
there), and the transient on the valve's downstream side (the liquid running on towards the ship lowers the
pressure in the arm's outboard).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from loadarm.design.plots import surge_figure
from loadarm.results import Metric, Result

__all__ = ["CLOSURE_LAWS", "SUPPORTS", "SURGE_METRICS", "SurgeResult", "joukowsky", "michaud", "pipe_wave_speed",
           "valve_opening", "moc_valve_closure", "surge_check"]

#: Closure laws of the valve's effective opening ``tau = (1 - s)^m``, ``s = (t - delay) / closure_time``:
#: name to exponent ``m`` ('linear': the classical uniform closure; 'quadratic': a ball valve's flow area,
#: a quarter left at half travel).
CLOSURE_LAWS = {"linear": 1.0, "quadratic": 2.0}

#: Pipe supports of Korteweg's wave speed, name to the factor ``c1(nu)`` of a thin-walled pipe (Wylie &
#: Streeter 1993, sec. 2.4): anchored at its upstream end only, anchored throughout against axial movement,
#: with expansion joints throughout.
SUPPORTS = {"upstream": lambda nu: 1.0 - 0.5 * nu, "anchored": lambda nu: 1.0 - nu * nu, "joints": lambda nu: 1.0}

_BAR = 1e-5


def _number(name: str, value, *, low: float | None = 0.0, strict: bool = True, unit: str = "") -> float:
    """``value`` as a finite float at or above (``strict``: above) ``low``; otherwise a one-line ValueError."""
    allowed = "finite" if low is None else f"finite and {'>' if strict else '>='} {low:g}"
    allowed += f" {unit}" if unit else ""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: not a number; allowed: {allowed}") from None
    if not math.isfinite(x) or (low is not None and (x <= low if strict else x < low)):
        raise ValueError(f"{name} = {value!r}: out of range; allowed: {allowed}")
    return x


def _law(name: str, law) -> float:
    if law not in CLOSURE_LAWS:
        raise ValueError(f"{name} = {law!r}: unknown closure law; allowed: {', '.join(map(repr, CLOSURE_LAWS))}")
    return CLOSURE_LAWS[law]


def joukowsky(density: float, wave_speed: float, velocity: float) -> float:
    """Joukowsky's pressure rise of an instantaneous stop, ``rho a dv``, Pa.

    The bound of any closure faster than the wave's round trip ``2 L / a`` (and, without column separation, of
    every closure of a frictionless line).

    Parameters
    ----------
    density : float
        Liquid density, kg/m^3 (> 0).
    wave_speed : float
        Pressure wave speed in the filled pipe, m/s (> 0; :func:`pipe_wave_speed`).
    velocity : float
        Change of the flow velocity, m/s (finite; the sign carries through).

    Returns
    -------
    float
        ``density * wave_speed * velocity``, Pa.
    """
    rho = _number("density", density, unit="kg/m^3")
    a = _number("wave_speed", wave_speed, unit="m/s")
    return rho * a * _number("velocity", velocity, low=None, unit="m/s")


def michaud(density: float, length: float, velocity: float, closure_time: float) -> float:
    """Michaud's slow-closure estimate of the rise, ``2 rho L v / Tc``, Pa.

    It assumes the velocity falls linearly over ``Tc > 2 L / a``. A valve whose loss is small against
    Joukowsky's rise destroys most of its flow at the end of its travel, and then the rise exceeds this
    estimate (for the linear law once the rise exceeds about three times the valve's initial loss).

    Parameters
    ----------
    density : float
        Liquid density, kg/m^3 (> 0).
    length : float
        Pipe length, m (> 0).
    velocity : float
        Initial velocity, m/s (>= 0).
    closure_time : float
        Closure time, s (> 0).

    Returns
    -------
    float
        The estimated rise, Pa.
    """
    rho = _number("density", density, unit="kg/m^3")
    L = _number("length", length, unit="m")
    v = _number("velocity", velocity, strict=False, unit="m/s")
    return 2.0 * rho * L * v / _number("closure_time", closure_time, unit="s")


def pipe_wave_speed(bulk_modulus: float, density: float, diameter: float, wall: float, young: float,
                    poisson: float = 0.3, *, support: str = "upstream") -> float:
    """Pressure wave speed of a liquid in a thin-walled elastic pipe (Korteweg), m/s.

    ``a = sqrt((K / rho) / (1 + c1 K D / (E e)))`` with ``c1`` from :data:`SUPPORTS` (Wylie & Streeter 1993,
    sec. 2.4; thin wall, ``D / e`` above about 25). For water hammer ``K`` is the liquid's isentropic bulk
    modulus ``rho c^2`` (the wave is too fast to exchange heat); for a cryogenic liquid it is far above the
    isothermal one (``cp / cv`` is about 1.65 for LNG).

    For LNG at -160 degC and 0.8 MPa, GERG-2008 (Kunz & Wagner 2012, evaluated with CoolProp 8.0) gives for a
    typical lean-to-medium composition (CH4 0.90, C2H6 0.06, C3H8 0.025, n-C4H10 0.01, N2 0.005 by mole) 459
    kg/m^3 and a speed of sound of 1398 m/s, ``K = 0.90 GPa`` (0.84 GPa for a leaner 448 kg/m^3 LNG, 0.95 GPa
    for a richer 470 kg/m^3 one; pure methane at its boiling point: 0.76 GPa). A 16-inch Sch 10S austenitic
    stainless line (OD 406.4 mm, wall 4.78 mm, ASME B36.19M; ``E`` about 195-200 GPa, 193 GPa at room
    temperature, a few percent more when cold) anchored upstream then carries the wave at about 1220 m/s.

    Parameters
    ----------
    bulk_modulus : float
        Liquid's isentropic bulk modulus ``K``, Pa (> 0).
    density : float
        Liquid density, kg/m^3 (> 0).
    diameter : float
        Pipe inner diameter ``D``, m (> 0).
    wall : float
        Wall thickness ``e``, m (> 0).
    young : float
        Young's modulus of the wall ``E``, Pa (> 0).
    poisson : float
        Poisson's ratio of the wall, in [0, 0.5).
    support : str
        How the pipe is held axially, a key of :data:`SUPPORTS` (default: anchored at its upstream end only).

    Returns
    -------
    float
        The wave speed, m/s.

    Examples
    --------
    >>> round(pipe_wave_speed(0.90e9, 459.0, 0.3968, 4.78e-3, 200e9))
    1220
    """
    K = _number("bulk_modulus", bulk_modulus, unit="Pa")
    rho = _number("density", density, unit="kg/m^3")
    D = _number("diameter", diameter, unit="m")
    e = _number("wall", wall, unit="m")
    E = _number("young", young, unit="Pa")
    nu = _number("poisson", poisson, strict=False)
    if nu >= 0.5:
        raise ValueError(f"poisson = {poisson!r}: out of range; allowed: finite and in [0, 0.5)")
    if support not in SUPPORTS:
        raise ValueError(f"support = {support!r}: unknown; allowed: {', '.join(map(repr, SUPPORTS))}")
    return math.sqrt(K / rho / (1.0 + SUPPORTS[support](nu) * K * D / (E * e)))


def valve_opening(t, closure_time: float, law: str = "linear", delay: float = 0.0) -> np.ndarray:
    """The valve's effective opening ``tau(t)``: 1 until ``delay``, then down to 0 at ``delay + closure_time``.

    Parameters
    ----------
    t : float or array_like
        Times, s.
    closure_time : float
        Closure time, s (> 0).
    law : str
        A key of :data:`CLOSURE_LAWS`.
    delay : float
        When the closure starts, s (>= 0).

    Returns
    -------
    ndarray
        ``tau`` in [0, 1], the shape of ``t``.
    """
    m = _law("law", law)
    tc = _number("closure_time", closure_time, unit="s")
    t0 = _number("delay", delay, strict=False, unit="s")
    s = np.clip((np.asarray(t, dtype=float) - t0) / tc, 0.0, 1.0)
    return (1.0 - s) ** m


#: The headline numbers of a surge check, declared once.
SURGE_METRICS = (
    Metric("verdict", "verdict"),
    Metric("route", "decided by"),
    Metric("closure_time_s", "ERS valve closure time", "s", ".2f"),
    Metric("closure_law", "closure law"),
    Metric("velocity_m_s", "line velocity", "m/s", ".2f"),
    Metric("round_trip_s", "wave round trip 2L/a", "s", ".3f"),
    Metric("operating_pressure_Pa", "pressure at the valve, steady flow", "bar g", ".2f", scale=_BAR),
    Metric("upstream_pressure_Pa", "pump pressure (constant head)", "bar g", ".2f", scale=_BAR),
    Metric("joukowsky_Pa", "Joukowsky rise rho a v", "bar", ".2f", scale=_BAR),
    Metric("bound_Pa", "Joukowsky bound (pump pressure + rho a v)", "bar g", ".2f", scale=_BAR),
    Metric("michaud_Pa", "Michaud estimate of the rise 2 rho L v / Tc", "bar", ".2f", scale=_BAR),
    Metric("peak_pressure_Pa", "peak pressure at the valve (MOC)", "bar g", ".2f", none="not computed",
           scale=_BAR),
    Metric("peak_time_s", "time of the peak", "s", ".2f", none="not computed"),
    Metric("min_pressure_Pa", "lowest pressure in the line (MOC)", "bar g", ".2f", none="not computed",
           scale=_BAR),
    Metric("judged_pressure_Pa", "pressure judged", "bar g", ".2f", scale=_BAR),
    Metric("design_pressure_Pa", "design pressure", "bar g", ".2f", none="none", scale=_BAR),
    Metric("margin_Pa", "margin (design - judged)", "bar", "+.2f", none="n/a", scale=_BAR),
)


def _empty() -> np.ndarray:
    return np.empty(0)


def _finite_or_none(x: float):
    return float(x) if math.isfinite(x) else None


@dataclass(frozen=True, eq=False)
class SurgeResult(Result):
    """The surge check of one ERS valve closure.

    Pressures are gauge, Pa; the series are empty when Joukowsky's bound decided (route ``'joukowsky'``).

    Attributes
    ----------
    route : str
        What decided: ``'joukowsky'`` (the bound alone) or ``'moc'`` (the transient).
    length, diameter, wave_speed, density, velocity, friction_factor : float
        The line (m, m, m/s, kg/m^3, m/s, 1).
    upstream_pressure : float
        The pump's constant pressure, Pa.
    operating_pressure : float
        The pressure at the valve in steady flow, Pa.
    downstream_pressure : float
        The constant pressure the valve discharges into, Pa.
    valve_loss : float
        The valve's own loss at the design flow, fully open, Pa (the rest of ``operating - downstream`` is a
        fixed loss in series).
    vapour_pressure : float
        The liquid's vapour pressure, Pa: below it the liquid column separates.
    design_pressure : float
        The arm's design pressure, Pa (``inf``: none).
    closure_time, delay : float
        The closure's duration and start, s.
    law : str
        The closure law (:data:`CLOSURE_LAWS`).
    reaches : int
        Reaches of the characteristics grid (0 on the Joukowsky route).
    dt : float
        Time step ``L / (reaches a)``, s (nan on the Joukowsky route).
    t : ndarray
        Times, s.
    valve_pressure, valve_flow, opening : ndarray
        At the valve: pressure (Pa), flow (m^3/s) and effective opening ``tau``, at ``t``.
    x : ndarray
        Node positions from the pump, m.
    line_max, line_min : ndarray
        Highest and lowest pressure over the run at each node, Pa.
    """

    route: str
    length: float
    diameter: float
    wave_speed: float
    density: float
    velocity: float
    friction_factor: float
    upstream_pressure: float
    operating_pressure: float
    downstream_pressure: float
    valve_loss: float
    vapour_pressure: float
    design_pressure: float
    closure_time: float
    delay: float
    law: str
    reaches: int = 0
    dt: float = math.nan
    t: np.ndarray = field(default_factory=_empty)
    valve_pressure: np.ndarray = field(default_factory=_empty)
    valve_flow: np.ndarray = field(default_factory=_empty)
    opening: np.ndarray = field(default_factory=_empty)
    x: np.ndarray = field(default_factory=_empty)
    line_max: np.ndarray = field(default_factory=_empty)
    line_min: np.ndarray = field(default_factory=_empty)

    METRICS = SURGE_METRICS

    @property
    def joukowsky_rise(self) -> float:
        """Joukowsky's rise ``rho a v``, Pa."""
        return self.density * self.wave_speed * self.velocity

    @property
    def bound(self) -> float:
        """The closure's upper bound, ``upstream_pressure + rho a v``, Pa."""
        return self.upstream_pressure + self.joukowsky_rise

    @property
    def michaud_rise(self) -> float:
        """Michaud's slow-closure estimate of the rise ``2 rho L v / Tc``, Pa."""
        return 2.0 * self.density * self.length * self.velocity / self.closure_time

    @property
    def friction_drop(self) -> float:
        """Darcy-Weisbach's drop along the line in steady flow, Pa."""
        return self.upstream_pressure - self.operating_pressure

    @property
    def round_trip(self) -> float:
        """The wave's round trip ``2 L / a``, s."""
        return 2.0 * self.length / self.wave_speed

    @property
    def peak_pressure(self) -> float:
        """The highest pressure at the valve, Pa (nan on the Joukowsky route)."""
        return float(self.valve_pressure.max()) if self.valve_pressure.size else math.nan

    @property
    def peak_time(self) -> float:
        """When the valve's pressure peaks, s (nan on the Joukowsky route)."""
        return float(self.t[int(np.argmax(self.valve_pressure))]) if self.valve_pressure.size else math.nan

    @property
    def min_pressure(self) -> float:
        """The lowest pressure anywhere in the line, Pa (nan on the Joukowsky route)."""
        return float(self.line_min.min()) if self.line_min.size else math.nan

    @property
    def column_separation(self) -> bool:
        """Whether the pressure falls below the vapour pressure somewhere (the liquid column separates)."""
        return bool(self.min_pressure < self.vapour_pressure)

    @property
    def judged_pressure(self) -> float:
        """The pressure the verdict is on: the bound (route 'joukowsky') or the peak at the valve, Pa."""
        return self.bound if self.route == "joukowsky" else self.peak_pressure

    @property
    def margin(self) -> float:
        """``design_pressure - judged_pressure``, Pa (positive: passes)."""
        return self.design_pressure - self.judged_pressure

    @property
    def problems(self) -> tuple:
        """Why the closure is refused (empty when it passes)."""
        out = []
        if self.margin < 0:
            out.append(f"the {'bound' if self.route == 'joukowsky' else 'peak at the valve'} "
                       f"{self.judged_pressure * _BAR:.2f} bar g exceeds the design pressure "
                       f"{self.design_pressure * _BAR:.2f} bar g by {-self.margin * _BAR:.2f} bar")
        if self.column_separation:
            out.append(f"column separation: the pressure falls to {self.min_pressure * _BAR:.2f} bar g, below the "
                       f"vapour pressure {self.vapour_pressure * _BAR:.2f} bar g; the liquid-only model does not "
                       "bound the peak (cavity collapse)")
        return tuple(out)

    @property
    def ok(self) -> bool:
        """Whether the closure passes: the judged pressure within the design pressure, no column separation."""
        return not self.problems

    def _values(self) -> dict:
        return {
            "verdict": "pass" if self.ok else "fail",
            "route": self.route,
            "closure_time_s": self.closure_time,
            "closure_law": self.law,
            "velocity_m_s": self.velocity,
            "round_trip_s": self.round_trip,
            "operating_pressure_Pa": self.operating_pressure,
            "upstream_pressure_Pa": self.upstream_pressure,
            "joukowsky_Pa": self.joukowsky_rise,
            "bound_Pa": self.bound,
            "michaud_Pa": self.michaud_rise,
            "peak_pressure_Pa": _finite_or_none(self.peak_pressure),
            "peak_time_s": _finite_or_none(self.peak_time),
            "min_pressure_Pa": _finite_or_none(self.min_pressure),
            "judged_pressure_Pa": self.judged_pressure,
            "design_pressure_Pa": _finite_or_none(self.design_pressure),
            "margin_Pa": _finite_or_none(self.margin),
            "friction_drop_Pa": self.friction_drop,
            "valve_loss_Pa": self.valve_loss,
            "column_separation": self.column_separation,
            "reaches": self.reaches,
            "problems": list(self.problems),
        }

    def _figure(self):

        return surge_figure(self)


def _auto_reaches(length: float, wave_speed: float, closure_time: float) -> int:
    """Reaches so that the closure spans at least 400 steps, between 4 and 200."""
    return int(min(200, max(4, math.ceil(400.0 * length / (wave_speed * closure_time)))))


def _march(p: np.ndarray, q: np.ndarray, tau: np.ndarray, *, b: float, r: float, q0: float, p_up: float,
           p_down: float, dp_valve: float, dp_rest: float):
    """Step the characteristics grid through ``tau``; returns the valve's pressure and flow and the envelopes.

    ``p``, ``q`` (node pressures and flows, modified in place) hold the steady state; ``b = rho a / A`` and
    ``r = f dx rho / (2 D A^2)`` are the pipe's impedance and friction per reach.
    """
    nt = tau.size - 1
    pv, qv = np.empty(nt + 1), np.empty(nt + 1)
    pv[0], qv[0] = p[-1], q[-1]
    hi, lo = p.copy(), p.copy()
    wp, wm, bq, fq = (np.empty_like(p) for _ in range(4))
    half_b = 0.5 / b
    for k in range(1, nt + 1):
        np.multiply(q, b, out=bq)
        np.add(p, bq, out=wp)                 # C+ leaving each node: p + B Q - R Q|Q|
        np.subtract(p, bq, out=wm)            # C- leaving each node: p - B Q + R Q|Q|
        if r:
            np.abs(q, out=fq)
            fq *= q
            fq *= r
            wp -= fq
            wm += fq
        cp, cm = float(wp[-2]), float(wm[1])
        np.add(wp[:-2], wm[2:], out=p[1:-1])
        p[1:-1] *= 0.5
        np.subtract(wp[:-2], wm[2:], out=q[1:-1])
        q[1:-1] *= half_b
        p[0], q[0] = p_up, (p_up - cm) / b
        t2 = float(tau[k]) ** 2
        c = t2 * q0 * q0 / (dp_valve + t2 * dp_rest)      # Q|Q| = c (p - p_down) through the valve
        head = cp - p_down
        qk = 2.0 * c * head / (c * b + math.sqrt(c * c * b * b + 4.0 * c * abs(head))) if c > 0.0 else 0.0
        q[-1], p[-1] = qk, cp - b * qk
        np.maximum(hi, p, out=hi)
        np.minimum(lo, p, out=lo)
        pv[k], qv[k] = p[-1], qk
    return pv, qv, hi, lo


def moc_valve_closure(*, length: float, diameter: float, wave_speed: float, density: float, velocity: float,
                      upstream_pressure: float, closure_time: float, friction_factor: float = 0.0,
                      law: str = "linear", downstream_pressure: float = 0.0, valve_loss: float | None = None,
                      vapour_pressure: float = 0.0, design_pressure: float = math.inf, delay: float = 0.0,
                      duration: float | None = None, reaches: int | None = None) -> SurgeResult:
    """The transient of a valve closing at the end of a pipe fed by a constant-pressure pump (MOC).

    Steady flow at ``velocity`` until ``delay``, then the valve's effective opening follows ``law`` down to 0
    at ``delay + closure_time``; the run goes on to ``duration``. Pressures are gauge.

    The run costs about 12 us per time step (9 without friction) on a 2-core CI machine; the default grid takes
    about ``400 + 8 reaches`` steps past the delay (681 steps, 8 ms, for a 10 s closure of 1 km of LNG line at
    1200 m/s).

    Parameters
    ----------
    length : float
        Pipe length from the pump to the valve, m (> 0).
    diameter : float
        Pipe inner diameter, m (> 0).
    wave_speed : float
        Pressure wave speed, m/s (> 0).
    density : float
        Liquid density, kg/m^3 (> 0).
    velocity : float
        Steady velocity towards the valve, m/s (> 0).
    upstream_pressure : float
        The pump's constant pressure at the pipe's inlet, Pa; above ``downstream_pressure`` plus the line's
        friction drop.
    closure_time : float
        Duration of the closure, s (> 0; one time step or less: an instantaneous closure).
    friction_factor : float
        Darcy friction factor (>= 0).
    law : str
        The closure law, a key of :data:`CLOSURE_LAWS`.
    downstream_pressure : float
        The constant pressure the valve discharges into, Pa.
    valve_loss : float, optional
        The valve's own pressure loss fully open at the design flow, Pa, in (0, operating - downstream]; the
        rest is a fixed loss in series. Default: all of it (the valve's law is the whole outlet's).
    vapour_pressure : float
        Vapour pressure of the liquid, Pa; below it the result reports column separation.
    design_pressure : float
        Design pressure the peak is judged against, Pa (default: none).
    delay : float
        Start of the closure, s (>= 0).
    duration : float, optional
        End of the run, s (default: ``delay + closure_time + 8 L / a``, two wave periods after the closure).
    reaches : int, optional
        Reaches of the grid (default: enough for 400 steps over the closure, between 4 and 200).

    Returns
    -------
    SurgeResult
        Route ``'moc'``, with the series at the valve and the envelopes along the line.
    """
    L = _number("length", length, unit="m")
    D = _number("diameter", diameter, unit="m")
    a = _number("wave_speed", wave_speed, unit="m/s")
    rho = _number("density", density, unit="kg/m^3")
    v = _number("velocity", velocity, unit="m/s")
    p_up = _number("upstream_pressure", upstream_pressure, low=None, unit="Pa")
    tc = _number("closure_time", closure_time, unit="s")
    f = _number("friction_factor", friction_factor, strict=False)
    _law("law", law)
    p_down = _number("downstream_pressure", downstream_pressure, low=None, unit="Pa")
    p_vap = _number("vapour_pressure", vapour_pressure, low=None, unit="Pa")
    p_design = float(design_pressure)
    if math.isnan(p_design):
        raise ValueError(f"design_pressure = {design_pressure!r}: not a number; allowed: a pressure in Pa or inf")
    t0 = _number("delay", delay, strict=False, unit="s")
    t_end = t0 + tc + 8.0 * L / a if duration is None else _number("duration", duration, unit="s")
    n = _auto_reaches(L, a, tc) if reaches is None else int(_number("reaches", reaches, low=1, strict=False))

    area = 0.25 * math.pi * D * D
    q0 = v * area
    drop = f * L / D * rho * v * v / 2.0
    dp0 = p_up - drop - p_down
    if dp0 <= 0.0:
        raise ValueError(f"upstream_pressure = {upstream_pressure!r}: out of range; allowed: above "
                         f"downstream_pressure + friction drop = {p_down + drop:.6g} Pa")
    dpv = dp0 if valve_loss is None else _number("valve_loss", valve_loss, unit="Pa")
    if dpv > dp0:
        raise ValueError(f"valve_loss = {valve_loss!r}: out of range; allowed: in (0, {dp0:.6g}] Pa (the "
                         "pressure left at the valve's inlet over the downstream pressure)")

    dx = L / n
    dt = dx / a
    b = rho * a / area
    r = f * dx * rho / (2.0 * D * area * area)
    x = np.linspace(0.0, L, n + 1)
    p = p_up - drop * x / L
    q = np.full(n + 1, q0)
    t = np.arange(int(math.ceil(t_end / dt - 1e-9)) + 1) * dt
    tau = valve_opening(t, tc, law, t0)
    pv, qv, hi, lo = _march(p, q, tau, b=b, r=r, q0=q0, p_up=p_up, p_down=p_down, dp_valve=dpv,
                            dp_rest=dp0 - dpv)
    return SurgeResult("moc", L, D, a, rho, v, f, p_up, p_up - drop, p_down, dpv, p_vap, p_design, tc, t0, law,
                       n, dt, t, pv, qv, tau, x, hi, lo)


def _attr(transfer, name: str, *, low: float | None = 0.0, strict: bool = True, unit: str = "") -> float:
    try:
        value = getattr(transfer, name)
    except AttributeError:
        raise ValueError(f"transfer.{name}: missing; the transfer record needs it") from None
    return _number(f"transfer.{name}", value, low=low, strict=strict, unit=unit)


def surge_check(transfer, closure_time: float) -> SurgeResult:
    """Check the ERS valve's closure at the arm's design flow against the arm's design pressure.

    Joukowsky first: when the bound ``operating + friction drop + rho a v`` (the pump's pressure plus
    Joukowsky's rise; with friction the line packs up to the pump's pressure, so the operating pressure alone
    is not a bound) is within the design pressure and ``operating - rho a v`` stays above the vapour pressure,
    the closure passes on the bound alone (route ``'joukowsky'``); otherwise the transient is computed
    (:func:`moc_valve_closure`, route ``'moc'``) and judged on its peak at the valve.

    Parameters
    ----------
    transfer : record
        Any object with ``design_flow`` (m^3/s), ``bore`` (m, inner diameter of the line), ``density``
        (kg/m^3), ``wave_speed`` (m/s), ``line_length`` (m, from the pump to the ERS valve), ``friction_factor``
        (Darcy), ``operating_pressure`` (Pa g, at the valve in steady flow), ``design_pressure`` (Pa g, the
        arm's) and ``closure_law`` (a key of :data:`CLOSURE_LAWS`); optionally ``downstream_pressure`` (Pa g,
        default 0), ``vapour_pressure`` (Pa g, default 0) and ``valve_loss`` (Pa, the ERS valve's own loss
        fully open; default: the whole of operating minus downstream).
    closure_time : float
        The ERS valve's closure time, s (> 0).

    Returns
    -------
    SurgeResult
        Route ``'joukowsky'`` (no series) or ``'moc'``, the pressure judged, the design pressure and the margin.
    """
    tc = _number("closure_time", closure_time, unit="s")
    flow = _attr(transfer, "design_flow", unit="m^3/s")
    D = _attr(transfer, "bore", unit="m")
    rho = _attr(transfer, "density", unit="kg/m^3")
    a = _attr(transfer, "wave_speed", unit="m/s")
    L = _attr(transfer, "line_length", unit="m")
    f = _attr(transfer, "friction_factor", strict=False)
    p_op = _attr(transfer, "operating_pressure", low=None, unit="Pa")
    p_design = _attr(transfer, "design_pressure", low=None, unit="Pa")
    law = getattr(transfer, "closure_law", None)
    _law("transfer.closure_law", law)
    p_down = _number("transfer.downstream_pressure", getattr(transfer, "downstream_pressure", 0.0), low=None)
    p_vap = _number("transfer.vapour_pressure", getattr(transfer, "vapour_pressure", 0.0), low=None)
    valve_loss = getattr(transfer, "valve_loss", None)
    if p_op <= p_down:
        raise ValueError(f"transfer.operating_pressure = {p_op!r}: out of range; allowed: above the downstream "
                         f"pressure {p_down:g} Pa")

    v = flow / (0.25 * math.pi * D * D)
    rise = joukowsky(rho, a, v)
    p_up = p_op + f * L / D * rho * v * v / 2.0
    if p_up + rise <= p_design and p_op - rise >= p_vap:
        dpv = p_op - p_down if valve_loss is None else _number("transfer.valve_loss", valve_loss, unit="Pa")
        return SurgeResult("joukowsky", L, D, a, rho, v, f, p_up, p_op, p_down, dpv, p_vap, p_design, tc, 0.0, law)
    try:
        return moc_valve_closure(length=L, diameter=D, wave_speed=a, density=rho, velocity=v, upstream_pressure=p_up,
                                 closure_time=tc, friction_factor=f, law=law, downstream_pressure=p_down,
                                 valve_loss=valve_loss, vapour_pressure=p_vap, design_pressure=p_design)
    except ValueError as exc:           # name the record's attribute, not the model's argument
        if str(exc).startswith("valve_loss"):
            raise ValueError(f"transfer.{exc}") from None
        raise
