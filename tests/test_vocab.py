"""The one safety vocabulary (loadarm.vocab): the faces' words held to the geometry, the alarms and the actions
declared once and served alike by the screen and the OPC UA server."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from loadarm.arm.faces import face_margins
from loadarm.vocab import (
    ACTION_TABLE,
    ANNUNCIATED,
    BANK_FACE_TABLE,
    COMMANDS,
    CONDITIONS,
    FACE_LABELS,
    FACE_TABLE,
    FACES,
    METHODS,
    Role,
    Severity,
    priority,
)

from .hypo import examples

SRC = Path(__file__).resolve().parents[1] / "src" / "loadarm"
#: A flange displacement small against the arm, large against rounding: 1 mm.
STEP = 1e-3


@settings(max_examples=examples(300), deadline=None)
@given(st.tuples(*[st.floats(0.0, 1.0)] * 3))
def test_each_faces_words_say_which_flange_motion_brings_it_nearer(inst, model, fractions):
    """Moving the flange the way a face's words say (up for "too high", out for "too far out", along +y for
    "+y") shrinks that face's margin, wherever the ship can present its flange: the datasheet's flange box
    (paper Table 1), along the berth as far as the slew allows, inside the attached envelope. Found: the words
    of alpha_max and alpha_min were swapped (alpha is measured from the upward vertical and is largest at the
    lowest flange); this fails on them. (Far above the box, with the outboard arm raised, alpha's sense
    against the flange's height turns: the words describe the berth, not every pose.)"""
    from loadarm.arm.envelope import berth_box

    box = berth_box(inst.datasheet)
    fx, fy, fz = fractions
    p = np.array([box.x_near + fx * (box.x_far - box.x_near), (2 * fy - 1) * 10.0,
                  box.y_low + fz * (box.y_high - box.y_low)])
    m0 = face_margins(model, *p)
    assume(np.all(m0 > 1e-6))
    pivot = np.array([0.0, 0.0, model.arm.a])
    for i, face in enumerate(FACE_TABLE):
        if face.radial:
            d = face.radial * (p - pivot) / np.linalg.norm(p - pivot)
        else:
            d = np.asarray(face.towards)
        m1 = face_margins(model, *(p + STEP * d))
        assert m1[i] < m0[i], (face.name, face.words, p, m0[i], m1[i])


def test_the_words_match_their_direction(model):
    """The words and the declared direction agree: "too high" goes up, "too low" down, "+y" along +y."""
    for f in FACE_TABLE:
        w = f.words
        if "too high" in w:
            assert f.towards[2] > 0
        if "too low" in w:
            assert f.towards[2] < 0
        if "too far out" in w:
            assert f.radial > 0
        if "too close in" in w:
            assert f.radial < 0
        if w.endswith("+y"):
            assert f.towards[1] > 0
        if w.endswith("-y"):
            assert f.towards[1] < 0
    assert FACES == ("beta_max", "beta_min", "alpha_max", "alpha_min", "slew_pos", "slew_neg")
    assert "too low" in FACE_LABELS["alpha_max"] and "too high" in FACE_LABELS["alpha_min"]


def test_every_alarm_stage_is_annunciated_once_and_more_severe_stages_rank_higher():
    stages = [c.stage for c in CONDITIONS if c.stage is not None]
    assert stages == [s for s in Severity if s != Severity.NORMAL]
    assert len(set(ANNUNCIATED)) == len(ANNUNCIATED)
    sev = [c.severity for c in CONDITIONS if c.stage is not None]
    assert sev == sorted(sev) and len(set(sev)) == len(sev)
    assert priority("RELEASE") == (1, "critical") and priority("PRE_ALARM") == (4, "low")
    assert all(1 <= c.severity <= 1000 and c.text for c in CONDITIONS)


def test_one_role_table_for_the_screen_and_the_opc_ua_methods():
    """The screen's commands and the OPC UA methods both come from the action table; a viewer's one request
    is ESD-1, on both."""
    from loadarm.opcua.server import METHODS as SERVED

    assert {n for n, r in COMMANDS.items() if r == Role.VIEWER} == {"esd"}
    assert [m[:3] for m in SERVED] == [m[:3] for m in METHODS]
    viewer_methods = [a.method for a in ACTION_TABLE if a.method and a.role == Role.VIEWER]
    assert viewer_methods == ["ManualESD1"]
    assert "{" not in "".join(m[3] for m in SERVED)              # every placeholder filled in


_TABLE_NAMES = {"FACES", "FACE_LABELS", "FACE_WORDS", "ANNUNCIATED", "CONDITION_SEVERITY", "CONDITION_TEXT",
                "COMMANDS", "ACTIONS", "METHODS", "PRIORITIES"}


def _literal_strings(node) -> list[str]:
    return [n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)]


def test_no_module_but_the_vocabulary_declares_a_face_text_an_alarm_text_or_an_action_table():
    """A second declaration fails here: a literal table under one of the vocabulary's names, or a face's words
    or an alarm's text written out, anywhere in the package but loadarm/vocab.py."""
    faces = FACE_TABLE + BANK_FACE_TABLE
    texts = {f.words for f in faces} | {f.detail for f in faces} | {c.text for c in CONDITIONS}
    found = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "vocab.py" and path.parent == SRC:
            continue
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                names = {t.id for t in targets if isinstance(t, ast.Name)}
                if names & _TABLE_NAMES and isinstance(node.value, (ast.Tuple, ast.Dict, ast.List)) \
                        and _literal_strings(node.value):
                    found.append(f"{path.relative_to(SRC)}:{node.lineno} declares {sorted(names & _TABLE_NAMES)}")
        for s in _literal_strings(tree):
            for t in texts:
                if t in s:
                    found.append(f"{path.relative_to(SRC)} writes out {t!r}")
    assert not found, found


def test_the_vocabulary_checks_itself_on_a_bad_role():
    from loadarm.errors import ConfigError

    assert Role.parse("Operator") == Role.OPERATOR
    with pytest.raises(ConfigError, match="unknown role 'boss'; one of viewer, operator, engineer"):
        Role.parse("boss")
    assert math.isfinite(float(Role.ENGINEER))


@pytest.mark.slow                      # a 260 s drift-off: about 15 s on 2 cores
def test_a_run_reads_its_events_by_code_so_rewording_changes_no_metric():
    """Found (issue 26): the headline metrics were found by searching the events' text, so rewording a message
    turned a metric into "-". Every event's text replaced, the drift-off's metrics and verdict stay; every
    stage and release event carries a declared code."""
    import dataclasses

    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario
    from loadarm.vocab import EVENTS

    from .conftest import PAPER_TOML

    sc, model = load_scenario(PAPER_TOML.parent / "scenarios" / "driftoff.toml")
    r = run_scenario(sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": 260.0})}), model)
    codes = [d.get("code") for _, _, k, _, d in r.events if k in ("alarm", "interlock") or d.get("code")]
    assert set(codes) <= set(EVENTS) and {"stage.esd1", "stage.release", "interlock.valves_confirmed",
                                          "command.coupler_opening", "command.release_complete"} <= set(codes)
    reworded = dataclasses.replace(r, events=[(t, m, k, "reworded", d) for t, m, k, _, d in r.events])
    a, b = r.to_dict(), reworded.to_dict()
    assert a == b and a["alarm1_s"] is not None and a["release_complete_s"] is not None
    assert a["valves_confirmed_s"] <= a["coupler_opening_s"] < a["release_complete_s"]


def test_importing_the_figures_chooses_no_backend():
    """Found (issue 26): the figure module (then ``loadarm.plotting``) called ``matplotlib.use("Agg")`` on import, overriding a notebook
    user's backend. A user's backend stays theirs, and a figure still saves without a screen."""
    import subprocess
    import sys

    code = ("import matplotlib; matplotlib.use('svg'); import loadarm.figures as p, loadarm.present.report; "
            "import loadarm.design.plots, loadarm.sim.plots, loadarm.studies.plots, loadarm.hydraulics.plots; "
            "import io; fig, ax = p.subplots(figsize=(2, 2)); ax.plot([0, 1]); b = io.BytesIO(); "
            "fig.savefig(b, format='png'); assert b.getvalue()[:4] == b'\\x89PNG'; print(matplotlib.get_backend())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "svg", out.stderr


def test_the_shared_alarm_rules_are_alarm_rules_the_prediction_does_not_act_in():
    """The rules a campaign counts as today's too (``SHARED_ALARM_RULES``) are declared rules, and none of those
    the prediction changes (its own, the measured routes it holds and their hold limit)."""
    from loadarm.vocab import ALARM_RULES, SHARED_ALARM_RULES

    assert SHARED_ALARM_RULES <= ALARM_RULES.keys()
    assert not SHARED_ALARM_RULES & {"prediction", "measured", "hold_limit"}
