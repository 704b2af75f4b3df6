"""The alarm settings of a bank of arms (``loadarm alarms --bank``, issue 31 item 6).

The arms of a bank share one ship: one mooring analysis (:func:`loadarm.design.alarm_design.mooring_analysis`)
gives the motion of every presentation flange, each the ship's manifold moved by its flange's offset along the
ship and its height (the same ship turned with its yaw moves each flange by its own lever). Each arm's stages
are then stacked on its own flange's drift (:func:`loadarm.design.alarm_design.design_from_analysis`), over its
own flanging area (the berth's manifold tolerance either side of its flange).

Arms built from one installation file share that file's ``[alarms]``, ``[slew]`` and ``[design_drift]``: the
settings to paste are the ones that suit every arm of the file (:func:`recommended_settings` over all their
faces: the earliest stage, ESD-1 never inside any arm's drift allowance; the largest design drift), and each
arm's stages are judged again under them (``settings = "bank"``). A bank whose shared settings leave an arm
short (its break-out past a face before its sequence is done, or ESD-1 inside its allowance) is refused, naming
the arm, the face, the stage and the shortfall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from loadarm.design.alarm_design import (
    AlarmDesign,
    DesignSettings,
    design_from_analysis,
    flanging_corners,
    mooring_analysis,
    recommended_settings,
)
from loadarm.errors import ConfigError
from loadarm.figures import subplots
from loadarm.results import Metric, Result

__all__ = ["bank_ships", "BankAlarmDesign", "design_bank_alarms", "HEADING_TOLERANCE_DEG", "SHARED",
           "MARGIN_TOLERANCE_M"]

#: The bank's manifold heading and the berth's ship heading must agree within this, deg.
HEADING_TOLERANCE_DEG = 0.5
#: The label of the shared settings' stage fits.
SHARED = "bank"
#: A stage's margin under the shared settings this much below its margin under the arm's own is reported, m
#: (the stacking's own resolution: ray crossings are found to 1 mm, thresholds rounded to 0.1 deg).
MARGIN_TOLERANCE_M = 0.01


def bank_ships(bank, ship) -> list:
    """The ship once per arm, its manifold moved to that arm's presentation flange (its offset along the ship
    and its height), in the arms' order.

    Parameters
    ----------
    bank : Bank
    ship : ShipModel
        The berth's ship; its ``manifold`` is the bank's manifold centre.

    Returns
    -------
    list of ShipModel

    Raises
    ------
    ConfigError
        The bank's ``manifold.heading_deg`` is not the berth's ship heading.
    """
    psi0 = float(ship.moorings.psi0)
    heading = bank.file.manifold.heading_deg
    if abs((heading - math.degrees(psi0) + 180.0) % 360.0 - 180.0) > HEADING_TOLERANCE_DEG:
        raise ConfigError(f"{bank.source}: manifold.heading_deg = {heading:g}: the berth's ship lies with its bow at "
                          f"{math.degrees(psi0):g} deg (allowed: within {HEADING_TOLERANCE_DEG:g} deg of it)")
    c, s = math.cos(psi0), math.sin(psi0)
    out = []
    for f in bank.flanges:
        # berth frame (0, offset) along the jetty, turned into the ship's axes (x to the bow, y to port)
        shift = np.array([s * f.offset, c * f.offset, f.height])
        out.append(replace(ship, manifold=np.asarray(ship.manifold, dtype=float) + shift))
    return out


def _shared(designs, paths) -> dict:
    """Per installation file, the settings that suit every arm built from it (degrees, as recommended)."""
    out = {}
    for path in dict.fromkeys(paths):
        group = [d for d, p in zip(designs, paths) if p == path]
        rec = recommended_settings([r for d in group for r in d.rows])
        rec["design_drift_speed_ms"] = max(d.recommended["design_drift_speed_ms"] for d in group)
        rec["design_drift_acceleration_ms2"] = max(d.recommended["design_drift_acceleration_ms2"] for d in group)
        out[path] = rec
    return out


def _costs(name: str, design: AlarmDesign) -> list[str]:
    """Where the shared settings leave the arm less margin than its own recommended settings, by more than
    :data:`MARGIN_TOLERANCE_M` (ESD-1 and the release on each face: the stages with a deadline)."""
    own = {(f.face, f.stage): f for f in design.stages if f.settings == "recommended"}
    out = []
    for fit in design.stages:
        mine = own.get((fit.face, fit.stage))
        if fit.settings != SHARED or mine is None or fit.breakout_margin_m is None \
                or fit.margin_m >= mine.margin_m - MARGIN_TOLERANCE_M:
            continue
        out.append(f"arm {name}: {fit.stage} on {fit.face} at the shared {fit.angle_deg:.1f} deg (its own "
                   f"{mine.angle_deg:.1f} deg): margin {fit.margin_m:+.2f} m, {mine.margin_m - fit.margin_m:.2f} m "
                   "less than its own")
    return out


@dataclass(frozen=True)
class BankAlarmDesign(Result):
    """The alarm design of a bank (``loadarm alarms --bank``).

    Attributes
    ----------
    names : tuple of str
        The arms.
    files : tuple of str
        Each arm's installation file.
    designs : tuple of AlarmDesign
        Each arm's own design at its flange (its stage fits include ``settings = "bank"``: the shared
        settings of its file judged on it).
    shared : dict
        Per installation file, the settings to paste (degrees; as :attr:`AlarmDesign.recommended`).
    problems : tuple of str
        Each arm's refusals (it cannot absorb the design drift at a corner of its flanging area), naming the arm.
    costs : tuple of str
        Where the shared settings leave an arm less margin than its own recommended ones.
    """

    names: tuple
    files: tuple
    designs: tuple = field(repr=False)
    shared: dict = field(repr=False)
    problems: tuple = ()
    costs: tuple = ()

    METRICS = (
        Metric("ok", "design holds for every arm"),
        Metric("arms", "arms", "", "d"),
        Metric("files", "installation files", "", "d"),
        Metric("first_beta_deg", "ESD-1 beta, earliest of the files", "deg", ".1f", none="-"),
        Metric("release_beta_deg", "ERS-2 beta, earliest of the files", "deg", ".1f", none="-"),
        Metric("first_slew_deg", "ESD-1 slew, earliest of the files", "deg", ".1f", none="-"),
        Metric("allowance_min_m", "drift allowance off the berth, least arm", "m", ".2f"),
        Metric("allowance_max_m", "drift allowance off the berth, largest arm", "m", ".2f"),
        Metric("governing_arm", "arm whose drift sets ESD-1 beta"),
        Metric("design_drift_speed_ms", "design drift speed, largest", "m/s", ".2f"),
    )

    @property
    def ok(self) -> bool:
        """No arm refused."""
        return not self.problems

    def _values(self) -> dict:
        def least(key):
            vals = [r[key] for r in self.shared.values() if r.get(key) is not None]
            return min(vals) if vals else None

        own = [d.recommended.get("first_beta_deg") for d in self.designs]
        governing = min((v, n) for v, n in zip(own, self.names) if v is not None)[1] if any(
            v is not None for v in own) else "-"
        allowances = [d.rows[0].allowance_m for d in self.designs]
        return {"ok": self.ok, "arms": len(self.names), "files": len(self.shared),
                "first_beta_deg": least("first_beta_deg"), "release_beta_deg": least("release_beta_deg"),
                "first_slew_deg": least("first_slew_deg"), "allowance_min_m": min(allowances),
                "allowance_max_m": max(allowances), "governing_arm": governing,
                "design_drift_speed_ms": max(r["design_drift_speed_ms"] for r in self.shared.values())}

    def to_dict(self) -> dict:
        """The headline, each arm's design, and the settings to paste per installation file.

        Returns
        -------
        dict
        """
        return {**self._values(), "problems": list(self.problems), "costs": list(self.costs),
                "arms_design": {n: {"installation": f, **d.to_dict()}
                                for n, f, d in zip(self.names, self.files, self.designs)},
                "arm_rows": self.arm_rows(), "shared": {f: dict(r) for f, r in self.shared.items()},
                "toml": {f: self.toml(f) for f in self.shared}}

    def toml(self, path: str) -> str:
        """The settings to paste into one installation file (``[alarms]``, ``[slew]``, ``[design_drift]``).

        Parameters
        ----------
        path : str
            One of :attr:`files`.

        Returns
        -------
        str
        """
        first = self.designs[self.files.index(path)]
        return replace(first, recommended=self.shared[path]).toml()

    def arm_rows(self) -> list[dict]:
        """Per arm: its own recommended stages, its drift allowance, the least margin of the shared settings and
        the verdict: ``refused`` (it cannot absorb the design drift at a corner of its flanging area), ``holds``
        (the shared angles alone hold on every face), or ``holds by the floor`` (a shared angle alone is late for
        the break-out, or fires inside the intact drift allowance, by the negative margin: the design-drift floor
        of the connected-mode monitor raises ESD-1 by the time to the face whatever the angles; the single arm's
        ``conditional``).

        Returns
        -------
        list of dict
        """
        rows = []
        for n, f, d in zip(self.names, self.files, self.designs):
            fits = [s for s in d.stages if s.settings == SHARED]
            rows.append({"arm": n, "installation": f, "allowance_m": d.rows[0].allowance_m,
                         **{k: d.recommended.get(k) for k in ("first_beta_deg", "release_beta_deg",
                                                               "first_slew_deg", "release_slew_deg")},
                         "shared_margin_m": min((s.margin_m for s in fits), default=None),
                         "ok": d.ok})
            least = rows[-1]["shared_margin_m"]
            rows[-1]["verdict"] = "refused" if not d.ok else (
                "holds" if least is None or least >= 0 else "holds by the floor")
        return rows

    def _figure(self):
        fig, (ax, bx) = subplots(1, 2, figsize=(11, 4))
        x = np.arange(len(self.names))
        for k, (key, label) in enumerate((("first_beta_deg", "ESD-1"), ("release_beta_deg", "ERS-2"))):
            own = [np.nan if d.recommended.get(key) is None else d.recommended[key] for d in self.designs]
            ax.bar(x + (k - 0.5) * 0.38, own, 0.38, color=("0.45", "0.75")[k], edgecolor="0.2",
                   label=f"{label}: the arm's own")
            shared = [self.shared[f].get(key) for f in self.files]
            ax.plot(x + (k - 0.5) * 0.38, [np.nan if v is None else v for v in shared], "_", ms=22, mew=2.5,
                    color="tab:red" if k == 0 else "tab:orange", label=f"{label}: shared by its file")
        ax.set_xticks(x, self.names)
        ax.set_ylabel("beta threshold, deg")
        lo = np.nanmin([d.recommended.get("first_beta_deg") or np.nan for d in self.designs])
        ax.set_ylim(lo - 5.0, None)
        ax.legend(fontsize=7, loc="lower right")
        ax.set_title("beta thresholds per arm")
        for d, n in zip(self.designs, self.names):
            bx.plot(d.breakout_t, d.breakout_s, lw=1.2, label=n)
        bx.set_xlabel("time since the lines part, s")
        bx.set_ylabel("break-out drift off the berth, m")
        bx.set_title("break-out at each arm's flange")
        bx.legend(fontsize=7)
        fig.tight_layout()
        return fig


def design_bank_alarms(bank, ship, env, *, settings: DesignSettings | None = None,
                       progress=None) -> BankAlarmDesign:
    """Design the alarm settings of every arm of a bank from one mooring analysis of the berth's ship.

    Parameters
    ----------
    bank : Bank
    ship : ShipModel
        The berth's ship (its manifold the bank's centre).
    env : Environment
        The design environment.
    settings : DesignSettings, optional
        Default: :class:`DesignSettings` ().
    progress : callable, optional
        Called with the fraction done.

    Returns
    -------
    BankAlarmDesign

    Raises
    ------
    ConfigError
        The bank's heading is not the ship's, or an arm has no corner of its flanging area inside its envelope.
    """
    settings = DesignSettings() if settings is None else settings
    ships = bank_ships(bank, ship)
    flanges = [tuple(float(v) for v in bank.flange_position(i)) for i in range(len(bank.names))]
    areas = []
    for i, model in enumerate(bank.models):
        try:
            areas.append(flanging_corners(model, ships[i], flanges[i]))
        except ConfigError as exc:
            raise ConfigError(f"{bank.source}: arm {bank.names[i]}: {exc}") from None
    analyses = mooring_analysis(ships, env, settings, progress)
    paths = tuple(str(p) for p in bank.paths)
    own = [design_from_analysis(m, a, settings, f, c, w)
           for m, a, f, (c, w) in zip(bank.models, analyses, flanges, areas)]
    shared = _shared(own, paths)
    designs = tuple(design_from_analysis(m, a, settings, f, c, w, judged=((SHARED, shared[p]),))
                    for m, a, f, (c, w), p in zip(bank.models, analyses, flanges, areas, paths))
    problems = [f"arm {n}: {p}" for n, d in zip(bank.names, designs) for p in d.problems]
    costs = [c for n, d in zip(bank.names, designs) for c in _costs(n, d)]
    return BankAlarmDesign(bank.names, paths, designs, shared, tuple(problems), tuple(costs))
