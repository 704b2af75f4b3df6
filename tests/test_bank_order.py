"""The order of the bank's approaches (issue 31, item 3): which arm moves first, which waits and for whom; the
order never makes a clash, and an input no order can serve is refused in one line."""

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.cli import main
from loadarm.design.bank import _waves, check_bank_approaches, order_bank_approaches
from loadarm.errors import PathError
from loadarm.params.bank import load_bank

from .hypo import examples

BANKS = Path(__file__).resolve().parents[1] / "src" / "loadarm" / "examples" / "banks"
EXAMPLE = BANKS / "lng150k_bank.toml"
FULL = (BANKS.parent / "full.toml").resolve()


@pytest.fixture(scope="module")
def staggered(tmp_path_factory):
    """The example bank with the vapour arm's riser 5 m nearer the ship and 0.5 m along the jetty, 0.95 m
    required: its stowed arm stands in L2's straight approach, and the two approaching together come 0.936 m
    apart."""
    text = EXAMPLE.read_text().replace('"../full.toml"', f'"{FULL}"')
    text = text.replace("y = 1.75    # m", "y = 0.5\nx = 5.0").replace("min_clearance = 0.5", "min_clearance = 0.95")
    path = tmp_path_factory.mktemp("staggered") / "staggered.toml"
    path.write_text(text)
    return path


def test_the_example_bank_moves_all_at_once():
    """The example's approaches keep 1.8 m all at once: one wave, nobody waits; the schedule is the all-at-once
    check's."""
    bank = load_bank(EXAMPLE)
    order = order_bank_approaches(bank)
    assert order.waves == (("L1", "L2", "V1", "L3"),) and order.waits_for == ()
    assert order.clearance.clear and order.clearance.min_clearance == pytest.approx(1.8, abs=1e-6)
    d = order.to_dict()
    assert d["moves_first"] == "L1, L2, V1, L3" and d["waits"] is None
    assert order.plot() is not None


def test_an_arm_whose_approach_clashes_with_a_stowed_neighbour_waits_for_it(staggered):
    """All at once, L2 comes 0.936 m from V1 (required 0.95 m); L2's approach past V1 stowed clashes too: V1
    moves first and L2 waits for it; the ordered schedule keeps the clearance all along."""
    bank = load_bank(staggered)
    assert not check_bank_approaches(bank).clear
    order = order_bank_approaches(bank)
    assert order.wave_of("V1") < order.wave_of("L2") and dict(order.waits_for) == {"L2": ("V1",)}
    assert order.clearance.clear and order.clearance.min_clearance >= 0.95
    assert order.start_s[bank.names.index("L2")] >= order.end_s[bank.names.index("V1")] - 1e-9


@pytest.mark.slow
def test_check_bank_shows_the_order(staggered, capsys):
    """``loadarm check --bank`` prints who moves first and who waits, and gives them in its JSON."""
    assert main(["check", "--bank", str(staggered)]) == 0
    out = capsys.readouterr().out
    assert "L2 waits for V1" in out and "L1 + V1 + L3 -> L2" in out
    assert main(["check", "--bank", str(staggered), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["approach_order"]["waits_for"] == {"L2": ["V1"]}


def _valid(waves, ok) -> bool:
    """Every pair's clearance holds in the schedule ``waves`` (lists of arm indices)."""
    alone, connected, together = ok
    wave = {i: w for w, members in enumerate(waves) for i in members}
    for i, j in itertools.permutations(wave, 2):
        if wave[i] < wave[j] and not (alone[i, j] and connected[j, i]):
            return False
        if wave[i] == wave[j] and not together[i, j]:
            return False
    return True


@settings(max_examples=examples(300), deadline=None)
@given(n=st.integers(2, 5), data=st.data())
def test_the_order_never_makes_a_clash_and_is_refused_only_when_none_exists(n, data):
    """Any pairwise clearances (each ordered pair: clear past the other stowed, past it connected, approaching
    together): the waves found keep every pair clear; a refusal comes only when no one-at-a-time order exists
    (checked against every permutation), in one line."""
    draw = st.lists(st.booleans(), min_size=n * n, max_size=n * n)
    ok = tuple(np.array(data.draw(draw)).reshape(n, n) for _ in range(3))
    together = ok[2] & ok[2].T
    ok = (ok[0], ok[1], together)
    names = tuple(f"A{i}" for i in range(n))
    alone, connected, _ = ok

    def sequential(order):
        return all(alone[i, j] and connected[j, i] for a, i in enumerate(order) for j in order[a + 1:])

    try:
        waves, waits = _waves(names, ok)
    except PathError as exc:
        assert "\n" not in str(exc) and "no order of the approaches" in str(exc)
        assert not any(sequential(p) for p in itertools.permutations(range(n)))
        return
    assert sorted(i for w in waves for i in w) == list(range(n)) and _valid(waves, ok)
    for k, ms in waits.items():
        assert all(not (alone[k, m] and together[k, m]) for m in ms)


def test_a_bank_no_order_can_serve_is_refused_in_one_line():
    """Two arms each clashing with the other both stowed and connected: refused, one line."""
    no = np.array([[True, False], [False, True]])
    with pytest.raises(PathError, match="no order of the approaches of A, B keeps the bank's clearance") as exc:
        _waves(("A", "B"), (no, no, no))
    assert "\n" not in str(exc.value)
