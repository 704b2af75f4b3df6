"""The emergency sequence's times, written once: what each alarm stage must leave before the flange reaches a
face of the attached envelope, and which stage a time to the nearest face calls for.

The sequence: pre-alarm -> ESD-1 (stop the transfer pumps, close the ESD valves; the ERS valves too unless
the installation closes them at ERS-2) -> the ERS valves confirmed closed by their limit switches -> ERS-2
releases the coupler -> retraction. Until the switches confirm, every lead counts the valves at the worst
their timeout allows (:func:`valve_worst_time`): a slow valve inside its timeout is no fault, and the coupler
waits for it.

The live monitor (:func:`loadarm.guidance.monitor.stage_leads`, the controller), the design check
(:mod:`loadarm.design.check`), alarm design and the operability kernel (:mod:`loadarm.studies.kernel`, which
compiles :func:`lead_values` and :func:`stage_of` with numba rather than transcribing them) all call these.
Pure scalar arithmetic: nothing here imports the rest of loadarm.
"""

from __future__ import annotations

import math

__all__ = ["valve_worst_time", "esd_lead", "release_lead", "hold_limit", "lead_values", "stage_of"]


def valve_worst_time(seq) -> float:
    """The latest the ERS valves may confirm closed after their command without a fault, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]``.

    Returns
    -------
    float
        ``ers_valve_time + ers_valve_timeout``.
    """
    return seq.ers_valve_time + seq.ers_valve_timeout


def esd_lead(seq) -> float:
    """Time the first alarm (ESD-1) must leave before any face, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]``.

    Returns
    -------
    float
        ``max(esd_time, ers_valve_time + ers_valve_timeout) + erc_release_time + margin``.
    """
    return max(seq.esd_time, valve_worst_time(seq)) + seq.erc_release_time + seq.margin


def release_lead(seq) -> float:
    """Time from ESD-1 to the coupler free at the latest, with the margin, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]``.

    Returns
    -------
    float
        ``ers_valve_time + ers_valve_timeout + erc_release_time + margin``.
    """
    return valve_worst_time(seq) + seq.erc_release_time + seq.margin


def hold_limit(seq) -> float:
    """The longest a trusted prediction may hold a call for ESD-1 of the rule without it, s: ESD-1's lead less the
    release's. That is how long a call forecasting the face ESD-1's whole lead away may stand and still leave the
    release its whole lead (the ERS valves at their timeout, the coupler and the margin) if it was right; a call
    forecasting the face sooner may stand only until its forecast leaves the release that lead (the controller
    keeps both, :meth:`loadarm.guidance.rules.SafetyRules._shadow`). What a hold may cost is the ESD-1
    shutdown's own time (the pumps and ESD valves, ``esd_time``). Where the valves' worst time is as long as that,
    nothing may be held (0).

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]``.

    Returns
    -------
    float
        ``esd_lead(seq) - release_lead(seq)`` (``max(esd_time, ers_valve_time + ers_valve_timeout) - ers_valve_time
        - ers_valve_timeout``), >= 0.
    """
    return esd_lead(seq) - release_lead(seq)


def lead_values(valves_left: float, release_left: float, margin: float, lead_esd1: float,
                pre_alarm_lead: float) -> tuple[float, float, float, float]:
    """The time each stage needs before a face, s, as the sequence stands.

    Parameters
    ----------
    valves_left : float
        Time until the ERS valves are confirmed closed at the latest, s (0 once confirmed).
    release_left : float
        Time until the coupler is free once it starts opening, s.
    margin : float
        The sequence's margin, s.
    lead_esd1 : float
        The whole sequence's lead (:func:`esd_lead`), s.
    pre_alarm_lead : float
        The pre-alarm's lead before ESD-1's, s (<= 0: no pre-alarm).

    Returns
    -------
    release, second, esd1, pre : float
        ``release = valves_left + release_left + margin``; ``second = release + margin``;
        ``esd1 = max(lead_esd1, second)``; ``pre = esd1 + pre_alarm_lead`` (``-inf`` without a pre-alarm).
    """
    release = max(valves_left, 0.0) + max(release_left, 0.0) + margin
    second = release + margin
    esd1 = max(lead_esd1, second)
    pre = esd1 + pre_alarm_lead if pre_alarm_lead > 0.0 else -math.inf
    return release, second, esd1, pre


def stage_of(ttl: float, ttl_measured: float, release: float, second: float, esd1: float, pre: float) -> int:
    """The alarm stage a time to the nearest face calls for (:class:`loadarm.vocab.Severity` as an int).

    Parameters
    ----------
    ttl : float
        Time to the nearest face by every route (the design drift included), s.
    ttl_measured : float
        By the measured routes alone, s: the pre-alarm warns of a drift the monitor sees, never of the design
        floor (``inf`` where there is no measured route, as in the operability kernel).
    release, second, esd1, pre : float
        From :func:`lead_values`.

    Returns
    -------
    int
        4 release, 3 second alarm, 2 ESD-1, 1 pre-alarm, 0 none.
    """
    if ttl <= release:
        return 4
    if ttl <= second:
        return 3
    if ttl <= esd1:
        return 2
    if ttl_measured <= pre:
        return 1
    return 0
