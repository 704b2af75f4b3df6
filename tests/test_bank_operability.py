"""`loadarm operability --bank`: the downtime of a bank is any arm's (issue 31, item 6).

Slow ones compile the berth's ship and each arm's design-drift table (3-6 s each); the fast ones hold the CLI's
refusals, the result's arithmetic and the run's manifest.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from loadarm.cli import main
from loadarm.errors import ConfigError
from loadarm.params.bank import load_bank
from loadarm.studies.bank_operability import (
    BankOperabilityResult,
    _criteria,
    _governing,
    bank_columns,
    bank_states,
    bank_tables,
)
from loadarm.studies.operability import (
    COLUMNS,
    CRITERIA,
    OperabilitySettings,
    _manifest,
    monitor_table,
    run_states,
)

from .conftest import ROOT

BANK = ROOT / "examples" / "banks" / "lng150k_bank.toml"
BERTH = ROOT / "examples" / "berths" / "lng150k.toml"
SAMPLE = ROOT / "examples" / "metocean" / "sample.csv"


def _run(capsys, *args):
    code = main([str(a) for a in args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _one_line(code, err):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("loadarm: error: "), (code, err)
    return lines[0]


# ----------------------------------------------------------------------------------------------------- fast


def test_operability_takes_config_or_bank_not_both_in_one_line(capsys, tmp_path):
    common = ["operability", "--berth", BERTH, "--metocean", SAMPLE, "--hours", "3", "--out", tmp_path / "o.parquet"]
    line = _one_line(*_run(capsys, *common, "--config", ROOT / "examples" / "full.toml", "--bank", BANK)[::2])
    assert "--config" in line and "--bank" in line and "not both" in line
    line = _one_line(*_run(capsys, *common)[::2])
    assert "--config" in line and "--bank" in line
    line = _one_line(*_run(capsys, *common, "--bank", tmp_path / "none.toml")[::2])
    assert "none.toml" in line and "not found" in line
    assert not (tmp_path / "o.parquet").exists()


def test_arms_with_different_operability_criteria_are_refused_naming_file_key_and_values(tmp_path):
    text = (ROOT / "examples" / "full.toml").read_text()
    assert text.count("\nwind_limit = 20.0 ") == 1
    (tmp_path / "a.toml").write_text(text)
    (tmp_path / "b.toml").write_text(text.replace("\nwind_limit = 20.0 ", "\nwind_limit = 18.0 "))
    bank = BANK.read_text().replace('"../full.toml"', '"a.toml"')
    bank = bank.replace('installation = "a.toml"\ny = 5.25', 'installation = "b.toml"\ny = 5.25')
    (tmp_path / "bank.toml").write_text(bank)
    b = load_bank(tmp_path / "bank.toml")
    with pytest.raises(ConfigError) as e:
        _criteria(b, str(tmp_path / "bank.toml"))
    msg = str(e.value)
    assert "\n" not in msg and "bank.toml" in msg and "operability.wind_limit = 18.0" in msg and "b.toml" in msg


def test_the_manifest_holds_the_bank_and_every_installation(tmp_path):
    files = {n: tmp_path / n for n in ("bank.toml", "berth.toml", "met.csv", "a.toml", "b.toml")}
    for p in files.values():
        p.write_text(p.name)
    st = OperabilitySettings()

    def digest():
        return _manifest(files["bank.toml"], files["berth.toml"], files["met.csv"], None, st, [(0, 1)],
                         extra=(files["a.toml"], files["b.toml"]))

    base = digest()
    for name in ("bank.toml", "b.toml"):
        files[name].write_text("changed")
        assert digest() != base, name
        base = digest()


def _table(stages: dict, ship_down: list[bool]) -> pd.DataFrame:
    """Rows of a made-up bank: each arm's stage per hour, the ship's criteria down where ``ship_down``."""
    names = tuple(stages)
    n = len(ship_down)
    rows = []
    for k in range(n):
        arms = [{"stage": stages[a][k], "esd1_s": 10.0 * (j + 1) if stages[a][k] >= 2 else math.nan,
                 "flange_motion_m": 0.5, "connectable": True, "down_arm": stages[a][k] >= 2}
                for j, a in enumerate(names)]
        row = {c: 0.0 for c in COLUMNS}
        row.update(time=np.datetime64("2025-01-01T00") + np.timedelta64(k, "h"), connectable=True, outside=False,
                   stage=max(a["stage"] for a in arms), release_s=math.nan)
        row.update({f"down_{c}": False for c in CRITERIA})
        row["down_lines"] = ship_down[k]
        row["down_arm"] = any(a["down_arm"] for a in arms)
        row["down"] = row["down_lines"] or row["down_arm"]
        row["arm_governing"] = _governing(names, arms)
        row.update(manifold_utilisation=math.nan, manifold_governing="", manifold_at_s=math.nan, down_manifold=False)
        row.update({f"{c}_{a}": arm[c] for a, arm in zip(names, arms) for c in ("stage", "esd1_s", "flange_motion_m",
                                                                               "connectable", "down_arm")})
        row.update({f"manifold_utilisation_{a}": math.nan for a in names})
        rows.append(row)
    return pd.DataFrame(rows, columns=list(bank_columns(names)))


def test_downtime_by_arm_and_the_governing_arm_from_the_rows():
    df = _table({"A": [0, 2, 2, 0, 0], "B": [0, 2, 0, 3, 0]}, [False, False, False, False, True])
    # both down at hour 1: the same stage, A's ESD-1 first (10 s against 20 s); B alone at 3 (ERS-1)
    assert df["arm_governing"].tolist() == ["", "A", "A", "B", ""]
    res = BankOperabilityResult(df, names=("A", "B"))
    d = res.to_dict()
    assert d["downtime_by_arm_h"] == {"A": 3, "B": 3}            # the ship's hour 4 counts for each arm alone
    assert d["governing_h"] == {"A": 2, "B": 1} and d["governing_arm"] == "A"
    assert d["states"] == 5 and d["downtime_fraction"] == pytest.approx(4 / 5)
    rows = dict(res.headline())
    assert rows["downtime by arm (that arm alone, the ship's criteria too)"] == "A 3 h (60.0 %), B 3 h (60.0 %)"
    assert rows["governing arm (hours it took the arm criterion down)"] == "A: A 2 h, B 1 h"
    labels = [label for label, _ in res.headline()]
    assert labels.index("downtime by arm (that arm alone, the ship's criteria too)") == \
        labels.index("  the arm (connect, ESD-1)") + 1
    assert BankOperabilityResult(_table({"A": [0], "B": [0]}, [False]), names=("A", "B")).to_dict()[
        "governing_arm"] == "none"


def test_manifold_loads_in_the_rows_take_the_bank_down_and_are_reported():
    """The manifold's criterion from the rows: B's flange loaded past its allowable at hour 2 (1.3) takes that hour
    down and counts for B alone; the result names the largest load, which and when, each arm's largest; the
    headline gains the criterion's row (after the arm's) and the largest load's. Not judged: None, no rows."""
    df = _table({"A": [0, 0, 0, 0], "B": [0, 0, 0, 0]}, [False] * 4)
    assert BankOperabilityResult(df, names=("A", "B")).to_dict()["manifold_loads"] is None
    labels = [label for label, _ in BankOperabilityResult(df, names=("A", "B")).headline()]
    assert not any("manifold" in label for label in labels)
    util = {"A": [0.2, 0.3, 0.4, 0.2], "B": [0.5, 0.9, 1.3, 0.6]}
    for a, u in util.items():
        df[f"manifold_utilisation_{a}"] = u
    df["manifold_utilisation"] = np.maximum(util["A"], util["B"])
    df["manifold_governing"] = "B axial force"
    df["manifold_at_s"] = [1.0, 2.0, 431.1, 4.0]
    df["down_manifold"] = df["manifold_utilisation"] > 1.0
    df["down"] = df["down"] | df["down_manifold"]
    res = BankOperabilityResult(df, names=("A", "B"))
    d = res.to_dict()
    m = d["manifold_loads"]
    assert m["hours_over"] == 1 and m["downtime_fraction"] == 0.25 and m["max_utilisation"] == 1.3
    assert m["governing"] == "B axial force" and m["at"] == "2025-01-01T02:00:00 + 431.1 s"
    assert m["max_utilisation_by_arm"] == {"A": 0.4, "B": 1.3} and m["hours_out_of_reach"] == 0
    assert d["downtime_by_arm_h"] == {"A": 0, "B": 1} and d["downtime_fraction"] == 0.25
    assert d["down_manifold_fraction"] == 0.25 and d["governing_by_month"] == {"2025-01": "manifold"}
    rows = dict(res.headline())
    assert rows["  manifold loads above their allowable (any arm)"] == "25.0 %"
    assert rows["largest manifold load / allowable"] == "1.30 (B axial force, 2025-01-01T02:00:00 + 431.1 s)"
    assert rows["largest manifold load / allowable, by arm"] == "A 0.40, B 1.30"
    labels = [label for label, _ in res.headline()]
    assert labels.index("  manifold loads above their allowable (any arm)") == \
        labels.index("  the arm (connect, ESD-1)") + 1


def test_manifold_loads_need_a_bank_in_one_line(capsys, tmp_path):
    line = _one_line(*_run(capsys, "operability", "--config", ROOT / "examples" / "full.toml", "--berth", BERTH,
                           "--metocean", SAMPLE, "--hours", "3", "--manifold-loads", "--out",
                           tmp_path / "o.parquet")[::2])
    assert "--manifold-loads needs --bank" in line and not (tmp_path / "o.parquet").exists()


def test_a_run_judging_the_manifold_is_not_resumed_from_one_that_did_not(tmp_path):
    from loadarm.studies.operability import _manifest

    files = [tmp_path / n for n in ("bank.toml", "berth.toml", "met.csv")]
    for p in files:
        p.write_text(p.name)
    st = OperabilitySettings()
    assert _manifest(*files, None, st, [(0, 1)]) != _manifest(*files, None, st, [(0, 1)], variant="manifold loads")


# ----------------------------------------------------------------------------------------------------- slow


@pytest.mark.slow
def test_the_manifold_criterion_is_the_manifold_study_s_on_the_same_hours(berth_ship):
    """The criterion's loads (each state's record as the monitoring reads it) against the separate study
    (`studies.manifold.manifold_states`: the ship simulated again by `ship.motion.simulate`, its
    `ShipMotion` through `motion_manifold_loads`) on the same hours, the sample's storm among them (2025-02-13
    18:00, the record's largest load): each arm's largest utilisation to 1e-9 (the same seed, the same ship)."""
    from loadarm.studies.manifold import manifold_states
    from loadarm.studies.operability import record_rows, state_ship

    bf, ship = berth_ship
    bank = load_bank(BANK)
    rows = record_rows(SAMPLE, None)[0][1049:1052]
    st = _settings(bank)
    df = pd.DataFrame(bank_states(bank, ship, bank_tables(bank, rows), rows, st, bf.berth.x_bearing_deg,
                                  bf.environment, manifold_loads=True))
    study = manifold_states(bank, state_ship(ship, st.criteria), bf.environment, rows,
                            x_bearing_deg=bf.berth.x_bearing_deg, duration=600.0, seed=st.seed)
    ours = df[[f"manifold_utilisation_{n}" for n in bank.names]].to_numpy()
    assert np.allclose(ours, study.utilisation.max(axis=2), rtol=0, atol=1e-9)
    assert df["manifold_utilisation"].tolist() == ours.max(axis=1).tolist()
    # docs/bank.md's worst over the sample (the whole record's, --manifold-loads, 2026-12-06: this hour's)
    assert ours.max() == pytest.approx(0.637, abs=5e-4) and df["manifold_governing"].iloc[1] == "L1 axial force"
    assert ours[1].tolist() == pytest.approx([0.637, 0.569, 0.438, 0.476], abs=5e-4)   # V1 its worst elsewhere
    assert not df["down_manifold"].any() and df["manifold_at_s"].iloc[1] == pytest.approx(431.1, abs=0.05)


def _alone(bank, i: int, *, centred: bool = False):
    """Arm ``i`` of the bank alone on the same manifold (a bank file takes two arms at least: built here); with
    ``centred``, its riser at the bank's origin and its flange at the manifold's centre."""
    arm, fl = bank.file.arms[i], bank.flanges[i]
    if centred:
        arm = arm.model_copy(update={"x": 0.0, "y": 0.0})
        fl = fl.model_copy(update={"offset": 0.0, "height": 0.0})
    file = bank.file.model_copy(update={"arms": (arm,), "manifold": bank.file.manifold.model_copy(
        update={"flanges": (fl,)})})
    return dataclasses.replace(bank, file=file, installations=bank.installations[i:i + 1],
                               paths=bank.paths[i:i + 1], models=bank.models[i:i + 1], shapes=bank.shapes[i:i + 1],
                               flanges=(fl,), connected=bank.connected[i:i + 1], stowed=bank.stowed[i:i + 1])


@pytest.fixture(scope="module")
def berth_ship():
    from loadarm.params.berth import load_berth
    from loadarm.ship.model import compile_ship

    bf = load_berth(BERTH)
    return bf, compile_ship(bf, source=str(BERTH))


def _settings(bank):
    return OperabilitySettings(duration_per_state=600.0).resolved(bank.installations[0].operability)


@pytest.mark.slow
def test_a_one_arm_bank_is_the_single_arm_operability(berth_ship):
    """The example installation alone, its riser at the bank's origin and its flange at the manifold's centre (the
    installation's own flange): the same rows as `loadarm operability --config`, bit for bit but the flange's
    significant motion (its standard deviation taken in the arm's frame, not the berth's: within 1e-12 m). The
    hours 05:00-07:00 of the sample: one up, two with ESD-1."""
    from loadarm.studies.operability import record_rows

    bf, ship = berth_ship
    bank = load_bank(BANK)
    one = _alone(bank, 0, centred=True)
    fx, fz = one.models[0].approach.flange
    assert np.array_equal(one.flange_position(0), [fx, 0.0, fz])
    rows = record_rows(SAMPLE, 8)[0][5:8]
    st = _settings(bank)
    single = pd.DataFrame(run_states(one.models[0], ship, monitor_table(one.models[0], rows), rows, st,
                                     bf.berth.x_bearing_deg, bf.environment), columns=list(COLUMNS))
    tables = bank_tables(one, rows)
    assert np.array_equal(tables[0]._hv, monitor_table(one.models[0], rows)._hv)
    banked = pd.DataFrame(bank_states(one, ship, tables, rows, st, bf.berth.x_bearing_deg, bf.environment),
                          columns=list(bank_columns(one.names)))
    assert single["stage"].tolist() == [0, 2, 2] and single["down"].tolist() == [False, True, True]
    for c in COLUMNS:
        if c == "flange_motion_m":
            np.testing.assert_allclose(banked[c], single[c], rtol=0, atol=1e-12)
        else:
            pd.testing.assert_series_equal(banked[c], single[c], check_exact=True, obj=c)
    assert banked["arm_governing"].tolist() == ["", "L1", "L1"]
    assert banked["stage_L1"].tolist() == single["stage"].tolist()


@pytest.mark.slow
def test_the_bank_is_down_when_any_arm_alone_is(berth_ship):
    """The example bank with L3's riser 0.3 m back from the ship (its flange farther: ESD-1 from 04:00) and L1's
    0.5 m towards it (never), over 03:00-07:00: the bank's down set is the union of each arm's run alone (a bank
    of that arm only, on the same manifold: the ship's criteria and that arm's), each arm's columns are its own
    run's, the downtime by arm is each run alone's, and the governing arm is one that is down alone."""
    from loadarm.studies.operability import record_rows

    bf, ship = berth_ship
    bank = load_bank(BANK)
    arms = list(bank.file.arms)
    arms[0] = arms[0].model_copy(update={"x": 0.5})
    arms[3] = arms[3].model_copy(update={"x": -0.3})
    bank = dataclasses.replace(bank, file=bank.file.model_copy(update={"arms": tuple(arms)}))
    rows = record_rows(SAMPLE, 8)[0][3:8]
    st = _settings(bank)
    env = (bf.berth.x_bearing_deg, bf.environment)
    tables = bank_tables(bank, rows)
    df = pd.DataFrame(bank_states(bank, ship, tables, rows, st, *env))
    alone = {}
    for i, n in enumerate(bank.names):
        one = _alone(bank, i)
        alone[n] = pd.DataFrame(bank_states(one, ship, tables[i:i + 1], rows, st, *env))
        assert alone[n][f"stage_{n}"].tolist() == df[f"stage_{n}"].tolist(), n
        for c in CRITERIA[:-1]:                                   # the ship's criteria: the same ship
            assert alone[n][f"down_{c}"].tolist() == df[f"down_{c}"].tolist(), (n, c)
        assert alone[n][f"down_arm_{n}"].tolist() == df[f"down_arm_{n}"].tolist(), n
    union = np.logical_or.reduce([a["down"].to_numpy() for a in alone.values()])
    assert df["down"].tolist() == union.tolist() == [False, True, True, True, True]
    assert [int(a[f"down_arm_{n}"].sum()) for n, a in alone.items()] == [0, 2, 2, 4]
    assert BankOperabilityResult(df, names=bank.names).by_arm()["downtime_by_arm_h"] == \
        {n: int(a["down"].sum()) for n, a in alone.items()}
    assert all(g == "" or alone[g]["down"].iloc[k] for k, g in enumerate(df["arm_governing"]))
    assert df["arm_governing"].tolist() == ["", "L3", "L3", "L3", "L3"]
    assert df["stage"].tolist() == np.max([df[f"stage_{n}"] for n in bank.names], axis=0).tolist()


@pytest.mark.slow
def test_cli_bank_prints_the_table_and_writes_the_parquet_then_resumes(capsys, tmp_path):
    """Through the command line: the table with the bank's rows, the Parquet with every arm's columns, the chunks
    resumed; an edit of an arm's installation (not of the bank file) refuses them."""
    (tmp_path / "arm.toml").write_text((ROOT / "examples" / "full.toml").read_text())
    bank = tmp_path / "bank.toml"
    bank.write_text(BANK.read_text().replace('"../full.toml"', '"arm.toml"'))
    out = tmp_path / "bank.parquet"
    args = ["operability", "--bank", bank, "--berth", BERTH, "--metocean", SAMPLE, "--hours", "3",
            "--duration-per-state", "600", "--chunks", "2", "--workers", "1", "--out", out]
    code, text, err = _run(capsys, *args)
    assert code == 0, err
    rows = {ln[:66].strip(): ln[66:].strip() for ln in text.splitlines()}
    assert rows["downtime by arm (that arm alone, the ship's criteria too)"] == \
        "L1 0 h (0.0 %), L2 0 h (0.0 %), V1 0 h (0.0 %), L3 0 h (0.0 %)", text
    assert rows["governing arm (hours it took the arm criterion down)"] == "none: L1 0 h, L2 0 h, V1 0 h, L3 0 h"
    assert rows["sea states"] == "3" and rows["downtime"] == "0.0 %"
    df = pd.read_parquet(out)
    assert list(df.columns) == list(bank_columns(("L1", "L2", "V1", "L3"))) and len(df) == 3
    assert sorted(p.name for p in Path(f"{out}.chunks").glob("chunk-*.parquet")) == ["chunk-00000.parquet",
                                                                                     "chunk-00001.parquet"]
    code, _, err = _run(capsys, *args)                   # resumed: every chunk written, nothing computed again
    assert code == 0, err
    pd.testing.assert_frame_equal(pd.read_parquet(out), df)
    (tmp_path / "arm.toml").write_text((tmp_path / "arm.toml").read_text() + "\n# edited\n")
    line = _one_line(*_run(capsys, *args)[::2])
    assert "chunks are from another run" in line


def _cited(text: str) -> None:
    page = " ".join((ROOT / "docs" / "bank.md").read_text(encoding="utf-8").split())
    assert text in page, f"docs/bank.md should say {text!r} (recomputed)"


@pytest.mark.slow
def test_bank_page_sample_numbers(tmp_path):
    """docs/bank.md, "Operability of a bank": the shipped sample at 600 s a state (seeded: the counts are exact)."""
    from loadarm.studies.bank_operability import run_bank_operability

    res = run_bank_operability(BANK, BERTH, SAMPLE, tmp_path / "b.parquet",
                               settings=OperabilitySettings(duration_per_state=600.0))
    d, t = res.to_dict(), res.table
    lo, hi = d["downtime_ci"]
    _cited(f"bank is down {100 * d['downtime_fraction']:.1f} % of the hours (90 % interval {100 * lo:.1f}-"
           f"{100 * hi:.1f} %), the arm criterion {100 * d['down_arm_fraction']:.1f} %")
    alone = d["downtime_by_arm_h"]
    _cited("been down " + ", ".join(f"{a} {alone[a]} h" for a in res.names) + f", and the bank {int(t['down'].sum())} h")
    some = t[[f"down_arm_{a}" for a in res.names]].sum(axis=1)
    _cited(f"only {int(some.between(1, len(res.names) - 1).sum())} hours had some arms down but not all")
    gov = sorted(((h, a) for a, h in d["governing_h"].items() if h), reverse=True)
    _cited(f"The governing arm is {d['governing_arm']} ({gov[0][0]} h, "
           + ", ".join(f"{a} {h} h" for h, a in gov[1:]) + ")")
