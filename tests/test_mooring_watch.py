"""The mooring load monitoring's judgement (loadarm.guidance.moorings): the second witness of the predictive alarms."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.guidance.moorings import LOST_SHARE, SLACK_SHARE, SLACK_TIME, STALE_TIME, MooringWatch

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


@settings(max_examples=examples(80), deadline=None)
@given(lines=st.integers(1, 16), n=st.integers(1, 40), period=st.sampled_from([0.02, 0.2, 1.0]),
       repeat=st.integers(1, 12), as_tuple=st.booleans(), data=st.data())
def test_the_moorings_are_lost_when_more_than_the_share_of_lines_are_slack_long_enough(lines, n, period, repeat,
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
    assert w.lost_at == expected and w.holding(times[-1]) == (expected is None and w.fresh(times[-1]))
    assert w.state(times[-1]) in ({"lost"} if expected is not None else {"holding", "silent"})


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
        w.update(now, [v + 1e-4 * (k % 3) for v in row] if k < 60 else row)     # live cells are never still
        if k < 62:
            assert w.holding(now), k
    assert w.lost_at == 62.0 and w.state(99.0) == "lost"


@pytest.mark.parametrize("parted, lost", [(5, False), (6, True), (8, True)])
def test_six_of_sixteen_lines_slack_are_lost_and_five_are_not(parted, lost):
    """The share is a third (from 2026-12-06; a half before): on the shipped berth's 16 lines, 6 slack for 2 s are
    the moorings lost, 5 are not; half the lines parting (8: the partial break-out) is seen."""
    assert LOST_SHARE == pytest.approx(1 / 3)
    w = MooringWatch()
    for k in range(10):
        row = [0.0] * parted + [0.05 + 1e-4 * k] * (16 - parted) if k >= 3 else [0.05 + 1e-4 * k] * 16
        w.update(float(k), row)
    assert (w.lost_at == 5.0) if lost else (w.lost_at is None and w.holding(9.0))


def test_no_reading_is_no_witness_and_a_stale_or_frozen_feed_is_silent():
    from loadarm.vocab import MOORINGS_TEXT

    w = MooringWatch()
    assert not w.holding(0.0) and not w.update(0.0, None) and w.state(0.0) == "none"    # not linked: no witness
    w.update(1.0, (0.05, 0.06))
    assert w.holding(1.0) and not w.update(2.0, None) and w.holding(2.0) and w.state(2.0) == "holding"
    assert w.holding(1.0 + STALE_TIME) and not w.holding(1.1 + STALE_TIME)          # no reading for 3 s: silent
    assert w.state(5.0) == "silent"
    for k in range(2, 8):                                     # the same values again and again: a frozen feed
        w.update(float(k), (0.05, 0.06))
    assert w.state(7.0) == "silent" and not w.holding(7.0)
    w.update(8.0, (0.05, 0.07))                               # moving again: a witness again
    assert w.holding(8.0)
    w.update(9.0, (0.0, 0.0))
    assert w.update(11.0, [0.0, 0.0]) and w.state(11.0) == "lost" and not w.holding(11.0)
    assert set(MOORINGS_TEXT) == {"none", "holding", "silent", "lost"}


@pytest.mark.parametrize("row", [[0.1, math.nan], [0.1, math.inf], [[0.1]], ["a", 0.1], [object(), 1]])
def test_a_reading_it_cannot_use_makes_it_silent_and_never_raises(row):
    """Found by review: a bad reading raised in the guidance cycle, which stopped the controller; now the watch
    goes silent (no witness: nothing is held) and says why."""
    w = MooringWatch()
    w.update(0.0, (0.05, 0.06))
    assert not w.update(1.0, row) and w.fault and w.state(1.0) == "silent" and not w.holding(1.0)
    w.update(2.0, (0.05, 0.07))
    assert w.holding(2.0) and not w.fault


def test_a_zero_drifted_below_nought_reads_slack_and_another_number_of_lines_starts_again():
    w = MooringWatch()
    for k in range(3):
        w.update(float(k), (-0.002, -0.001, 0.05 + 0.01 * k))
    assert w.lost_at == 2.0                                   # 2 of 3 below 1 % for 2 s
    v = MooringWatch()
    v.update(0.0, (0.0, 0.0))
    v.update(1.0, (0.0, 0.0, 0.05))                           # another ship's lines: timers start again
    assert not v.update(2.0, (0.0, 0.0, 0.06)) and v.update(3.0, (0.0, 0.0, 0.07))


@pytest.mark.slow
def test_the_judgement_s_basis_on_the_ship_records():
    """docs/guidance.md section 13's basis, on samples of the stored campaigns' seeds (the ship's records alone, no
    arm): at Hs 1.5-2.0 m (the runs file's first 20 seeds, their drawn Hs) the watch never finds the moorings lost
    and at most 4 of the 16 lines are slack at once; in the break-out (seeds 100-104), read once a second, the
    moorings are lost at the 402 s reading, 2 s after the lines part at 400 s."""
    import json
    from pathlib import Path

    from loadarm.params.scenario import load_scenario
    from loadarm.ship.flange import flange_motion
    from loadarm.ship.model import moored_ship

    root = Path(__file__).resolve().parents[1]
    rows = [json.loads(line) for line in (root / "docs/campaigns/hs15_tracked_hs1.5-2.0_runs.jsonl").open()][1:21]
    sc0, _ = load_scenario(root / "examples/scenarios/hs15_tracked.toml")
    ship = moored_ship(sc0)
    for r in rows:
        run = r["run"]
        sc = sc0.model_copy(update={"scenario": sc0.scenario.model_copy(update={"seed": run["seed"]}),
                                     "environment": sc0.environment.model_copy(
                                         update={"hs": run["draws"]["environment.hs"]})})
        fm, w, most = flange_motion(sc, ship), MooringWatch(), 0
        for t in np.arange(0.0, sc.scenario.duration, 0.2):
            w.update(float(t), fm.line_loads(float(t)))
            most = max(most, int(np.count_nonzero(w.low_since <= t - SLACK_TIME + 1e-9)))
        assert w.lost_at is None and most <= 4, (run["seed"], most)
    sc0, _ = load_scenario(root / "examples/scenarios/breakout_tracked.toml")
    for seed in range(100, 105):
        sc = sc0.model_copy(update={"scenario": sc0.scenario.model_copy(update={"seed": seed})})
        fm, w = flange_motion(sc, ship), MooringWatch()
        for t in np.arange(380.0, 420.0, 0.2):
            w.update(float(t), fm.line_loads(float(t)))
        assert w.lost_at is not None and abs(w.lost_at - 402.0) <= 0.2 + 1e-9, (seed, w.lost_at)


def test_the_simulated_plant_s_reading_is_the_record_s_at_every_cycle():
    """Found in review: the simulated plant cached the reading on its own rounding of the run time while the
    ship's record rounded the record's time (the run's plus ``[ship] history``): with a history that is not a
    whole number of reading periods the plant served a reading up to a period late. Now one rounding
    (``MooredFlangeMotion.reading``): at every 0.2 s cycle the cached reading is the record's."""
    from types import SimpleNamespace

    from loadarm.ship.flange import MooredFlangeMotion
    from loadarm.sim.loop import LINE_LOAD_PERIOD, SimulatedPlant

    t = np.arange(0.0, 40.0, 0.1)
    record = SimpleNamespace(t=t, tension=np.column_stack([t, 2 * t]), mbl=np.array([100.0, 100.0]))
    for start in (0.0, 2.5, 7.3):
        fm = MooredFlangeMotion(record, np.zeros(3), np.zeros(3), start)
        plant = SimpleNamespace(_mlms=True, _loads=(math.nan, None), motion=fm)
        for now in np.arange(0.0, 30.0, 0.2):
            got = SimulatedPlant.line_loads(plant, float(now))
            assert got == fm.line_loads(float(now), LINE_LOAD_PERIOD), (start, now)
            read_at = math.floor(now + start + 1e-9)                   # the last whole second of the record
            assert got[0] == pytest.approx(read_at / 100.0, abs=1e-12), (start, now)


@pytest.mark.slow
def test_at_hs_2_5_m_some_ships_lose_more_than_a_third_of_their_lines_tension():
    """docs/guidance.md section 13's Hs 2.0-2.5 m note, held: at Hs 2.5 m (the hs15 scenario, seeds 100-129) the
    ship's records alone lose more than a third of their lines' tension (brakes rendered, lines slack) in 16 of
    30 seeds, which stands the prediction down: its false ESD-1 there can only rise. (With the share at a half,
    until 2026-12-06: 5 of 30, seeds 101, 104, 105, 110 and 128, all of them among these.)"""
    from pathlib import Path

    from loadarm.params.scenario import load_scenario
    from loadarm.ship.flange import flange_motion
    from loadarm.ship.model import moored_ship

    sc0, _ = load_scenario(Path(__file__).resolve().parents[1] / "examples/scenarios/hs15_tracked.toml")
    ship, lost = moored_ship(sc0), []
    for seed in range(100, 130):
        sc = sc0.model_copy(update={"scenario": sc0.scenario.model_copy(update={"seed": seed}),
                                     "environment": sc0.environment.model_copy(update={"hs": 2.5})})
        fm, w = flange_motion(sc, ship), MooringWatch()
        for t in np.arange(0.0, sc.scenario.duration, 0.2):
            w.update(float(t), fm.line_loads(float(t)))
        if w.lost_at is not None:
            lost.append(seed)
    assert lost == [101, 103, 104, 105, 107, 109, 110, 111, 114, 121, 122, 123, 124, 125, 126, 128]


def test_the_basis_watch_is_the_guidance_s_watch_over_the_readings():
    """``studies.watch_basis.watch_over_record`` runs the shipped watch over a motion's readings: the most lines
    slack at once (each for SLACK_TIME) and the lost time, against the independent count above."""
    from types import SimpleNamespace

    from loadarm.studies.watch_basis import watch_over_record

    rng = np.random.default_rng(7)
    for _ in range(20):
        table = np.where(rng.random((40, 16)) < rng.uniform(0.05, 0.6), 0.0, 0.05)      # one reading a second
        motion = SimpleNamespace(line_loads=lambda t, period=1.0: tuple(table[int(math.floor(t + 1e-9))]))
        most, lost = watch_over_record(motion, 0.0, 39.8)               # both ends included
        times = np.arange(0.0, 39.9, 0.2)
        assert lost == pytest.approx(_lost_at_by_count(times, [table[int(math.floor(t + 1e-9))] for t in times]))
        assert (lost is not None) == (most > LOST_SHARE * 16)


def test_the_basis_refuses_what_is_not_a_single_arm_s_runs_file_in_one_line(tmp_path):
    """Found by review: a header that was not an object raised AttributeError, one without a scenario KeyError,
    and a runs file of other inputs (a changed berth) gave a silently wrong basis. Each is now one line naming the
    file, the line and what is wrong; the file is never changed."""
    import json
    import shutil
    from pathlib import Path

    from loadarm.errors import ConfigError
    from loadarm.studies.watch_basis import _read_runs, main, watch_basis

    root = Path(__file__).resolve().parents[1]
    scen = root / "examples" / "scenarios"
    good = (root / "docs" / "campaigns" / "partial_breakout_tracked_third_runs.jsonl").read_text().splitlines()
    head = json.loads(good[0])
    bad = tmp_path / "x_runs.jsonl"
    cases = {"": "line 1: not the header", "[]\n": "line 1: not the header", "1\n": "line 1: not the header",
             '{"generator": "loadarm", "kind": "campaign runs"}\n': "line 1: scenario = None",
             json.dumps({**head, "bank": "b.toml"}) + "\n": "line 1: scenario = .*bank = 'b.toml'",
             json.dumps({**head, "scenario": "nope.toml"}) + "\n": "line 1: scenario = 'nope.toml': no such file",
             json.dumps({**head, "inputs_sha256": "0" * 64}) + "\n": "line 1: inputs_sha256 = 0000000000000000.*: "
                                                                     "run on other inputs",
             good[0] + "\nnot json\n" + good[1] + "\n": "line 2: not a run",
             good[0] + '\n{"run": {"seed": 1.5, "draws": {}}}\n': "line 2: seed = 1.5",
             good[0] + '\n{"run": {"seed": 1, "draws": {"ship.history": 9}}}\n': "line 2: draws key 'ship.history'"}
    for text, why in cases.items():
        bad.write_text(text)
        with pytest.raises(ConfigError, match=f"^{bad}: {why}"):
            watch_basis(bad, scen)
        assert bad.read_text() == text                         # never changed
    bad.write_text(good[0] + "\n" + good[1] + "\n" + good[2][:30])     # a torn last line: skipped, as the campaign
    assert [s for s, _ in _read_runs(bad, scen)[1]] == [json.loads(good[1])["run"]["seed"]]
    assert main([str(tmp_path / "none.jsonl"), "--out", str(tmp_path / "o.json")]) == 2
    assert not (tmp_path / "o.json").exists()
    theirs = tmp_path / "theirs.json"                         # a file loadarm did not write: never changed
    theirs.write_text('{"mine": 1}\n')
    shutil.copy(root / "docs" / "campaigns" / "partial_breakout_tracked_third_runs.jsonl", tmp_path / "p_runs.jsonl")
    assert main([str(tmp_path / "p_runs.jsonl"), "--out", str(theirs)]) == 2 and theirs.read_text() == '{"mine": 1}\n'


@pytest.mark.slow  # 10-20 s: 12 runs of the ship's records
def test_the_stored_basis_is_the_ship_records_and_the_reruns_are_its_lost_runs(tmp_path):
    """docs/campaigns/mooring_watch_basis.json (the watch over every stored run of the hs bands and the
    break-out, from the ship's records alone) is what ``watch_basis`` gives today for the first runs of each file;
    the Hs 2.0-2.5 m runs file of the watch's new share keeps from the file before it exactly the runs where the
    watch never fires (the same decisions: the prediction never stood down for the moorings) and ran the others
    again; and below Hs 2.0 m the watch fired in no stored run (their results stand)."""
    import json
    from pathlib import Path

    from loadarm.studies.watch_basis import watch_basis

    root = Path(__file__).resolve().parents[1]
    camp = root / "docs" / "campaigns"
    basis = json.loads((camp / "mooring_watch_basis.json").read_text())
    assert basis["lost_share"] == pytest.approx(LOST_SHARE) and basis["slack_time_s"] == SLACK_TIME
    files = basis["files"]
    for name, rec in files.items():                  # a runs file still growing: the basis covers its first runs
        lines = (camp / name).read_text().splitlines()
        assert 0 < rec["runs"] <= len(lines) - 1
        assert [r[0] for r in rec["per_run"]] == sorted(json.loads(x)["run"]["seed"] for x in lines[1:rec["runs"] + 1])
        cut = tmp_path / name
        cut.write_text("\n".join(lines[:3]) + "\n")
        again = watch_basis(cut, root / "examples" / "scenarios").to_dict()["per_run"]
        stored = {r[0]: r for r in rec["per_run"]}
        assert again == [stored[r[0]] for r in again] and len(again) == 2, name
    for band in ("0.5-1.0", "1.0-1.5", "1.5-2.0"):
        assert files[f"hs15_tracked_hs{band}_runs.jsonl"]["lost_runs"] == 0
    lost = set(files["hs15_tracked_hs2.0-2.5_runs.jsonl"]["lost_seeds"])
    before = [json.loads(x) for x in (camp / "hs15_tracked_hs2.0-2.5_runs.jsonl").read_text().splitlines()[1:]]
    now = [json.loads(x) for x in (camp / "hs15_tracked_hs2.0-2.5_third_runs.jsonl").read_text().splitlines()[1:]]
    old_codes = {r["code"] for r in before}
    kept = {r["run"]["seed"] for r in now if r["code"] in old_codes}
    assert kept == {r["run"]["seed"] for r in before} - lost and len(now) == len(before) and len(lost) == 167
    assert all(r in before for r in now if r["code"] in old_codes)              # kept as they were, byte for byte
    for name in ("partial_breakout_tracked_third_runs.jsonl", "partial_breakout_squall_tracked_third_runs.jsonl",
                 "breakout_tracked_moorings_runs.jsonl"):          # lines parting at 400 s: lost at the 402 s reading
        assert {r[2] for r in files[name]["per_run"]} == {402.0}, name


@pytest.mark.slow  # 60-120 s: two tracked runs of 600 s (make test's budget; CI runs it)
@pytest.mark.parametrize("seed", [161, 100])
def test_the_basis_lost_time_is_the_controller_s(seed):
    """Found by review: nothing held the basis (the watch over the ship's records alone) to the controller's own
    watch in a run. Hs 2.0-2.5 m seed 161 (the basis: lost at 15.0 s) and seed 100 (never): the run's
    ``info.moorings_lost`` comes at the basis's time, or not at all."""
    import json
    from pathlib import Path

    from loadarm.sim.loop import run_scenario
    from loadarm.studies.campaign import ScenarioDraws

    root = Path(__file__).resolve().parents[1]
    camp = root / "docs" / "campaigns"
    basis = {r[0]: r[2] for r in json.loads((camp / "mooring_watch_basis.json").read_text())["files"][
        "hs15_tracked_hs2.0-2.5_runs.jsonl"]["per_run"]}
    draws = next(json.loads(x)["run"]["draws"] for x in (camp / "hs15_tracked_hs2.0-2.5_runs.jsonl").open()
                 if f'"seed":{seed},' in x.replace(" ", ""))
    sc, model = ScenarioDraws(str(root / "examples" / "scenarios" / "hs15_tracked.toml")).build(seed, draws)
    res = run_scenario(sc, model, plant="kinematic")
    lost = res.first_code("info.moorings_lost")
    assert (lost is None) if basis[seed] is None else lost == pytest.approx(basis[seed], abs=1e-6)
    assert (basis[seed] is None) == (seed == 100)
