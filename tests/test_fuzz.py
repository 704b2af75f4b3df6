"""Fuzz every command with hypothesis-generated files (issue 11, item 4).

Installations and scenarios are the shipped ones mutated (values replaced by huge, tiny, negative, NaN,
infinite, wrongly typed or nested ones; keys deleted, added or misspelt), broken as text, or replaced by random
bytes; event logs are random bytes or foreign SQLite files. The property for every command: exit 0 with JSON
whose numbers are all finite, or exit 2 with one ``loadarm: error:`` line; never an internal error (exit 1), a
traceback, a hang or another status. ``HYPOTHESIS_PROFILE=thorough`` runs about 17 times more cases.

Runs are kept short on purpose: a valid scenario's duration is capped at 10 s and its rates at 100 Hz (a long
valid run is not a fuzz finding, only a slow one).
"""

from __future__ import annotations

import copy
import json
import math
import sqlite3
import tomllib

import pytest
import tomli_w
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from loadarm.cli import main

from .conftest import PAPER_TOML, ROOT
from .hypo import examples

SCEN = ROOT / "examples" / "scenarios"
PAPER = tomllib.loads(PAPER_TOML.read_text())
SCENARIO = {**tomllib.loads((SCEN / "driftoff.toml").read_text())}
SCENARIO["scenario"] = {**SCENARIO["scenario"], "installation": PAPER_TOML.as_posix(), "duration": 10.0}
SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

EXTREMES = [0.0, -0.0, -1.0, 1e-300, 5e-324, -1e-300, 1e300, -1e300, 1.7976931348623157e308, 2 ** 63 - 1,
            -(2 ** 63), math.nan, math.inf, -math.inf, True, False, "", "12", "nan", [], {}]
VALUES = st.one_of(
    st.sampled_from(EXTREMES),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2 ** 63), 2 ** 63 - 1),
    st.booleans(),
    st.text(max_size=12),
    st.lists(st.floats(-1e6, 1e6), max_size=6),
    st.lists(st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=2), max_size=3),
    st.dictionaries(st.text(min_size=1, max_size=6), st.integers(), max_size=3),
)


@st.composite
def mutated(draw, base: dict) -> dict:
    """A copy of ``base`` with 1-4 edits: a value replaced, or scaled by 0.3-3 (in range more often than not: this
    drives the maths with unusual installations), a key deleted, an unknown key or section added, a key
    misspelt, a section replaced by a value."""
    d = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["set", "scale", "scale", "scale", "delete", "add", "misspell", "section"]))
        sec = draw(st.sampled_from(sorted(d)))
        body = d[sec]
        if op == "section":
            d[sec] = draw(VALUES)
            continue
        if not isinstance(body, dict) or not body:
            continue
        key = draw(st.sampled_from(sorted(body)))
        if op == "set":
            body[key] = draw(VALUES)
        elif op == "scale":
            v = body[key]
            f = draw(st.floats(0.3, 3.0))
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                body[key] = v * f
            elif isinstance(v, list) and all(isinstance(x, (int, float)) for x in v):
                body[key] = [x * f for x in v]
        elif op == "delete":
            del body[key]
        elif op == "add":
            body[draw(st.text(min_size=1, max_size=10))] = draw(VALUES)
        else:
            body[key + draw(st.sampled_from(["_", "s", "x"]))] = body.pop(key)
    return d


def _toml(d: dict) -> str:
    try:
        return tomli_w.dumps(d)
    except (TypeError, ValueError):          # not representable in TOML (e.g. an empty key): write it as a string
        return "x = " + json.dumps(repr(d)) + "\n"


@st.composite
def broken_text(draw, text: str) -> str:
    """TOML text with characters replaced, inserted or deleted."""
    chars = list(text)
    for _ in range(draw(st.integers(1, 8))):
        i = draw(st.integers(0, max(len(chars) - 1, 0)))
        op = draw(st.sampled_from(["replace", "insert", "delete"]))
        c = draw(st.sampled_from(list("[]{}=\"'#\n.,x0-+e ")) | st.characters())
        if op == "replace" and chars:
            chars[i] = c
        elif op == "insert":
            chars.insert(i, c)
        elif chars:
            del chars[i]
    return "".join(chars)


def _short(d: dict) -> dict:
    """Cap a valid scenario's duration and rates (see the module's note)."""
    for sec, key, cap in (("scenario", "duration", 10.0), ("guidance", "rate", 100.0), ("sensor", "rate", 100.0)):
        body = d.get(sec)
        if isinstance(body, dict):
            v = body.get(key)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > cap:
                body[key] = cap
    return d


def check(capsys, *args) -> int:
    """The property: exit 0 with finite JSON, or exit 2 with one error line. Returns the status."""
    code = main([str(a) for a in args])
    cap = capsys.readouterr()
    event(f"{args[0]}: exit {code}")                  # pytest --hypothesis-show-statistics counts them
    assert "Traceback" not in cap.err and "internal error" not in cap.err, cap.err
    if code == 0:
        if "--json" in args:
            json.loads(cap.out, parse_constant=lambda c: pytest.fail(f"non-finite {c} in the JSON output"))
    else:
        lines = cap.err.strip().splitlines()
        assert code == 2, (code, cap.err)
        assert len(lines) == 1 and lines[0].startswith("loadarm: error: "), cap.err
    return code


@pytest.fixture
def fuzz_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


@settings(max_examples=examples(30), **SETTINGS)
@given(data=mutated(PAPER), command=st.sampled_from(["plan", "size", "check"]))
def test_mutated_installations(capsys, fuzz_dir, data, command):
    f = fuzz_dir / "inst.toml"
    f.write_text(_toml(data), encoding="utf-8")
    check(capsys, command, "-c", f, "--json")


@settings(max_examples=examples(20), **SETTINGS)
@given(text=broken_text(PAPER_TOML.read_text()), command=st.sampled_from(["plan", "size"]))
def test_broken_installation_text(capsys, fuzz_dir, text, command):
    f = fuzz_dir / "broken.toml"
    f.write_bytes(text.encode("utf-8", "surrogatepass"))         # a lone surrogate makes invalid UTF-8: also input
    check(capsys, command, "-c", f, "--json")


@settings(max_examples=examples(20), **SETTINGS)
@given(data=mutated(SCENARIO), plant=st.sampled_from(["kinematic", "hydraulic"]))
@pytest.mark.slow  # 2.5-5.6 s (make test's two minutes; CI runs it)
def test_mutated_scenarios(capsys, fuzz_dir, data, plant):
    f = fuzz_dir / "scen.toml"
    f.write_text(_toml(_short(data)), encoding="utf-8")
    check(capsys, "run", "-s", f, "--no-db", "--json", "--plant", plant)


@pytest.mark.slow                      # 3-6 s: to keep make test under two minutes with the HMI's browser tests
@settings(max_examples=examples(20), **SETTINGS)
@given(blob=st.binary(max_size=2048), target=st.sampled_from(["config", "scenario", "db"]))
def test_random_bytes_as_any_input(capsys, fuzz_dir, blob, target):
    f = fuzz_dir / "blob"
    f.write_bytes(blob)
    if target == "config":
        assert check(capsys, "plan", "-c", f, "--json") == 2             # never a valid installation
    elif target == "scenario":
        check(capsys, "run", "-s", f, "--no-db", "--json")
    else:
        before = f.read_bytes()
        check(capsys, "log", "--db", f, "--json")
        assert f.read_bytes() == before                    # a query never changes the file


@settings(max_examples=examples(15), **SETTINGS)
@given(tables=st.lists(st.sampled_from(["events", "loadarm_meta", "other", "sample"]), max_size=3, unique=True),
       app_id=st.sampled_from([0, 0x4C41524D, 1, -1]),
       rows=st.lists(st.tuples(st.one_of(st.floats(allow_nan=True), st.text(max_size=4), st.none()),
                               st.sampled_from(["mode", "sample", "bogus"]), st.sampled_from(["{}", "{bad", "[]",
                                                                                              '{"beta": 1}'])),
                     max_size=4))
def test_foreign_and_damaged_sqlite_files_as_event_logs(capsys, fuzz_dir, tables, app_id, rows):
    f = fuzz_dir / "x.db"
    f.unlink(missing_ok=True)
    con = sqlite3.connect(f)
    con.execute(f"PRAGMA application_id = {app_id}")
    for t in tables:
        if t == "events":
            con.execute("CREATE TABLE events (id INTEGER PRIMARY KEY AUTOINCREMENT, run TEXT NOT NULL, t REAL, "
                        "wall TEXT NOT NULL, state TEXT NOT NULL, kind TEXT NOT NULL, reason TEXT NOT NULL, "
                        "data TEXT NOT NULL DEFAULT '{}')")
            for t_val, kind, data in rows:
                con.execute("INSERT INTO events (run, t, wall, state, kind, reason, data) VALUES "
                            "('r', ?, 'w', 'CONNECTED', ?, 'x', ?)", (t_val, kind, data))
        else:
            con.execute(f"CREATE TABLE {t} (key TEXT, value TEXT)")
    con.commit()
    con.close()
    before = f.read_bytes()
    check(capsys, "log", "--db", f, "--json", "--samples")
    assert f.read_bytes() == before


HEAVY = {"envelope": ("--png", "fig.png"), "loads": ("--json",), "mjcf": (), "balance": ("--json", "--spacing", "1.0"),
         "simulate": ("--json",), "verify": ("--json", "--samples", "21")}


@pytest.mark.slow
@pytest.mark.parametrize("command", sorted(HEAVY))
def test_every_other_command_on_mutated_installations(capsys, fuzz_dir, command):
    """The commands whose valid runs take a second or more, fewer cases each (slow: CI runs them)."""

    @settings(max_examples=examples(6), **SETTINGS)
    @given(data=mutated(PAPER))
    def inner(data):
        f = fuzz_dir / "inst.toml"
        f.write_text(_toml(data), encoding="utf-8")
        args = [a if a != "fig.png" else fuzz_dir / a for a in HEAVY[command]]
        check(capsys, command, "-c", f, *args)

    inner()


@pytest.mark.slow
def test_campaign_and_demo_on_hostile_files(capsys, fuzz_dir):
    """`campaign` (one seed, in this process) on mutated scenarios; `demo` on random bytes and broken text (its
    valid run is the whole report, which `make demo` exercises)."""

    @settings(max_examples=examples(6), **SETTINGS)
    @given(data=mutated(SCENARIO))
    def campaign(data):
        f = fuzz_dir / "scen.toml"
        f.write_text(_toml(_short(data)), encoding="utf-8")
        check(capsys, "campaign", "-s", f, "--seeds", "1", "--workers", "1", "--json")

    @settings(max_examples=examples(6), **SETTINGS)
    @given(blob=st.binary(max_size=512) | broken_text(PAPER_TOML.read_text()).map(lambda t: t.encode("utf-8",
                                                                                                     "surrogatepass")))
    def demo(blob):
        f = fuzz_dir / "demo.toml"
        f.write_bytes(blob)
        check(capsys, "demo", "-c", f, "--out", fuzz_dir / "out")

    campaign()
    demo()
