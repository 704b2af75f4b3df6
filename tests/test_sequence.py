"""The emergency sequence written once (loadarm.arm.sequence): the operability kernel's compiled scan and the live
monitor's leads, stepped as the controller steps them, reach the same stage at the same samples."""

import dataclasses
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.arm.sequence import esd_lead, lead_values, release_lead, stage_of, valve_worst_time
from loadarm.guidance.monitor import stage_leads
from loadarm.studies.kernel import _scan
from loadarm.vocab import Severity

from .hypo import examples


def _controller_way(seq, level, ttl, dt, close_at_release):
    """The controller's route, step by step: its leads (monitor.stage_leads with the valves counted at their
    worst from the command until they confirm ``ers_valve_time`` later), the stage of the time to the face
    (stage_of, no measured route), raised one way; returns (stage, i_esd1, i_release)."""
    raised, i_esd, i_cmd, i_rel = 0, -1, -1, -1
    for i in range(len(ttl)):
        t = i * dt
        if i_cmd < 0:
            left = None
        elif t >= i_cmd * dt + seq.ers_valve_time - 1e-9:
            left = 0.0
        else:
            left = i_cmd * dt + valve_worst_time(seq) - t
        ld = stage_leads(dataclasses.replace(seq, pre_alarm_lead=0.0), valves_left=left)
        stage = stage_of(ttl[i], math.inf, ld[Severity.RELEASE], ld[Severity.SECOND], ld[Severity.ESD1], -math.inf)
        raised = max(raised, int(level[i]), stage)
        if raised >= 2 and i_esd < 0:
            i_esd = i
        if i_cmd < 0 and ((raised >= 2 and not close_at_release) or raised >= 4):
            i_cmd = i
        if raised >= 4 and i_rel < 0 and i_cmd >= 0 and t >= i_cmd * dt + seq.ers_valve_time - 1e-9:
            i_rel = i
    return raised, i_esd, i_rel


@settings(max_examples=examples(150), deadline=None)
@given(start=st.floats(5.0, 120.0), speed=st.floats(0.05, 3.0), wobble=st.floats(0.0, 8.0),
       valve=st.floats(1.0, 20.0), timeout=st.floats(0.0, 10.0), release=st.floats(0.5, 6.0),
       margin=st.floats(0.0, 5.0), close_at_release=st.booleans(), seed=st.integers(0, 2**31 - 1))
def test_the_kernel_scans_the_sequence_as_the_controller_steps_it(model, start, speed, wobble, valve, timeout,
                                                                   release, margin, close_at_release, seed):
    """Over random times to the face (a closing drift with wave wobble) and sequence times: the same stage,
    the same ESD-1 sample and the same release sample, exactly (both call the same lead and stage functions;
    this holds the kernel's compiled scan to the controller's stepping of them)."""
    seq = dataclasses.replace(model.sequence, ers_valve_time=valve, ers_valve_timeout=timeout,
                              erc_release_time=release, margin=margin)
    dt = 0.5
    t = np.arange(0.0, 200.0, dt)
    rng = np.random.default_rng(seed)
    ttl = np.maximum(start - speed * t + wobble * np.sin(0.3 * t + rng.uniform(0, 6.3)), 0.0)
    level = np.zeros(t.size, dtype=np.int64)
    got = _scan(level, ttl, dt, seq.ers_valve_time, seq.erc_release_time, seq.margin, esd_lead(seq),
                valve_worst_time(seq), close_at_release)
    assert got[:3] == _controller_way(seq, level, ttl, dt, close_at_release)


def test_the_leads_are_the_sequence_times(model):
    """The leads against the sequence written out: the worst valve, the release and the margins."""
    q = model.sequence
    release, second, esd1, pre = lead_values(valve_worst_time(q), q.erc_release_time, q.margin, esd_lead(q), 30.0)
    assert release == q.ers_valve_time + q.ers_valve_timeout + q.erc_release_time + q.margin == release_lead(q)
    assert second == release + q.margin and esd1 == max(esd_lead(q), second) and pre == esd1 + 30.0
    assert lead_values(0.0, 0.0, 2.0, 35.0, 0.0)[3] == -math.inf
    assert [stage_of(x, math.inf, 20.0, 22.0, 35.0, 65.0) for x in (19.0, 21.0, 30.0, 50.0)] == [4, 3, 2, 0]
    assert stage_of(50.0, 60.0, 20.0, 22.0, 35.0, 65.0) == 1         # the pre-alarm: measured routes only
