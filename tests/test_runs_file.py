"""A campaign run in parts through a runs file (``--runs``) gives exactly the campaign run at once."""

import json

import pytest

from loadarm.cli import main
from loadarm.errors import ConfigError
from loadarm.studies.campaign import parse_vary, run_campaign
from loadarm.studies.runs_file import RunsFile, code_digest

from .conftest import ROOT


def _short(tmp_path, name="short.toml", duration=30.0):
    """The calm berth for a few seconds of simulated time (what is stored does not depend on the run's length)."""
    text = (ROOT / "examples" / "scenarios" / "calm.toml").read_text()
    text = text.replace('installation = "../paper.toml"',
                        f'installation = "{(ROOT / "examples" / "paper.toml").as_posix()}"')
    text = text.replace("duration = 400.0", f'duration = {duration}\nplant = "kinematic"')
    p = tmp_path / name
    p.write_text(text)
    return p


def _stats(res):
    d = res.to_dict()
    d.pop("codes")
    return d


@pytest.mark.slow           # 3 s: make test's budget on 2 cores (CI runs it)
def test_a_campaign_in_parts_is_the_campaign_at_once(tmp_path):
    sc = _short(tmp_path)
    vary = [parse_vary("ship.tide_rate=0:2e-4")]
    whole = run_campaign(sc, 4, vary=vary, workers=1, first_seed=10)
    runs = tmp_path / "runs.jsonl"
    first = run_campaign(sc, 2, vary=vary, workers=1, first_seed=11, runs_file=runs)
    assert first.summary()["runs"] == 2 and first.codes == {code_digest()[:16]: 2}
    seen = []
    merged = run_campaign(sc, 4, vary=vary, workers=1, first_seed=10, runs_file=runs,
                          progress=lambda d, n: seen.append(d))
    assert seen[0] == 2 and seen[-1] == 4              # the stored two reported first, then only two more run
    assert _stats(merged) == _stats(whole)
    assert [r for r in merged.runs] == [r for r in whole.runs]
    lines = runs.read_text().splitlines()
    assert len(lines) == 5 and json.loads(lines[0])["kind"] == "campaign runs"
    assert sorted(json.loads(x)["run"]["seed"] for x in lines[1:]) == [10, 11, 12, 13]
    # all held: nothing runs, the same answer
    again = run_campaign(sc, 4, vary=vary, workers=1, first_seed=10, runs_file=runs)
    assert _stats(again) == _stats(whole) and len(runs.read_text().splitlines()) == 5
    # a sub-range reports its own seeds only
    assert run_campaign(sc, 2, vary=vary, workers=1, first_seed=12, runs_file=runs).to_dict()["seeds"] == [12, 13]


def test_a_line_cut_by_a_kill_is_dropped_and_cut_off_before_the_next_append(tmp_path):
    sc = _short(tmp_path)
    runs = tmp_path / "runs.jsonl"
    run_campaign(sc, 1, workers=1, first_seed=0, runs_file=runs)
    whole = runs.read_bytes()
    runs.write_bytes(whole + b'{"code":"x","run":{"seed":1,"dra')          # killed mid-line
    f = RunsFile(runs, str(sc), None, [])
    assert f.seeds() == {0} and runs.read_bytes() == whole
    res = run_campaign(sc, 2, workers=1, first_seed=0, runs_file=runs)
    assert [r.seed for r in res.runs] == [0, 1]
    assert all(json.loads(x) for x in runs.read_text().splitlines())


def test_a_runs_file_of_another_campaign_is_refused_in_one_line(tmp_path):
    sc = _short(tmp_path)
    runs = tmp_path / "runs.jsonl"
    run_campaign(sc, 1, workers=1, runs_file=runs)
    before = runs.read_bytes()
    with pytest.raises(ConfigError, match=r"--runs .*runs.jsonl: its runs are of another campaign \(plant"):
        RunsFile(runs, str(sc), "kinematic", [])
    with pytest.raises(ConfigError, match=r"another campaign \(vary"):
        RunsFile(runs, str(sc), None, [("ship.tide_rate", 0.0, 1e-4)])
    other = _short(tmp_path, "short.toml", duration=31.0)                   # same name, other contents
    with pytest.raises(ConfigError, match=r"another campaign \(inputs_sha256"):
        RunsFile(runs, str(other), None, [])
    assert runs.read_bytes() == before
    foreign = tmp_path / "notes.jsonl"
    foreign.write_text('{"a": 1}\n')
    with pytest.raises(ConfigError, match="not a loadarm campaign runs file"):
        RunsFile(foreign, str(other), None, [])
    assert foreign.read_text() == '{"a": 1}\n'                             # not ours: not changed by a byte
    edited = tmp_path / "edited.jsonl"
    edited.write_bytes(runs.read_bytes().replace(b'"seed":0', b'"seed":0,,'))
    _short(tmp_path, "short.toml")
    with pytest.raises(ConfigError, match="line 2 is not a run"):
        RunsFile(edited, str(sc), None, [])
    head = runs.read_text().splitlines()[0]
    for bad in ('{"code": "x"}', '{"code": "x", "run": {"seed": "1"}}', '[1, 2]', '{"run": {"seed": 1}}'):
        edited.write_text(head + "\n" + bad + "\n")                       # JSON, but not a run
        with pytest.raises(ConfigError, match="line 2 is not a run"):
            RunsFile(edited, str(sc), None, [])


def test_the_cli_refuses_a_foreign_runs_file_before_running(tmp_path, capsys):
    sc = _short(tmp_path)
    foreign = tmp_path / "notes.jsonl"
    foreign.write_text("hello\n")
    assert main(["campaign", "-s", str(sc), "-n", "1", "--runs", str(foreign)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a loadarm campaign runs file" in err[0]
    bank = str(ROOT / "examples" / "banks" / "lng150k_bank.toml")
    breakout = str(ROOT / "examples" / "scenarios" / "breakout.toml")
    assert main(["campaign", "-s", breakout, "-n", "1", "--runs", str(foreign), "--bank", bank]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a loadarm campaign runs file" in err[0]
    assert main(["campaign", "-s", breakout, "-n", "1", "--plant", "kinematic", "--bank", bank]) == 2
    assert "takes no --vary, --plant or --scheduler" in capsys.readouterr().err
    assert foreign.read_text() == "hello\n"


def test_with_a_runs_file_each_batch_is_small_so_a_kill_loses_little(tmp_path, monkeypatch):
    """Found: 1000 seeds on one worker went in batches of 250 (about an hour of tracked runs), none written until
    its batch ended; with a runs file a batch holds at most RUNS_FILE_BATCH runs, and each is on file as it ends
    (the runs themselves are not the point here: the worker is stood in for)."""
    from loadarm.studies import campaign

    sizes: list[int] = []

    def counted(scenario, plant, jobs):
        sizes.append(len(jobs))
        if len(sizes) == 1:
            return [campaign.CampaignRun(seed=s, draws=d, overstretched=False, overstretched_before_isolation=False,
                                         opened_on_live_product=False, false_alarm=False, missed_alarm=False,
                                         alarm1_s=None, release_complete_s=None, limit_s=None,
                                         release_margin_s=None, limit_face="") for s, d in jobs]
        raise KeyboardInterrupt                      # the kill, after the first batch

    monkeypatch.setattr(campaign, "run_batch", counted)
    runs = tmp_path / "runs.jsonl"
    with pytest.raises(KeyboardInterrupt):
        run_campaign(_short(tmp_path), 100, workers=1, runs_file=runs)
    kept = [json.loads(line) for line in runs.read_text().splitlines()[1:]]
    assert sizes == [campaign.RUNS_FILE_BATCH, campaign.RUNS_FILE_BATCH]
    assert [k["run"]["seed"] for k in kept] == list(range(campaign.RUNS_FILE_BATCH))
    sizes.clear()
    monkeypatch.setattr(campaign, "run_batch", lambda sc, pl, jobs: sizes.append(len(jobs)) or [])
    run_campaign(_short(tmp_path, "other.toml"), 100, workers=1)       # no runs file: about four a worker
    assert sizes == [25, 25, 25, 25]


@pytest.mark.parametrize("runs", sorted(p.name for p in (ROOT / "docs" / "campaigns").glob("*_runs.jsonl")))
def test_every_stored_campaign_is_of_the_shipped_inputs(runs, tmp_path):
    """Each runs file under docs/campaigns (whose results the docs' tables quote) was run on the scenario, its
    installation and berth, and for a bank the bank file and its installations, as they ship today: its header's
    digest is theirs. Found: the example bank's flanges were moved and nothing said that the stored bank campaign
    described the old manifold. (Read from a copy: opening a runs file may cut a torn last line.)"""
    import shutil

    from loadarm.params.bank import load_bank

    src = ROOT / "docs" / "campaigns" / runs
    head = json.loads(src.open(encoding="utf-8").readline())
    copy = tmp_path / runs
    shutil.copyfile(src, copy)
    scenario = ROOT / "examples" / "scenarios" / head["scenario"]
    if head.get("bank"):
        bank_file = ROOT / "examples" / "banks" / head["bank"]
        also = sorted({str(p) for p in load_bank(bank_file).paths})
        RunsFile(copy, str(scenario), head["plant"], [], bank=bank_file, also=also)
    else:
        RunsFile(copy, str(scenario), head["plant"], [tuple(v) for v in head["vary"]])
