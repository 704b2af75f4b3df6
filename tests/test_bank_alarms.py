"""The alarm design of a bank (``loadarm alarms --bank``): one mooring analysis, each arm on its own flange."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from loadarm.cli import main
from loadarm.design.alarm_design import (
    DesignSettings,
    design_from_analysis,
    flanging_corners,
    mooring_analysis,
    recommended_settings,
)
from loadarm.design.bank_alarms import SHARED, bank_ships, design_bank_alarms
from loadarm.errors import ConfigError
from loadarm.params.bank import load_bank
from loadarm.params.berth import load_berth
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import flange_kinematics

from .conftest import ROOT

BANK = ROOT / "examples" / "banks" / "lng150k_bank.toml"
BERTH = ROOT / "examples" / "berths" / "lng150k.toml"
#: One seed of ten minutes: what is tested is the sharing and the stacking, not the statistics.
TINY = DesignSettings(seeds=1, intact_duration=600.0, breakout_window=120.0)


@pytest.fixture(scope="module")
def setup():
    berth = load_berth(BERTH)
    return load_bank(BANK), berth, compile_ship(berth)


def test_each_arm_s_ship_carries_its_flange_where_the_bank_puts_it(setup):
    bank, _, ship = setup
    ships = bank_ships(bank, ship)
    z3, z6 = np.zeros((1, 3)), np.zeros((1, 6))
    centre = flange_kinematics(ship, ship.eq0[None], z3, z6, z6)[0][0]
    for i, s in enumerate(ships):
        at = flange_kinematics(s, ship.eq0[None], z3, z6, z6)[0][0]
        f = bank.flanges[i]
        # the bank's own route: its flanges in the arms' frames less the manifold's centre, riser by riser
        expect = bank.flange_position(i) + (bank.file.arms[i].x, bank.file.arms[i].y, 0.0) - \
            np.array(bank.file.manifold.position)
        assert at - centre == pytest.approx(expect, abs=1e-12) and expect[1] == pytest.approx(f.offset)
        # yawed by 1 deg about the ship's midships: each flange moves by its own lever (the same rigid body)
        pose = ship.eq0[None] + np.array([[0.0, 0.0, math.radians(1.0)]])
        moved = flange_kinematics(s, pose, z3, z6, z6)[0][0] - at
        centre_moved = flange_kinematics(ship, pose, z3, z6, z6)[0][0] - centre
        c, sn = math.cos(math.radians(1.0)), math.sin(math.radians(1.0))
        lever = np.array([-f.offset * sn, f.offset * c - f.offset, 0.0])
        assert moved == pytest.approx(centre_moved + lever, abs=1e-9)


def test_a_bank_turned_away_from_the_ship_is_refused_in_one_line(setup):
    bank, _, ship = setup
    file = bank.file.model_copy(update={"manifold": bank.file.manifold.model_copy(update={"heading_deg": -90.0})})
    with pytest.raises(ConfigError, match=r"manifold.heading_deg = -90: the berth's ship lies with its bow at 90 deg"):
        bank_ships(dataclasses.replace(bank, file=file), ship)


@pytest.mark.slow           # ~20 s: two mooring analyses of the tiny settings
def test_one_analysis_for_all_flanges_is_each_flange_s_own_analysis(setup):
    bank, berth, ship = setup
    res = design_bank_alarms(bank, ship, berth.environment, settings=TINY)
    i = 2                                        # V1: not the first ship, so its flange comes from the shared run
    s_i = bank_ships(bank, ship)[i]
    own = mooring_analysis((s_i,), berth.environment, TINY)[0]       # a simulation of its own
    flange = tuple(float(v) for v in bank.flange_position(i))
    corners, warnings = flanging_corners(bank.models[i], s_i, flange)
    alone = design_from_analysis(bank.models[i], own, TINY, flange, corners, warnings,
                                 judged=((SHARED, res.shared[res.files[i]]),))
    assert alone.to_dict() == res.designs[i].to_dict()
    # the shared settings: never inside any arm's allowance, the earliest that is not, the largest design drift
    shared = res.shared[res.files[0]]
    assert shared == {**recommended_settings([r for d in res.designs for r in d.rows]),
                      "design_drift_speed_ms": max(d.recommended["design_drift_speed_ms"] for d in res.designs),
                      "design_drift_acceleration_ms2": max(d.recommended["design_drift_acceleration_ms2"]
                                                           for d in res.designs)}
    floor = max(math.degrees(r.floor) for d in res.designs for r in d.rows if r.coordinate == "beta")
    assert shared["first_beta_deg"] >= math.floor(10 * floor) / 10
    assert shared["first_beta_deg"] <= max(d.recommended["first_beta_deg"] for d in res.designs)
    # every flange in front of its riser: every arm absorbs the design drift over its flanging area
    assert [r["ok"] for r in res.arm_rows()] == [True] * 4 and res.problems == () and res.ok
    # the verdict says what a negative margin means: the angles alone are short there, the floor holds
    for r in res.arm_rows():
        assert r["verdict"] == ("holds" if r["shared_margin_m"] >= 0 else "holds by the floor"), r
    assert res.to_dict()["arm_rows"] == res.arm_rows()
    assert "[alarms]\nfirst_deg = " in res.toml(res.files[0])
    assert res.summary()["arms"] == 4 and res.to_dict()["toml"]


def test_cli_takes_one_of_config_or_bank(capsys):
    assert main(["alarms", "--berth", str(BERTH)]) == 2
    assert capsys.readouterr().err.strip() == "loadarm: error: loadarm alarms takes one of --config FILE or --bank FILE"
    assert main(["alarms", "--berth", str(BERTH), "--bank", str(BANK), "--config",
                 str(ROOT / "examples" / "paper.toml")]) == 2
    assert "one of --config FILE or --bank FILE" in capsys.readouterr().err


@pytest.mark.slow           # ~10 s: the CLI's mooring analysis at one seed of three hours
def test_cli_gives_the_example_bank_s_settings_and_its_figure(capsys, tmp_path):
    """The example bank holds on every arm: exit 0, the settings to paste and the figure."""
    png = tmp_path / "bank-alarms.png"
    assert main(["alarms", "--berth", str(BERTH), "--bank", str(BANK), "--seeds", "1", "--png", str(png)]) == 0
    out = capsys.readouterr().out
    assert "design holds for every arm" in out and "Paste into" in out and "[alarms]\nfirst_deg = " in out
    for arm in ("L1", "L2", "V1", "L3"):
        assert f"\n {arm} " in out
    assert png.read_bytes().startswith(b"\x89PNG") and png.stat().st_size > 10_000


@pytest.mark.slow           # ~10 s: the CLI's mooring analysis at one seed of three hours
def test_cli_refuses_a_bank_whose_outer_flanges_lie_inboard_of_their_risers_naming_the_arms(capsys, tmp_path):
    """Found by this command on the first example bank: its flanges 3.0 m apart under risers 3.5 m apart, each outer
    flange 0.75 m inboard of its riser, and with the berth's 1.5 m manifold tolerance the far top corner of their
    flanging area cannot absorb the design drift. Refused, in one line naming the outer arms and not the inner."""
    text = BANK.read_text().replace('"../full.toml"', f'"{(BANK.parent.parent / "full.toml").resolve()}"')
    offsets = iter((-4.5, -1.5, 1.5, 4.5))
    text, n = re.subn(r"(?m)^offset = \S+", lambda _: f"offset = {next(offsets)}", text)
    assert n == 4
    narrow = tmp_path / "narrow_manifold.toml"
    narrow.write_text(text)
    assert main(["alarms", "--berth", str(BERTH), "--bank", str(narrow), "--seeds", "1"]) == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith(f"loadarm: error: {narrow}: refused: arm L1: ") and "arm L3:" in last
    assert "arm L2" not in last and "arm V1" not in last


@pytest.mark.slow           # 3-5 s: a 120 s simulation of the moored ship (make test's budget; CI runs it)
def test_the_ship_s_own_point_and_the_bank_s_turned_offset_agree_in_a_seaway(setup):
    """Two routes to a flange on the moving ship: the moored ship's kinematics at the moved manifold (the alarm
    design's) and the manifold's centre plus the flange's offset turned by roll, pitch and yaw (the bank monitor's,
    the campaign's, the bank operability's). The ship's first-order motion is linear in its rotations (r x theta),
    the bank's a full rotation: they differ by about theta^2 |offset|; and the bank turns the offset by the whole
    yaw while the ship's point is taken from its mean pose, whose static yaw (0.007 deg here) moves a flange by
    its offset times that angle (0.5 mm at 4.5 m): the bound is the sum of the two."""
    from loadarm.guidance.bank import BankMonitor
    from loadarm.ship.motion import simulate

    bank, berth, ship = setup
    m = simulate(ship, berth.environment, 120.0, seed=3)
    ships = bank_ships(bank, ship)
    monitor = BankMonitor(bank)
    centre = np.asarray(bank.file.manifold.position) + (m.flange - m.flange_reference)
    risers = np.array([[a.x, a.y, 0.0] for a in bank.file.arms])
    by_bank = monitor.flanges(centre, m.flange_angles) + risers       # bank frame
    for i, s in enumerate(ships):
        ref = flange_kinematics(s, m.mean_pose[None], np.zeros((1, 3)), np.zeros((1, 6)), np.zeros((1, 6)))[0][0]
        p, _, _ = flange_kinematics(s, m.pose, m.pose_velocity, m.wave, m.wave_velocity)
        by_ship = bank.flange_position(i) + (bank.file.arms[i].x, bank.file.arms[i].y, 0.0) + (p - ref)
        theta = float(np.max(np.abs(m.flange_angles)))
        lever = abs(bank.flanges[i].offset) + abs(bank.flanges[i].height)
        bound = lever * (theta ** 2 + abs(float(m.mean_pose[2]))) + 1e-6
        assert np.max(np.abs(by_ship - by_bank[:, i])) < bound, (i, theta)
