"""The mooring load monitoring's judgement (loadarm.guidance.moorings): the second witness of the predictive alarms."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.guidance.moorings import LOST_SHARE, SLACK_SHARE, SLACK_TIME, MooringWatch

from .hypo import examples


def _lost_at_by_count(times, loads):
    """Independent route: for each reading, walk back over the readings while each line stays low; the first
    reading where more than LOST_SHARE of the lines have been low for SLACK_TIME or longer."""
    loads = np.asarray(loads)
    for k, now in enumerate(times):
        slack = 0
        for j in range(loads.shape[1]):
            i = k
            while i >= 0 and loads[i, j] < SLACK_SHARE:
                i -= 1
            first_low = i + 1
            if first_low <= k and now - times[first_low] >= SLACK_TIME - 1e-9:
                slack += 1
        if slack > LOST_SHARE * loads.shape[1]:
            return now
    return None


@settings(max_examples=examples(150), deadline=None)
@given(lines=st.integers(1, 16), n=st.integers(1, 40), period=st.sampled_from([0.02, 0.2, 1.0]),
       repeat=st.integers(1, 12), as_tuple=st.booleans(), data=st.data())
def test_the_moorings_are_lost_when_more_than_half_the_lines_are_slack_long_enough(lines, n, period, repeat,
                                                                                   as_tuple, data):
    """Over any readings, held and read again between updates (``repeat`` cycles a reading, as the guidance
    cycle reads a 1 Hz monitoring; a tuple: the same object again, which the watch skips until a slack time is
    up), the watch finds the moorings lost exactly when an independent count does."""
    low = st.floats(0.0, SLACK_SHARE, exclude_max=True)
    high = st.floats(SLACK_SHARE, 1.5)
    drawn = data.draw(st.lists(st.lists(st.one_of(low, high), min_size=lines, max_size=lines), min_size=n,
                               max_size=n))
    drawn = [tuple(r) if as_tuple else r for r in drawn]
    rows = [r for r in drawn for _ in range(repeat)]
    times = [k * period / repeat for k in range(len(rows))]
    w = MooringWatch()
    found = [now for now, row in zip(times, rows) if w.update(now, row)]
    expected = _lost_at_by_count(times, rows)
    assert found == ([] if expected is None else [expected])
    assert w.lost_at == expected and w.holding == (expected is None) and w.reading


def test_a_break_out_is_found_two_seconds_after_the_lines_part_and_a_wave_s_slack_is_not():
    w = MooringWatch()
    taut = [0.05] * 16
    for k in range(100):                                   # 1 Hz readings, taut until 50 s
        now = float(k)
        if 50 <= k < 54:
            row = [0.0] * 4 + [0.05] * 12                  # four breast lines slack for 4 s: the waves
        elif k >= 60:
            row = [0.0] * 16                               # every line parted at 60 s
        else:
            row = taut
        w.update(now, row)
        if k < 62:
            assert w.holding, k
    assert w.lost_at == 62.0


def test_no_reading_is_no_witness_and_a_gap_keeps_the_state():
    from loadarm.vocab import MOORINGS_TEXT

    w = MooringWatch()
    assert not w.holding and not w.update(0.0, None) and w.state == "none"      # not linked: no witness
    w.update(1.0, [0.05, 0.05])
    assert w.holding and not w.update(2.0, None) and w.holding and w.state == "holding"
    w.update(3.0, [0.0, 0.0])
    assert w.update(5.0, [0.0, 0.0]) and w.state == "lost" and not w.holding
    assert set(MOORINGS_TEXT) == {"none", "holding", "lost"}


@pytest.mark.parametrize("row, words", [([0.1, -0.01], "finite share"), ([0.1, math.nan], "finite share"),
                                        ([], "finite share"), ([[0.1]], "finite share")])
def test_a_bad_reading_is_refused_in_one_line(row, words):
    with pytest.raises(ValueError, match=words):
        MooringWatch().update(0.0, row)


def test_a_reading_with_another_number_of_lines_is_refused():
    w = MooringWatch()
    w.update(0.0, [0.1, 0.1])
    with pytest.raises(ValueError, match="3 lines reported, 2 before"):
        w.update(1.0, [0.1, 0.1, 0.1])
