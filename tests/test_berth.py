"""The berth file (issue 12, item 1): the shipped example loads; every cross-check refuses in one line."""

from __future__ import annotations

import copy
import tomllib

import pytest

from loadarm.errors import ConfigError
from loadarm.params.berth import RHO_SEA, berth_parameter_markdown, load_berth, parse_berth

from .conftest import ROOT

EXAMPLE = ROOT / "examples" / "berths" / "lng150k.toml"
DATA = tomllib.loads(EXAMPLE.read_text())


def test_the_example_berth_loads_with_what_the_docs_say():
    b = load_berth(EXAMPLE)
    s = b.ship
    assert len(b.moorings) == 16 and len(b.fenders) == 4 and b.berth.water_depth == 20.0
    cb = s.displacement / (RHO_SEA * s.length_pp * s.beam * s.draft)
    from .test_doc_numbers import cited

    cited("docs/ship-motion.md", f"({s.length_pp:g} x {s.beam:g} x {s.draft:g} m, {s.displacement / 1e6:.0f} 000 t,")
    cited("docs/ship-motion.md", f"block coefficient {cb:.2f}")
    # lines pull towards the jetty side: every bollard lies behind the fender line
    assert all(m.bollard[0] <= 0 for m in b.moorings)


def _edit(path: str, value, data=None):
    d = copy.deepcopy(DATA if data is None else data)
    node = d
    keys = path.split(".")
    for k in keys[:-1]:
        node = node[int(k)] if k.isdigit() else node[k]
    last = keys[-1]
    if value is KeyError:
        del node[last]
    else:
        node[last] = value
    return d


@pytest.mark.parametrize("path,value,expect", [
    ("ship.depth", 11.0, "ship.draft = 11.5 m must be below ship.depth = 11 m"),
    ("ship.displacement", 50e6, "block coefficient of 0.352"),
    ("ship.manifold", [0.0, 30.0, 28.0], "ship.manifold = [0.0, 30.0, 28.0] m must lie on the hull"),
    ("ship.beam", "43.4", "ship.beam = '43.4'"),
    ("ship.beam", 5.0, "valid range [10, 70] m"),
    ("ship.lenght_pp", 278.0, "did you mean 'length_pp'"),
    ("berth.water_depth", 11.0, "no water under the keel"),
    ("berth.side", "aft", "berth.side = 'aft'"),
    ("moorings.0.pretension", 600e3, "pretension = 600000 N must be below 55 % of the MBL"),
    ("moorings.0.bollard", [5.0, 190.0, 8.0], "lies on the water side of the fender line"),
    ("moorings.0.fairlead", [135.0, 40.0, 26.0], "lies off the ship"),
    ("moorings.1.name", "head 1", "moorings: names must be unique, head 1 repeated"),
    ("fenders.0.load", [0.0, 3.8e5, 7.6e5, 1.1e6, 1.42e6, 1.68e6, 1.86e6, 1.96e6, 2e6, 1.9e6, 2.5e6, 4e6],
     "never fall in load"),
    ("fenders.0.rated_deflection", 1.5, "rated_deflection 1.5 m lies past the load curve's last deflection 1.35 m"),
    ("fenders.0.friction", 0.9, "less than or equal to 0.6"),
    ("fenders.0.deflection", [0.0, 0.5], "the same number (>= 2) of points"),
    ("environment.spreading", float("nan"), "environment.spreading = nan"),
])
def test_each_cross_check_refuses_in_one_line(path, value, expect):
    with pytest.raises(ConfigError) as exc:
        parse_berth(_edit(path, value), source="b.toml")
    msg = str(exc.value)
    assert msg.startswith("b.toml: ") and "\n" not in msg and expect in msg, msg


def test_moorings_and_fenders_are_required():
    with pytest.raises(ConfigError, match="missing required key 'moorings'"):
        parse_berth(_edit("moorings", KeyError))
    d = _edit("fenders", DATA["fenders"][:1])
    with pytest.raises(ConfigError, match="fenders"):
        parse_berth(d)


def test_the_cli_refuses_a_bad_berth_file_like_any_input(tmp_path):
    """Read through the same input layer (regular files, 1 MiB, depth)."""
    with pytest.raises(ConfigError, match="berth file must be a regular file"):
        load_berth(tmp_path)


def test_ship_motion_doc_table_is_up_to_date():
    doc = (ROOT / "docs" / "ship-motion.md").read_text()
    assert berth_parameter_markdown() in doc, "regenerate with: python -m loadarm.present.docsgen"
