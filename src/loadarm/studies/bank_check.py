"""``loadarm check --bank``'s checks and their verdict, in one place: the command line refuses a bank on the first
refusal, the report shows every check and every refusal (found: the report computed the checks again and stopped
on the first error, a power unit too small for the approaches; it never said that a bank the check refuses was
refused).

The checks, each in its own module: the approaches ordered to the design flanges and to each corner of the
flanging area (:func:`loadarm.design.bank.order_over_flanging_area`), the swivels at the design case and over the
flanging area and the ship's motions (:func:`~loadarm.design.bank.design_swivel_margins`,
:func:`~loadarm.design.bank.swivel_envelope`), the loads on the manifold
(:func:`loadarm.design.manifold.check_manifold_loads`) and one emergency release for all
(:func:`loadarm.hydraulics.bank_release.simulate_release`). Each refusal is one line naming the file, the key and
what is short.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.manifold import LOAD_NAMES
from loadarm.design.bank import (BankOrder, SwivelEnvelope, design_swivel_margins, flanging_moves,
                                 order_bank_approaches, order_over_flanging_area, swivel_envelope)
from loadarm.design.manifold import LOAD_LABELS, ManifoldLoadCheck, check_manifold_loads
from loadarm.errors import LoadarmError
from loadarm.hydraulics.bank_release import BankRelease, simulate_release
from loadarm.params.bank import Bank
from loadarm.vocab import event_label

__all__ = ["BankChecks", "check_bank", "overload_line"]


@dataclass(frozen=True)
class BankChecks:
    """Every check of a bank and its refusals (a bundle of results, each with its own ``summary()``, ``to_dict()``
    and ``plot()``).

    Attributes
    ----------
    bank : Bank
    over : tuple of (displacement, BankOrder)
        The approaches' order at the design position (first) and at each corner of the flanging area: the design
        position's alone when a corner's could not be made, empty when not even it could (the refusal says why).
    swivel_margins : ndarray, shape (n_arms, 6)
        Each arm's swivels' margins to their stops at the design case, rad.
    swivels : SwivelEnvelope
        Their margins over the flanging area's corners and the ship's motions.
    loads : ManifoldLoadCheck
    release : BankRelease
    refusals : tuple of str
        One line each, in the check's order (approaches, swivels, the connected arms' clearance, manifold loads,
        release); empty: the bank passes.
    """

    bank: Bank
    over: tuple
    swivel_margins: np.ndarray
    swivels: SwivelEnvelope
    loads: ManifoldLoadCheck
    release: BankRelease
    refusals: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """No refusal."""
        return not self.refusals

    @property
    def order(self) -> BankOrder | None:
        """The approaches' order at the design flanges (None when none could be made)."""
        return self.over[0][1] if self.over else None

    def corners(self) -> dict | None:
        """The flanging area's corners: the least clearance of their ordered approaches, where, and each corner's
        order (None when a corner's order could not be made).

        Returns
        -------
        dict or None
        """
        if len(self.over) < 2:
            return None
        corner, worst = min(self.over[1:], key=lambda c: c[1].clearance.min_clearance)
        return {"least_clearance_m": worst.clearance.min_clearance, "displacement_m": list(corner),
                "orders": [[list(w) for w in o.waves] for _, o in self.over[1:]]}

    def to_dict(self) -> dict:
        """JSON-ready: each check's own ``to_dict()`` and the refusals.

        Returns
        -------
        dict
        """
        names = self.bank.names
        order = self.order
        return {"ok": self.ok, "refusals": list(self.refusals),
                "approach_order": None if order is None else order.to_dict(),
                "clearance": None if order is None else order.clearance.to_dict(),
                "flanging_area_corners": self.corners(),
                "swivel_envelope": self.swivels.to_dict(),
                "swivel_margin_deg": {n: math.degrees(float(self.swivel_margins[i].min())) for i, n in enumerate(names)},
                "release": self.release.to_dict(), "manifold_loads": self.loads.to_dict()}


def overload_line(bank: Bank, exceeded: list[dict]) -> str:
    """One line naming the worst load past its allowable: the file, the alarm's label, the arm, the load and its
    key.

    Parameters
    ----------
    bank : Bank
    exceeded : list of dict
        :attr:`ManifoldLoadCheck.exceeded`.

    Returns
    -------
    str
    """
    e = max(exceeded, key=lambda e: e["value"] / e["allowable"])
    unit = "kN" if e["load"].endswith("force") else "kN m"
    return (f"{bank.source}: {event_label(e['code'])}: arm {e['arm']!r} loads its flange with {e['value'] / 1e3:.2f} "
            f"{unit} of {LOAD_LABELS[LOAD_NAMES.index(e['load'])]}; manifold_loads.{e['load']} = "
            f"{e['allowable'] / 1e3:g} {unit} ({len(exceeded)} loads of the bank over their allowable)")


def _approaches(bank: Bank) -> tuple[tuple, list[str]]:
    """The ordered approaches at the design position and over the flanging area, as far as they could be made,
    and why not (each error's own line, as the command has always printed it)."""
    try:
        design = order_bank_approaches(bank)
    except LoadarmError as exc:
        return (), [str(exc)]
    try:
        over = tuple(order_over_flanging_area(bank, design))
    except LoadarmError as exc:            # a corner of the flanging area: the design position's order stands
        return ((flanging_moves(bank)[0], design),), [str(exc)]
    clearance = design.clearance
    if not clearance.clear:
        return over, [f"{bank.source}: the arms' approaches come {clearance.where()}, below "
                      f"clearance.min_clearance = {clearance.required:g} m"]
    return over, []


def check_bank(bank: Bank) -> BankChecks:
    """Every check of ``loadarm check --bank`` and its refusals.

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    BankChecks
    """
    over, refusals = _approaches(bank)
    swivels = swivel_envelope(bank)
    least, k, i, j = swivels.least()
    if least < 0.0:
        key = f"swivel{j // 2 + 1}_deg"
        refusals.append(f"{bank.source}: {swivels.words(k, i, j)}: past its stop by {math.degrees(-least):.1f} deg; "
                        f"swivels.{key} = {list(getattr(bank.file.swivels, key))} deg (the flanging area's corners "
                        "and the terminal's [operability] roll, pitch and yaw limits)")
    if swivels.clearance is not None and not swivels.clearance.clear:
        refusals.append(f"{bank.source}: the arms connected come {swivels.clash_words()}, below "
                        f"clearance.min_clearance = {swivels.clearance.required:g} m (the flanging area's corners "
                        "and the terminal's [operability] roll, pitch and yaw limits)")
    loads = check_manifold_loads(bank)
    if not loads.ok:
        refusals.append(overload_line(bank, loads.exceeded))
    release = simulate_release(bank)
    if not release.ok:
        refusals.append(release.problems[0])
    return BankChecks(bank, over, design_swivel_margins(bank), swivels, loads, release, tuple(refusals))
