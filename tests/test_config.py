"""Configuration loading and validation: every bad-input path gives one clear line."""

import math
import re
import tomllib

import pytest

from loadarm.errors import ConfigError
from loadarm.params.config import Installation, load_config, parameter_table, parse_config

from .conftest import PAPER_TOML


def _data():
    return tomllib.loads(PAPER_TOML.read_text())


def test_example_file_is_the_paper_case(inst, paper):
    """examples/paper.toml is the paper's case; it adds only the scenarios its report runs."""
    assert inst.model_dump(exclude={"report"}) == paper.model_dump(exclude={"report"})
    assert inst.report.scenarios and paper.report.scenarios == ()
    from loadarm.present.report import is_paper_case
    assert is_paper_case(inst) and is_paper_case(paper)
    d = inst.model_dump()
    d["arm"]["outboard"] = 8.3
    assert not is_paper_case(parse_config(d))


def test_values_are_si_and_angles_convert(inst):
    assert inst.arm.inboard == 12.0
    assert inst.alarms.first == pytest.approx(123.0 * 3.141592653589793 / 180, rel=1e-15)
    assert inst.approach.stored == (3.82, 10.40)


@pytest.mark.parametrize("section,key,fragment", [
    ("arm", "inboard", "missing required key 'arm.inboard'"),
    ("datasheet", "A", "missing required key 'datasheet.A'"),
    ("approach", "flange", "missing required key 'approach.flange'"),
])
def test_missing_key(section, key, fragment):
    d = _data()
    del d[section][key]
    with pytest.raises(ConfigError) as e:
        parse_config(d, source="x.toml")
    msg = str(e.value)
    assert fragment in msg and "\n" not in msg


def test_missing_section():
    d = _data()
    del d["actuators"]
    with pytest.raises(ConfigError, match="missing required key 'actuators'"):
        parse_config(d)


@pytest.mark.parametrize("section,key,value,rng", [
    ("arm", "inboard", -3.0, "valid range (0, 100] m"),
    ("arm", "riser", 0.0, "valid range (0, 100] m"),
    ("datasheet", "B", -1.0, "valid range [0, 100] m"),
    ("actuators", "a1", 50.0, "valid range (0, 20] m"),
    ("actuators", "valve_range_V", 0.0, "valid range (0, 24] V"),
    ("approach", "max_speed", -0.1, "valid range [0.01, 2] m/s"),
    ("alarms", "first_deg", 200.0, "valid range (0, 180) deg"),
])
def test_out_of_range_names_key_value_and_range(section, key, value, rng):
    d = _data()
    d[section][key] = value
    with pytest.raises(ConfigError) as e:
        parse_config(d, source="f.toml")
    msg = str(e.value)
    assert msg.startswith("f.toml: ") and f"{section}.{key}" in msg and repr(value) in msg and rng in msg
    assert "\n" not in msg


def test_alarm_angles_out_of_order():
    d = _data()
    d["alarms"]["second_deg"] = 120.0
    with pytest.raises(ConfigError, match=r"alarm angles must increase: first_deg \(123.0\) < second_deg \(120.0\)"):
        parse_config(d)


def test_wrong_type_and_shape():
    d = _data()
    d["arm"]["inboard"] = "long"
    with pytest.raises(ConfigError, match="arm.inboard = 'long'"):
        parse_config(d)
    d = _data()
    d["approach"]["stored"] = [1.0]
    with pytest.raises(ConfigError, match="approach.stored"):
        parse_config(d)


def test_unknown_key_is_rejected_with_allowed_list():
    d = _data()
    d["arm"]["inbord"] = 12.0
    with pytest.raises(ConfigError, match=r"unknown key 'arm.inbord' \(did you mean 'inboard'\?\); allowed keys: "
                                          r"riser, inboard, outboard"):
        parse_config(d)


def test_typo_is_reported_before_the_key_it_hides():
    """Found: a typo 'inbord' was reported as "missing required key 'arm.inboard'", hiding the typo."""
    d = _data()
    d["arm"]["inbord"] = d["arm"].pop("inboard")
    with pytest.raises(ConfigError, match=r"unknown key 'arm.inbord' \(did you mean 'inboard'\?\)"):
        parse_config(d)
    d = _data()
    d["alarm"] = d.pop("alarms", {})
    with pytest.raises(ConfigError, match=r"unknown key 'alarm' \(did you mean 'alarms'\?\)"):
        parse_config(d)


def test_datasheet_d_below_c():
    d = _data()
    d["datasheet"]["D"] = 0.5
    with pytest.raises(ConfigError, match="datasheet.D"):
        parse_config(d)


def test_sizing_bounds_order():
    d = _data()
    d["sizing"]["inboard"] = [12.0, 8.0]
    with pytest.raises(ConfigError, match=r"sizing.inboard must be \[low, high\]"):
        parse_config(d)


def test_file_errors(tmp_path):
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[arm\nriser = 7")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(bad)
    with pytest.raises(ConfigError, match="must be a regular file, this is a directory"):
        load_config(tmp_path)


def test_optional_sections_default():
    d = _data()
    del d["alarms"], d["sizing"]
    inst = parse_config(d)
    assert (inst.alarms.first_deg, inst.alarms.second_deg, inst.alarms.release_deg) == (123.0, 143.0, 150.0)
    assert inst.sizing.inboard == (8.0, 12.0)


def test_models_are_frozen(inst):
    from pydantic import ValidationError
    with pytest.raises(ValidationError, match="frozen"):
        inst.arm.inboard = 3.0


def test_every_parameter_declares_unit_range_and_source():
    rows = parameter_table()
    assert len(rows) >= 30
    for r in rows:
        assert r["unit"], r
        assert r["source"], r
        assert r["description"], r
    keys = {r["key"] for r in rows}
    assert {"arm.riser", "alarms.first_deg", "actuators.volts_per_metre", "approach.max_accel"} <= keys
    assert set(Installation.model_fields) == {k.split(".")[0] for k in keys}


def test_non_finite_points_rejected():
    d = _data()
    d["approach"]["flange"] = [float("nan"), 1.0]
    with pytest.raises(ConfigError, match=r"approach.flange.0 = nan: Input should be a finite number"):
        parse_config(d)
    d = _data()
    d["approach"]["stored"] = [float("inf"), 1.0]
    with pytest.raises(ConfigError, match=r"approach.stored.0 = inf: Input should be a finite number"):
        parse_config(d)
    d = _data()
    d["approach"]["stored"] = [1500.0, 1.0]
    with pytest.raises(ConfigError, match=r"approach.stored must be two finite coordinates within"):
        parse_config(d)


def test_configuration_doc_is_up_to_date():
    from loadarm.params.config import parameter_markdown

    from .conftest import ROOT
    doc = (ROOT / "docs" / "configuration.md").read_text()
    assert parameter_markdown() in doc, "regenerate the table with: python -m loadarm.params.config"


def test_full_example_lists_every_key_and_equals_the_paper_case(paper):
    from loadarm.params.config import example_toml, load_config

    from .conftest import ROOT
    full = load_config(ROOT / "examples" / "full.toml")
    assert full == paper
    assert (ROOT / "examples" / "full.toml").read_text() == example_toml(), \
        "regenerate with: python -m loadarm.params.config --example > examples/full.toml"
    text = (ROOT / "examples" / "full.toml").read_text()
    for row in parameter_table():
        section, key = row["key"].split(".")
        body = text.split(f"[{section}]")[1]
        assert f"\n{key} = " in body or f"\n# {key} = (not set)" in body, row["key"]   # optional keys: commented


@pytest.mark.parametrize("key,value,rng", [("connect_motion_limit", -1.0, "valid range (0, 5] m"),
                                           ("connect_motion_limit", 6.0, "valid range (0, 5] m"),
                                           ("duration_per_state", 5.0, "valid range [10, 3600] s"),
                                           ("duration_per_state", 7200.0, "valid range [10, 3600] s")])
def test_operability_settings_are_declared_and_checked(key, value, rng):
    d = _data()
    d["operability"] = {key: value}
    with pytest.raises(ConfigError) as e:
        parse_config(d, source="f.toml")
    msg = str(e.value)
    assert msg.startswith("f.toml: ") and f"operability.{key}" in msg and rng in msg and "\n" not in msg


@pytest.mark.parametrize("key,value,rng", [("connect_motion_limit", -1.0, "(0, 5] m"),
                                           ("connect_motion_limit", 6.0, "(0, 5] m"),
                                           ("connect_motion_limit", math.nan, "(0, 5] m"),
                                           ("duration_per_state", 5.0, "[10, 3600] s"),
                                           ("duration_per_state", 7200.0, "[10, 3600] s")])
def test_operability_overrides_are_held_to_the_declared_ranges(key, value, rng):
    """OperabilitySettings (the command line's overrides) takes its ranges from the [operability] declaration
    (found: its own copy had no upper bound on connect_motion_limit, so 6 m passed), and the range ends pass."""
    from loadarm.params.declare import param_range
    from loadarm.params.sections import Operability
    from loadarm.studies.operability import OperabilitySettings

    with pytest.raises(ConfigError, match=re.escape(f"must be in {rng}, got")):
        OperabilitySettings(**{key: value})
    lo, lo_incl, hi, _, _ = param_range(Operability, key)
    assert getattr(OperabilitySettings(**{key: hi}), key) == hi
    if lo_incl:
        assert getattr(OperabilitySettings(**{key: lo}), key) == lo


def test_a_metocean_record_needs_a_berth():
    d = _data()
    d["report"] = {"metocean": "metocean/sample.csv"}
    with pytest.raises(ConfigError, match="metocean needs a berth") as e:
        parse_config(d, source="f.toml")
    assert "\n" not in str(e.value)
    d["report"]["berth"] = "berths/lng150k.toml"
    assert parse_config(d).report.metocean == "metocean/sample.csv"


def test_operability_settings_take_the_installation_s_unless_given():
    """`loadarm operability` without --duration-per-state takes the installation's [operability]; given, the
    flag wins; the connect limit always comes from the installation unless set in the API."""
    from loadarm.studies.operability import OperabilitySettings

    d = _data()
    d["operability"] = {"duration_per_state": 600.0, "connect_motion_limit": 0.8}
    sec = parse_config(d).operability
    assert OperabilitySettings().resolved(sec) == OperabilitySettings(600.0, 0.8, criteria=sec)
    assert OperabilitySettings(duration_per_state=60.0).resolved(sec) == OperabilitySettings(60.0, 0.8, criteria=sec)
    assert OperabilitySettings(connect_motion_limit=1.2, chunks=7).resolved(sec) == OperabilitySettings(
        600.0, 1.2, chunks=7, criteria=sec)
    assert sec.line_limit == 0.5 and sec.loading_hours == 14.0      # the terminal's criteria, with their defaults
    with pytest.raises(ValueError, match="resolved settings"):
        from loadarm.studies.operability import run_states

        run_states(None, None, None, [], OperabilitySettings(), 0.0, None)
