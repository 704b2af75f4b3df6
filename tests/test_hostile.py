"""Hostile inputs and files (issue 11): each case found by the attack on 289 inputs, reproduced here.

The property everywhere: exit 0 with what was asked for, or exit 2 with one ``loadarm: error:`` line that names
the file, the key, the value and the allowed range; never a traceback, a hang, a silent coercion or clamp, a
lost input or an overwritten file.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

from loadarm.cli import main

from .conftest import PAPER_TOML, ROOT

CFG = str(PAPER_TOML)
SCEN = ROOT / "examples" / "scenarios"


def run(capsys, *args):
    code = main([str(a) for a in args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def refused(capsys, *args, contains=()):
    """Exit 2, one line on stderr starting with loadarm: error:, containing each given text."""
    code, out, err = run(capsys, *args)
    lines = err.strip().splitlines()
    assert code == 2, (code, out, err)
    assert len(lines) == 1 and lines[0].startswith("loadarm: error: "), err
    for c in (contains if isinstance(contains, (list, tuple)) else [contains]):
        assert c in lines[0], (c, lines[0])
    return lines[0]


def digest(p) -> str:
    return hashlib.sha256(open(p, "rb").read()).hexdigest()


def _paper_with(tmp_path, old: str, new: str, name="inst.toml"):
    text = PAPER_TOML.read_text()
    assert old in text, old
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1))
    return p


def _scenario(tmp_path, body: str, name="s.toml"):
    p = tmp_path / name
    p.write_text(f'[scenario]\ninstallation = "{PAPER_TOML.as_posix()}"\n' + body)
    return p


# ---------------------------------------------------------------- tracebacks found

def test_rich_markup_in_names_and_paths_is_printed_as_it_is(capsys, tmp_path):
    """Found: a scenario `name = "[/bold]"` or a `[/x]` in --csv, --png or --db raised rich's MarkupError after
    the file was written; a `[link=...]` in a path changed what was printed."""
    sc = _scenario(tmp_path, 'name = "[/bold] [link=http://x]y[/link]"\nduration = 5.0\nplant = "kinematic"\n')
    db = tmp_path / "[/x]ev.db"
    code, out, err = run(capsys, "run", "-s", sc, "--db", db, "--png", tmp_path / "[/x].png")
    assert code == 0, err
    assert "scenario [/bold] [link=http://x]y[/link]:" in out and f"events logged to {db}" in out
    assert (tmp_path / "[/x].png").is_file() and db.is_file()
    csv = tmp_path / "[link=https://evil.example]a[/link].csv"
    code, out, err = run(capsys, "plan", "-c", CFG, "--csv", csv)
    assert code == 0 and f"samples written to {csv}" in out and csv.is_file()
    # the CLI's own error lines keep their brackets (found while fixing: "[start, end]" was eaten as markup)
    bad = _scenario(tmp_path, "duration = 60.0\n[sensor]\ndropouts = [[48.0, 40.0]]\n", "drop.toml")
    refused(capsys, "run", "-s", bad, "--no-db", contains="[start, end]")


def test_deeply_nested_toml_is_refused(capsys, tmp_path):
    """Found: a value nested 5000 brackets deep raised RecursionError."""
    p = tmp_path / "deep.toml"
    p.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    refused(capsys, "plan", "-c", p, contains=[str(p), "nested too deeply"])
    p.write_text("a = " + "[" * 40 + "]" * 40 + "\n")
    refused(capsys, "plan", "-c", p, contains=[str(p), "nested more than 32 levels"])


@pytest.mark.parametrize("body", ["[scenario]\nduration = 86400.0\n[sensor]\nrate = 1000.0\n",
                                  "[scenario]\nduration = 86400.0\n[guidance]\nrate = 5000.0\n"])
def test_a_run_that_needs_gigabytes_is_refused_with_the_figure(capsys, tmp_path, body):
    """Found: in-range scenarios needing 20-58 GB ended in a MemoryError or an OOM kill."""
    sc = tmp_path / "big.toml"
    sc.write_text(body.replace("[scenario]\n", f'[scenario]\ninstallation = "{PAPER_TOML.as_posix()}"\n'))
    line = refused(capsys, "run", "-s", sc, "--no-db", contains=[str(sc), "scenario.duration = 86400 s", "GB"])
    assert "more than the 2 GB a run may take" in line


def test_the_wave_motion_of_a_day_is_computed_in_bounded_memory():
    """Found: `[waves] hs = 1.5` over a day built a (times, 3, components) array of tens of gigabytes. The
    motion is now summed in chunks: the same numbers (bit for bit, on a sample) in memory bounded by the chunk
    and the output, far below the whole array's."""
    from loadarm.params.scenario import load_scenario
    from loadarm.ship.flange import WAVE_CHUNK, flange_motion

    sc, _ = load_scenario(SCEN / "hs15.toml")
    m = flange_motion(sc)
    t = np.linspace(0.0, 600.0, 3001)
    whole = np.sum(m.amp * np.cos(t[:, None, None] * m.w + m.phase), axis=-1)
    assert np.array_equal(m._waves(t, 0), whole)
    tt = np.arange(0.0, 3600.0, 0.1)                      # an hour at 10 Hz: all at once would be 173 MB
    tracemalloc.start()
    m.position(tt)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 4 * 8 * WAVE_CHUNK + 10 * 8 * 3 * tt.size < tt.size * 3 * m.w.size * 8 / 2, peak


@pytest.mark.slow
def test_the_run_memory_estimate_covers_what_a_run_allocates():
    """The estimate that refuses a run is checked against tracemalloc: the extra memory a run takes for
    twice the duration is at most the estimate's difference."""
    from loadarm.params.scenario import load_scenario, run_memory
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCEN / "calm.toml")

    def peak(duration):
        s = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": duration,
                                                                             "plant": "kinematic"})})
        tracemalloc.start()
        r = run_scenario(s, model)
        p = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        del r
        return p, run_memory(s)

    run_scenario(sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": 5.0})}), model)
    p1, e1 = peak(60.0)
    p2, e2 = peak(120.0)
    assert p2 - p1 <= e2 - e1, (p2 - p1, e2 - e1)


def _events_db(tmp_path, name="ev.db"):
    from loadarm.eventlog import EventLog

    db = tmp_path / name
    with EventLog(db, run="r") as log:
        for i in range(300):
            log.append(float(i), "CONNECTED", "sample", "state", beta=1.0, phi=0.0, distance=0.1)
            log.append(float(i), "CONNECTED", "info", "x" * 200)
    return db


def test_a_corrupt_event_log_is_refused(capsys, tmp_path):
    """Found: an event log whose pages are corrupt (header intact) raised sqlite3.DatabaseError: malformed."""
    db = _events_db(tmp_path)
    with open(db, "r+b") as fh:
        fh.seek(4096 * 2)
        fh.write(os.urandom(4096 * 6))
    before = digest(db)
    refused(capsys, "log", "--db", db, contains=str(db))
    assert digest(db) == before


def test_a_read_only_event_log_is_refused_before_the_run(capsys, tmp_path):
    """Found: a read-only database raised OperationalError: readonly after the run had started. Read-only by
    its mode; as root (who writes such files anyway), immutable (`chattr +i`) where the file system allows."""
    import shutil

    db = _events_db(tmp_path)
    os.chmod(db, 0o444)
    immutable = False
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        chattr = shutil.which("chattr")
        immutable = bool(chattr) and subprocess.run([chattr, "+i", str(db)], capture_output=True).returncode == 0
        if not immutable:
            pytest.skip("root writes read-only files, and chattr +i is not available here")
    try:
        sc = _scenario(tmp_path, "duration = 5.0\n")
        refused(capsys, "run", "-s", sc, "--db", db, contains=[str(db), "cannot open event log"])
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(db)], capture_output=True)


def test_a_foreign_database_is_refused_and_left_as_it_was(capsys, tmp_path):
    """Found: a foreign SQLite file with its own `events` table gave 'no such column: wall'; `log` (a read-only
    command) added tables to a foreign or empty file and switched it to WAL; `run` wrote into a foreign one."""
    foreign = tmp_path / "foreign.db"
    con = sqlite3.connect(foreign)
    con.execute("CREATE TABLE events (a, b)")
    con.commit()
    con.close()
    empty = tmp_path / "empty.db"
    empty.write_bytes(b"")
    sc = _scenario(tmp_path, 'duration = 5.0\nplant = "kinematic"\n')
    for db in (foreign, empty):
        before = digest(db)
        refused(capsys, "log", "--db", db, contains=[str(db), "not an event log" if db == empty
                                                   else "not a loadarm event log"])
        assert digest(db) == before and not os.path.exists(f"{db}-wal")
    before = digest(foreign)
    refused(capsys, "run", "-s", sc, "--db", foreign, contains="not a loadarm event log")
    assert digest(foreign) == before
    refused(capsys, "run", "-s", sc, "--db", ":memory:", contains="--no-db")     # found: events thrown away


@pytest.mark.parametrize("edit,expect", [
    ("UPDATE events SET data = '{}' WHERE kind = 'sample' AND id = 3", "a sample needs a finite number 'beta'"),
    ("UPDATE events SET data = '{bad' WHERE id = 5", "event id 5: data is not a JSON object"),
    ("UPDATE events SET state = 'NOPE' WHERE kind = 'sample' AND id = 7", "state 'NOPE' is not a guidance mode"),
    ("UPDATE events SET t = 'x' WHERE id = 9", "event id 9: t = 'x' is not a finite number"),
])
def test_damaged_rows_are_named_not_trusted(capsys, tmp_path, edit, expect):
    """Found: a `sample` row with data='{}' raised KeyError: 'beta' in `log --png`; bad JSON or a bad state
    raised 'tuple.index(x): x not in tuple'."""
    db = _events_db(tmp_path)
    con = sqlite3.connect(db)
    con.execute(edit)
    con.commit()
    con.close()
    refused(capsys, "log", "--db", db, "--samples", "--png", tmp_path / "t.png", contains=expect)


# ---------------------------------------------------------------- hangs found

@pytest.mark.parametrize("special", ["fifo", "/dev/zero", "/dev/urandom"])
def test_special_files_as_config_are_refused_at_once(tmp_path, special):
    """Found: a FIFO, /dev/zero or /dev/urandom as --config hung (read without a size limit). Run in a
    subprocess with a timeout, so a regression fails instead of hanging the suite."""
    if special == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no FIFOs on this platform")
        special = tmp_path / "fifo"
        os.mkfifo(special)
    elif not os.path.exists(special):
        pytest.skip(f"no {special} here")
    r = subprocess.run([sys.executable, "-m", "loadarm.cli", "plan", "--config", str(special)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.startswith("loadarm: error: ") and "regular file" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_large_input_is_refused_unread(capsys, tmp_path):
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * (1 << 21) + "\n")
    refused(capsys, "plan", "-c", big, contains=[str(big), "at most 1048576 bytes"])


# ---------------------------------------------------------------- silently accepted, found

@pytest.mark.parametrize("old,new,expect", [
    ("inboard = 12.0", 'inboard = "12"', "arm.inboard = '12'"),
    ("inboard = 12.0", "inboard = true", "arm.inboard = True"),
    ("max_speed = 0.15", "max_speed = 1e-300", "approach.max_speed = 1e-300"),
    ("max_accel = 0.05", "max_accel = 1e-300", "approach.max_accel = 1e-300"),
    ("a1 = 1.0", "a1 = 1e-12", "cylinder 1 has a usable stroke of 2e-12 m"),
])
def test_installation_values_are_not_coerced_or_left_absurd(capsys, tmp_path, old, new, expect):
    """Found: `inboard = "12"` and `inboard = true` (1.0 m) were accepted; max_speed or max_accel = 1e-300 made
    a plan lasting 1e301 s; `actuators.a1 = 1e-12` made a zero-stroke cylinder."""
    p = _paper_with(tmp_path, old, new)
    line = refused(capsys, "plan", "-c", p, contains=[str(p), expect])
    assert "valid range" in line or "at least 0.05 m" in line


@pytest.mark.parametrize("body,expect", [
    ("seed = true\n", "scenario.seed = True"),
    ('duration = "400"\n', "scenario.duration = '400'"),
    ("[sensor]\ndropouts = [[48.0, 40.0]]\n", "0 <= start < end, got [48.0, 40.0]"),
    ("[sensor]\ndropouts = [[nan, nan]]\n", "sensor.dropouts.0.0 = nan"),
])
def test_scenario_values_are_not_coerced_or_ignored(capsys, tmp_path, body, expect):
    """Found: `seed = true`, `duration = "400"` accepted; `dropouts = [[48, 40]]` or `[[nan, nan]]` ignored."""
    sc = tmp_path / "s.toml"
    head = f'[scenario]\ninstallation = "{PAPER_TOML.as_posix()}"\n'
    sc.write_text(head + body if body.startswith("[") else head + body)
    refused(capsys, "run", "-s", sc, "--no-db", contains=[str(sc), expect])


def test_log_since_nan_is_refused(capsys, tmp_path):
    """Found: `log --since nan` printed 0 events."""
    db = _events_db(tmp_path)
    refused(capsys, "log", "--db", db, "--since", "nan", contains="--since must be a finite time")


def test_an_output_never_replaces_an_input_or_a_foreign_file(capsys, tmp_path):
    """Found: `plan --config X --csv X` overwrote the installation with CSV; every output was written in place and
    silently replaced whatever was there."""
    inst = tmp_path / "inst.toml"
    inst.write_text(PAPER_TOML.read_text())
    before = digest(inst)
    refused(capsys, "plan", "-c", inst, "--csv", inst, contains="is an input of this command")
    refused(capsys, "envelope", "-c", inst, "--png", inst, contains="--png must name a .png file")
    assert digest(inst) == before
    notes = tmp_path / "notes.png"
    notes.write_bytes(b"\x89PNG\r\n\x1a\nsomeone else's picture")
    refused(capsys, "envelope", "-c", inst, "--png", notes, contains=["was not written by loadarm", "--force"])
    assert notes.read_bytes().endswith(b"someone else's picture")
    code, _, err = run(capsys, "envelope", "-c", inst, "--png", notes, "--force")
    assert code == 0, err
    code, _, err = run(capsys, "envelope", "-c", inst, "--png", notes)          # now loadarm's: replaced freely
    assert code == 0, err
    # two outputs that are one file, and an event log that is the figure
    sc = _scenario(tmp_path, 'duration = 5.0\nplant = "kinematic"\n')
    refused(capsys, "run", "-s", sc, "--db", tmp_path / "x.png", "--png", tmp_path / "x.png",
            contains="name the same file")
    refused(capsys, "run", "-s", sc, "--db", sc, contains="is an input of this command")
    # the report's directory
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text('{"mine": 1}')
    refused(capsys, "demo", "--out", out, contains=["summary.json", "was not written by loadarm"])
    assert json.loads((out / "summary.json").read_text()) == {"mine": 1}


def test_outputs_are_written_atomically(tmp_path):
    """An output is a temporary file renamed over the target: a failure mid-write leaves the old file and no
    temporary behind."""
    from loadarm.files import atomic_open, atomic_write

    p = atomic_write(tmp_path / "a.txt", "old")
    with pytest.raises(RuntimeError):
        with atomic_open(p, "w", encoding="utf-8") as fh:
            fh.write("half of the new")
            raise RuntimeError("disk full")
    assert p.read_text() == "old" and sorted(os.listdir(tmp_path)) == ["a.txt"]
    atomic_write(p, b"new")
    assert p.read_bytes() == b"new" and sorted(os.listdir(tmp_path)) == ["a.txt"]


def test_loadarm_recognises_its_outputs_by_format_not_by_a_word(tmp_path):
    from loadarm.files import HTML_MARK, JSON_MARK, written_by_loadarm

    cases = {
        "mention.md": (b"# notes about loadarm and its outputs", False),
        "theirs.png": (b"\x89PNG\r\n\x1a\n....Software\x00matplotlib", False),
        "ours.png": (b"\x89PNG\r\n\x1a\n....Software\x00loadarm 0.1", True),
        "ours.html": (b"<!doctype html><html><head>" + HTML_MARK.encode() + b' 0.1">', True),
        "theirs.html": (b"<!doctype html><p>loadarm</p>", False),
        "ours.json": (JSON_MARK.encode() + b' 0.1", "a": 1}', True),
        "theirs.json": (b'{"generator": "loadarm"}', False),
        "ours.csv": (b"t_s,x_m,y_m,alpha_deg,beta_deg\n0,1,2,3,4\n", True),
        "theirs.csv": (b"a,b\n1,2\n", False),
    }
    for name, (data, ours) in cases.items():
        (tmp_path / name).write_bytes(data)
        assert written_by_loadarm(tmp_path / name) is ours, name


def test_a_campaign_on_a_malformed_scenario_is_refused(capsys, tmp_path):
    """Found by the fuzz suite (thorough profile): `scenario = 0.0` in a campaign's scenario raised
    AttributeError ('float' object has no attribute 'get') before validation."""
    sc = tmp_path / "s.toml"
    sc.write_text("scenario = 0.0\n")
    refused(capsys, "campaign", "-s", sc, "--seeds", "1", "--workers", "1", contains=[str(sc), "scenario = 0.0"])


# ---------------------------------------------------------------- the moored ship and the studies

BERTH = ROOT / "examples" / "berths" / "lng150k.toml"


@pytest.mark.parametrize("old,new,expect", [
    ("kg = 12.4", 'kg = "12.4"', "ship.kg"),                          # a string where a number is declared
    ("hs = 1.0", "hs = -1.0", "environment.hs"),
    ("water_depth = 20.0", "water_depth = 11.0", "no water under the keel"),
    ('name = "F1"', 'name = "F2"', "fenders: names must be unique"),
])
def test_bad_berth_files_are_refused_in_one_line(capsys, tmp_path, old, new, expect):
    text = BERTH.read_text()
    assert old in text, old
    p = tmp_path / "b.toml"
    p.write_text(text.replace(old, new, 1))
    refused(capsys, "hydro", "--berth", p, contains=[str(p), expect])
    refused(capsys, "alarms", "--config", CFG, "--berth", p, contains=[expect])


def test_bad_metocean_records_are_refused_before_any_cluster(capsys, tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("time,hs_m\n2025-01-01T00:00Z,1.0\n")
    refused(capsys, "operability", "--config", CFG, "--berth", BERTH, "--metocean", p, "--out", tmp_path / "r.parquet",
            contains=[str(p), "tp_s: missing"])
    refused(capsys, "operability", "--config", CFG, "--berth", BERTH, "--metocean", tmp_path / "none.csv",
            "--out", tmp_path / "r.parquet", contains=["none.csv"])
    refused(capsys, "operability", "--config", CFG, "--berth", BERTH,
            "--metocean", ROOT / "examples" / "metocean" / "sample.csv", "--duration-per-state", "5",
            "--out", tmp_path / "r.parquet", contains=["--duration-per-state must be in [10, 3600] s"])


@pytest.mark.parametrize("command", ["operability", "campaign"])
def test_a_scheduler_address_that_is_not_one_is_refused_naming_it(capsys, tmp_path, command):
    """`--scheduler` with no port: one line naming the option and the address, exit 2 (found: Dask's own words
    alone, which named neither), before any state or run is computed."""
    if command == "operability":
        args = ["operability", "--config", PAPER_TOML, "--berth", ROOT / "examples" / "berths" / "lng150k.toml",
                "--metocean", ROOT / "examples" / "metocean" / "sample.csv", "--hours", "2",
                "--out", tmp_path / "op.parquet"]
    else:
        args = ["campaign", "--scenario", ROOT / "examples" / "scenarios" / "calm.toml", "--seeds", "2"]
    refused(capsys, *args, "--scheduler", "nonsense", contains=("--scheduler nonsense", "no Dask scheduler"))


def test_a_refused_scheduler_leaves_no_dead_default_client():
    """Found (issue 26): a refused address left its half-made client as the process's default and dask's
    scheduler pointing at it; the next dask computation (an xarray read in another test) failed on it."""
    import dask
    import dask.array
    import numpy as np
    from distributed.client import _get_global_client

    from loadarm.errors import ConfigError
    from loadarm.studies.cluster import connect_scheduler

    before = dask.config.get("scheduler", None)
    with pytest.raises(ConfigError, match="--scheduler nonsense"):
        connect_scheduler("nonsense")
    assert _get_global_client() is None and dask.config.get("scheduler", None) == before
    assert float(dask.array.from_array(np.arange(4.0), chunks=2).sum().compute()) == 6.0


def test_a_silent_scheduler_address_is_refused_in_time_naming_it():
    """Nothing listening at the address: refused after the timeout, naming the option and the address."""
    from loadarm.errors import ConfigError
    from loadarm.studies.cluster import connect_scheduler
    from loadarm.testing.loadtest import free_port

    address = f"tcp://127.0.0.1:{free_port()}"
    with pytest.raises(ConfigError, match=f"--scheduler {address}: no Dask scheduler reachable"):
        connect_scheduler(address, timeout=1.0)
