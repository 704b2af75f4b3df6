"""The operability study: the batched kernel against its routes and against `loadarm run`, the Dask driver."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from loadarm.arm.faces import breakout_distance, face_margins, first_face, ray_crossing
from loadarm.params.compiler import compile_model
from loadarm.params.berth import load_berth
from loadarm.params.config import load_config
from loadarm.ship.model import compile_ship
from loadarm.studies.kernel import _DIRS, breakout_time, floor_table, monitor_record

from .conftest import ROOT, stop_process_groups
from .hypo import examples

PAPER = ROOT / "examples" / "paper.toml"
BERTH = ROOT / "examples" / "berths" / "lng150k.toml"


@pytest.fixture(scope="module")
def model():
    return compile_model(load_config(PAPER))


@pytest.fixture(scope="module")
def table(model):
    fx, fz = model.approach.flange
    return floor_table(model, [fx - 2.5, -2.5, fz - 3.0], [fx + 2.5, 2.5, fz + 3.0])


@settings(max_examples=examples(200), deadline=None)
@given(d=st.floats(0.0, 50.0), v=st.floats(0.01, 1.0), a=st.floats(0.001, 0.5))
def test_breakout_time_inverts_breakout_distance(d, v, a):
    t = float(breakout_time(d, v, a))
    assert float(breakout_distance(t, v, a)) == pytest.approx(d, rel=1e-9, abs=1e-9)


def test_the_table_s_ray_distances_match_direct_ray_casting(model, table):
    """At grid points, every direction: the tabulated distance against faces.ray_crossing (a second route,
    0.01 m marching and bisection), within 2 mm (both bisect to about 1 mm)."""
    rng = np.random.default_rng(3)
    shape = np.array(table.dist.shape[:3])

    def outside(pts):
        return first_face(face_margins(model, pts[:, 0], pts[:, 1], pts[:, 2]))[0]

    for _ in range(12):
        idx = rng.integers(0, shape)
        p = table.origin + table.spacing * idx
        for j, d in enumerate(_DIRS):
            cap = table.cap if j < 8 else table.cap_v
            direct = ray_crossing(p, d, outside)
            want = cap if direct is None or direct > cap else direct
            assert table.dist[tuple(idx) + (j,)] == pytest.approx(want, abs=2e-3), (p, d)


def _record(p0, v, a, n, dt=0.1):
    t = np.arange(n) * dt
    return np.asarray(p0) + np.outer(breakout_distance(t, v, a), [1.0, 0.0, 0.0])


def test_a_still_flange_raises_nothing(model, table):
    fx, fz = model.approach.flange
    r = monitor_record(model, table, np.tile([fx, 0.0, fz], (600, 1)), 0.1)
    assert r.stage == 0 and math.isnan(r.esd1_s) and math.isnan(r.release_s) and not r.outside


def test_a_breakout_runs_the_whole_sequence(model):
    """The flange breaking out off the berth at the design drift: ESD-1 as soon as the time to the face is the
    ESD-1 lead, the release once the valves have had their time and the time to the face is the release's."""
    fx, fz = model.approach.flange
    dd, seq = model.design_drift, model.sequence
    wide = floor_table(model, [fx - 1.0, -1.0, fz - 1.0], [fx + 6.0, 1.0, fz + 1.0])
    p = _record([fx, 0.0, fz], dd.speed, dd.acceleration, 400)
    r = monitor_record(model, wide, p, 0.1)
    assert r.stage == 4
    assert r.release_s >= r.esd1_s + seq.ers_valve_time - 1e-9
    assert r.min_time_to_limit_s < seq.ers_valve_time


def test_position_alarms_come_from_the_angles():
    """A flange held just past the customer's first-alarm beta raises ESD-1 at once, with a design drift so slow
    (0.02 m/s at 0.001 m/s^2: 0.5 m in the ESD-1 lead) that the floor alone would stay quiet there."""
    from loadarm.arm.slew import inverse3d
    from loadarm.params.config import parse_config, read_toml

    data = read_toml(PAPER)
    data["design_drift"] = {"speed": 0.02, "acceleration": 0.001, "vertical_speed": 0.001}
    slow = compile_model(parse_config(data, source="slow"))
    fx, fz = slow.approach.flange

    def beta_at(s):
        return float(inverse3d(slow.arm, fx + s, 0.0, fz, check=False).beta)

    lo, hi = 0.0, 5.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if beta_at(mid) < slow.alarms.first + math.radians(0.5) else (lo, mid)
    p = np.array([fx + hi, 0.0, fz])
    tab = floor_table(slow, p - 0.5, p + 0.5)
    r = monitor_record(slow, tab, np.tile(p, (50, 1)), 0.1)
    assert r.stage == 2 and r.esd1_s == 0.0 and r.min_time_to_limit_s == math.inf
    r0 = monitor_record(slow, tab, np.tile(p - [0.3, 0.0, 0.0], (50, 1)), 0.1)
    assert r0.stage == 0


def test_positions_beyond_the_table_are_cast_directly(model, table):
    """Found: a storm hour of the shipped sample moved the flange beyond the table's box and failed its chunk.
    Positions beyond the table now get their rays cast directly: the same result as a table that covers them."""
    fx, fz = model.approach.flange
    p = np.array([[fx + 3.0, 0.3, fz + 0.5], [fx, 0.0, fz]])
    assert not table.inside(p).all()
    wide = floor_table(model, [fx - 1.0, -1.0, fz - 1.0], [fx + 4.0, 1.0, fz + 1.0])
    a = monitor_record(model, table, np.repeat(p, 5, axis=0), 0.1)
    b = monitor_record(model, wide, np.repeat(p, 5, axis=0), 0.1)
    assert a.stage == b.stage and a.min_time_to_limit_s == pytest.approx(b.min_time_to_limit_s, abs=0.05)


def test_chunks_cover_every_state_once():
    from loadarm.studies.operability import plan_chunks

    for n, k in ((1, 100), (48, 8), (8760, 100), (7, 3)):
        c = plan_chunks(n, k)
        assert c[0][0] == 0 and c[-1][1] == n and all(a < b for a, b in c)
        assert all(c[i][1] == c[i + 1][0] for i in range(len(c) - 1)) and len(c) == min(n, k)


#: The kernel judges a record by the position alarms and the design-drift floor; the loop's monitor also fits
#: the measured drift over its window. On the lines of issue 28 the moored ship's slow motion (47-95 s) is large
#: enough in Hs 2-2.5 m for the measured drift to raise a stage the kernel does not (Hs 2.5 m at the nominal
#: flange: ESD-1 in the loop, the kernel's least time to a face 36.6 s against a 35 s lead; Hs 2 m near the
#: first alarm: alarm 2 in the loop, "beta_max face in 7.0 s", the kernel's least 18 s). The kernel is
#: optimistic there until it carries the monitor's forecast (issue 30, item 5: everywhere the monitor is);
#: strict, so that the day they agree again the marks must go.
_MEASURED_DRIFT = pytest.mark.xfail(strict=True, reason="the kernel has no measured-drift rule (issue 30)")


@pytest.mark.slow
@pytest.mark.parametrize("flange, hs, seed", [((13.0, 1.0, 0.5), 1.0, 7),
                                             pytest.param((13.0, 1.0, 0.5), 2.5, 8, marks=_MEASURED_DRIFT),
                                             ((15.5, 0.0, 0.5), 1.5, 9),
                                             pytest.param((16.5, 0.5, 1.0), 2.0, 10, marks=_MEASURED_DRIFT)])
def test_the_kernel_agrees_with_loadarm_run(flange, hs, seed):
    """Issue 13, item 3: the same sea state, the same seed, the full closed loop (`loadarm run`, kinematic plant)
    against the batched kernel on the same flange motion from the connection on: the same alarm stage, the same
    largest beta within 0.1 deg (measured: 0.001 deg), ESD-1 within 0.1 s (measured: 0.02 s). The four states
    were chosen before running: calm and rough at the nominal flange, and two flanges near the first alarm
    (two of them fail on the real lines of issue 28: :data:`_MEASURED_DRIFT`)."""
    from loadarm.params.scenario import load_scenario
    from loadarm.ship.flange import flange_motion
    from loadarm.ship.model import moored_ship
    from loadarm.sim.loop import run_scenario

    sc0, model = load_scenario(ROOT / "examples" / "scenarios" / "hs15_moored.toml")
    d = sc0.model_dump()
    d["ship"]["flange"] = flange
    d["environment"]["hs"] = hs
    d["scenario"].update(seed=seed, duration=600.0, plant="kinematic")
    sc = sc0.model_validate(d)
    ship = moored_ship(sc)
    r = run_scenario(sc, model, ship=ship)
    s = r.summary()
    conn = np.flatnonzero(r.signals["connected"] > 0)
    tc = float(r.signals["t"][conn[0]])
    tt = np.arange(math.ceil(tc / 0.1) * 0.1, 600.0 + 1e-9, 0.1)
    p = flange_motion(sc, ship).position(tt)
    k = monitor_record(model, floor_table(model, p.min(0) - 0.3, p.max(0) + 0.3), p, 0.1)
    stage = 4 if s["release_s"] is not None else 3 if s["alarm2_s"] is not None else 2 if s["alarm1_s"] else 0
    assert k.stage == stage
    assert k.max_beta_deg == pytest.approx(s["max_beta_deg"], abs=0.1)
    if stage:
        assert tt[0] + k.esd1_s == pytest.approx(s["alarm1_s"], abs=0.1)


def _tiny_record(tmp_path, hours=12):
    from loadarm.studies.metocean import synthetic_metocean, write_metocean_csv

    return write_metocean_csv(synthetic_metocean(hours, seed=5), tmp_path / "m.csv")


@pytest.mark.slow
def test_operability_on_a_local_cluster_writes_chunks_and_resumes(tmp_path):
    """Twelve hours, 60 s each, four chunks on a two-worker local cluster; then one chunk removed: the second run
    recomputes that chunk only and gives the same table."""
    import os

    import pandas as pd

    from loadarm.studies.operability import OperabilitySettings, run_operability

    rec = _tiny_record(tmp_path)
    out = tmp_path / "r.parquet"
    st_ = OperabilitySettings(duration_per_state=60.0, chunks=4)
    first = run_operability(PAPER, BERTH, rec, out, settings=st_, workers=2)
    chunks = sorted((tmp_path / "r.parquet.chunks").glob("chunk-*.parquet"))
    assert len(chunks) == 4 and len(first.table) == 12 and first.workers == 2
    d = first.to_dict()
    assert 0.0 <= d["downtime_fraction"] <= 1.0 and d["states"] == 12
    stamps = {c.name: c.stat().st_mtime_ns for c in chunks}
    os.remove(chunks[2])
    second = run_operability(PAPER, BERTH, rec, out, settings=st_, workers=2)
    again = sorted((tmp_path / "r.parquet.chunks").glob("chunk-*.parquet"))
    assert [c.name for c in again] == [c.name for c in chunks]
    for c in again:
        if c.name != chunks[2].name:
            assert c.stat().st_mtime_ns == stamps[c.name], "finished chunks are not recomputed"
    pd.testing.assert_frame_equal(first.table, second.table)
    assert pd.read_parquet(out).shape == (12, len(first.table.columns))


@pytest.mark.slow
def test_a_real_dask_cluster_on_loopback_survives_a_killed_worker(tmp_path):
    """`dask scheduler` and two `dask worker` processes on loopback (ephemeral ports, no dashboard), the
    command line pointed at them with --scheduler; one worker is killed (SIGKILL) once the first chunk is
    written: its tasks go to the other worker, nothing finished is lost, every state is in the result. Every
    process started here is stopped here."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time

    import pandas as pd

    rec = _tiny_record(tmp_path, hours=48)
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "src"))
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    sfile = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen(dask + ["--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                              "--dashboard-address", "127.0.0.1:0",
                                              "--scheduler-file", str(sfile)], env=env, cwd=tmp_path,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        for _ in range(300):
            if sfile.is_file() and sfile.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(sfile.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for _ in range(2):
            procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                           "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                                          env=env, cwd=tmp_path, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, start_new_session=True))
        out = tmp_path / "r.parquet"
        run = subprocess.Popen([sys.executable, "-m", "loadarm.cli", "operability", "--config", str(PAPER),
                                "--berth", str(BERTH), "--metocean", str(rec), "--duration-per-state", "3600",
                                "--chunks", "12", "--scheduler", address, "--out", str(out), "--json"],
                               env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        chunks = tmp_path / "r.parquet.chunks"
        for _ in range(1200):
            if chunks.is_dir() and any(chunks.glob("chunk-*.parquet")):
                break
            time.sleep(0.1)
        done_at_kill = len(list(chunks.glob("chunk-*.parquet")))
        os.killpg(procs[1].pid, signal.SIGKILL)
        stdout, stderr = run.communicate(timeout=600)
        assert 1 <= done_at_kill < 12, "the worker was killed mid-run"
        assert run.returncode == 0, stderr
        result = json.loads(stdout)
        assert result["states"] == 48 and result["workers"] >= 1
        assert len(list(chunks.glob("chunk-*.parquet"))) == 12
        assert len(pd.read_parquet(out)) == 48
    finally:
        stop_process_groups(procs)


def test_results_are_marked_and_a_rerun_may_replace_them(tmp_path):
    """Found: a second run of the same command (to resume) was refused, its own Parquet output not recognised
    as loadarm's. Parquet written here carries the generator in its metadata."""
    import pandas as pd

    from loadarm.files import written_by_loadarm
    from loadarm.studies.operability import write_parquet

    p = write_parquet(pd.DataFrame({"a": [1.0, 2.0]}), tmp_path / "r.parquet")
    assert written_by_loadarm(p)
    other = tmp_path / "o.parquet"
    pd.DataFrame({"a": [1.0]}).to_parquet(other)
    assert not written_by_loadarm(other)
    assert pd.read_parquet(p)["a"].tolist() == [1.0, 2.0]


def test_chunks_of_another_run_are_refused_or_discarded(tmp_path):
    """Resuming is for the same run only: chunks made from other inputs or settings would mix two studies."""
    from loadarm.errors import ConfigError
    from loadarm.studies.operability import _check_manifest

    d = tmp_path / "r.parquet.chunks"
    _check_manifest(d, "aaa", False)
    (d / "chunk-00000.parquet").write_bytes(b"x")
    _check_manifest(d, "aaa", False)                       # the same run: kept
    assert (d / "chunk-00000.parquet").is_file()
    with pytest.raises(ConfigError, match="from another run"):
        _check_manifest(d, "bbb", False)
    assert (d / "chunk-00000.parquet").is_file()
    _check_manifest(d, "bbb", True)                        # --force: start again
    assert not (d / "chunk-00000.parquet").exists() and (d / "MANIFEST").read_text().strip() == "bbb"


def test_the_manifest_follows_the_inputs_the_settings_and_the_code(tmp_path, monkeypatch):
    """Found: the manifest hashed the inputs and the version number, so chunks computed by an older kernel of the
    same version would have been resumed into a newer run. Any of the inputs, the settings or a module's source
    changes it."""
    import loadarm.studies.operability as op

    met = tmp_path / "m.csv"
    met.write_text("x")
    st_ = op.OperabilitySettings(duration_per_state=600.0, connect_motion_limit=1.0)
    base = op._manifest(PAPER, BERTH, met, None, st_, [(0, 1)])
    assert base == op._manifest(PAPER, BERTH, met, None, st_, [(0, 1)])
    met.write_text("y")
    assert op._manifest(PAPER, BERTH, met, None, st_, [(0, 1)]) != base
    met.write_text("x")
    assert op._manifest(PAPER, BERTH, met, 10, st_, [(0, 1)]) != base
    wider = op.OperabilitySettings(duration_per_state=600.0, connect_motion_limit=1.5)
    assert op._manifest(PAPER, BERTH, met, None, wider, [(0, 1)]) != base
    real = Path.read_bytes
    kernel = Path(op.__file__).resolve().parent / "kernel.py"
    monkeypatch.setattr(Path, "read_bytes",
                        lambda self: real(self) + (b"# changed" if self.resolve() == kernel else b""))
    assert op._manifest(PAPER, BERTH, met, None, st_, [(0, 1)]) != base


# --------------------------------------------------------------------------- the compiled passes against their originals

_angles = st.one_of(st.floats(-4.0, 4.0), st.just(float("nan")))


@settings(max_examples=examples(300), deadline=None)
@given(beta=st.lists(_angles, min_size=1, max_size=40), phi=st.lists(st.floats(-3.2, 3.2), min_size=1, max_size=40),
       alpha=st.lists(st.floats(-3.2, 3.2), min_size=1, max_size=40), near=st.booleans())
def test_the_compiled_levels_and_faces_are_the_vectorised_rules(model, beta, phi, alpha, near):
    """The per-sample pass (kernel._samples, compiling alarms.zone_level and faces.past_a_face) gives exactly the
    levels of beta_severity and slew_severity (unreachable: release) and the faces of face_margins/first_face,
    including angles on a threshold (``near``: the samples put on the thresholds and limits themselves)."""
    from loadarm.arm.alarms import beta_severity, slew_severity
    from loadarm.studies.kernel import _samples
    from loadarm.vocab import Severity

    al, sl, lim = model.alarms, model.slew, model.joint_limits
    n = min(len(beta), len(phi), len(alpha))
    b, f, a = (np.array(x[:n], dtype=float) for x in (beta, phi, alpha))
    if near:
        edges_b = [al.first, al.second, al.release, al.release - 1e-9, al.first + 1e-9, *lim.beta]
        edges_f = [sl.first, -sl.second, sl.release, *lim.phi]
        b[: min(n, len(edges_b))] = edges_b[:n]
        f[: min(n, len(edges_f))] = edges_f[:n]
        a[: min(n, 2)] = list(lim.alpha)[:n]
    level, ttl, ins = np.empty(n, dtype=np.int64), np.empty(n), np.empty(n, dtype=np.bool_)
    zero = np.zeros(n)
    bmax, smax, outside, _, _ = _samples(f, a, b, zero, zero, zero, (al.first, al.second, al.release),
                                         (sl.first, sl.second, sl.release), tuple(map(float, lim.phi)),
                                         tuple(map(float, lim.alpha)), tuple(map(float, lim.beta)),
                                         np.ones((2, 2, 2, 2)), np.zeros(3), 1.0, (5.0, 5.0, 0.15, 0.02, 0.1),
                                         level, ttl, ins)
    bs = beta_severity(b, al)
    want = np.where(bs < 0, int(Severity.RELEASE), np.maximum(bs, slew_severity(f, sl)))
    assert np.array_equal(level, want)
    # face_margins takes positions; its rule on the joints: the margins it stacks from phi, alpha, beta
    m = np.stack([lim.beta[1] - b, b - lim.beta[0], lim.alpha[1] - a, a - lim.alpha[0], lim.phi[1] - f,
                  f - lim.phi[0]], axis=-1)
    m[np.isnan(b)] = -np.inf
    assert outside == bool(first_face(m)[0].any())
    assert (math.isnan(bmax) and np.isnan(b).all()) or bmax == np.nanmax(b)
    assert smax == np.max(np.abs(f))


def test_past_a_face_is_face_margins_on_positions(model):
    """The scalar face rule on the joints of 2000 positions around the nominal flange (some beyond every face,
    some out of reach) against face_margins/first_face on the same positions."""
    from loadarm.arm.faces import past_a_face
    from loadarm.arm.slew import inverse3d

    rng = np.random.default_rng(3)
    fx, fz = model.approach.flange
    p = np.array([fx, 0.0, fz]) + rng.uniform(-1, 1, (2000, 3)) * [12.0, 12.0, 12.0]
    q = inverse3d(model.arm, p[:, 0], p[:, 1], p[:, 2], check=False)
    lim = model.joint_limits
    got = np.array([past_a_face(f, a, b, lim.phi, lim.alpha, lim.beta) for f, a, b in zip(q.phi, q.alpha, q.beta)])
    want = first_face(face_margins(model, p[:, 0], p[:, 1], p[:, 2]))[0]
    assert 100 < want.sum() < 1900 and np.array_equal(got, want)
    # the same rule on arrays, as the envelope's ray marches take it
    from loadarm.arm.faces import past_a_face_at

    assert np.array_equal(past_a_face_at(model, p[:, 0], p[:, 1], p[:, 2]), want)
    # and on the faces themselves: joints at their limits, a margin of exactly zero (inside)
    from loadarm.arm.slew import forward3d

    edge = np.array(np.meshgrid(lim.phi, lim.alpha, lim.beta, indexing="ij")).reshape(3, -1)
    x, y, z = forward3d(model.arm, *edge)
    q = inverse3d(model.arm, x, y, z, check=False)
    exact = np.array([past_a_face(f, a, b, lim.phi, lim.alpha, lim.beta) for f, a, b in zip(q.phi, q.alpha, q.beta)])
    assert np.array_equal(past_a_face_at(model, x, y, z), first_face(face_margins(model, x, y, z))[0])
    assert np.array_equal(exact, first_face(face_margins(model, x, y, z))[0])


@settings(max_examples=examples(100), deadline=None)
@given(seed=st.integers(0, 2**31), spacing=st.floats(0.05, 1.0), shape=st.tuples(*[st.integers(2, 7)] * 3))
def test_the_compiled_table_lookup_is_map_coordinates(seed, spacing, shape):
    """FloorTable.lookup (one compiled trilinear pass) against scipy's map_coordinates (order 1, nearest) on the
    least horizontal and vertical distances, and the box test, over points inside, on the edges and beyond
    (to 1e-12 m: the same interpolation, operations in another order)."""
    from scipy.ndimage import map_coordinates

    from loadarm.studies.kernel import FloorTable

    rng = np.random.default_rng(seed)
    dist = rng.uniform(0.0, 5.0, (*shape, 10))
    t = FloorTable(rng.uniform(-5, 5, 3), spacing, dist, 5.0, 5.0)
    hi = t.origin + spacing * (np.array(shape) - 1)
    p = t.origin + rng.uniform(-0.2, 1.2, (300, 3)) * (hi - t.origin)
    p[:8] = [t.origin, hi, t.origin - 1e-10, hi + 1e-10, t.origin - 1e-8, hi + 1e-8, (t.origin + hi) / 2,
             [hi[0], t.origin[1], hi[2]]]
    h, v, ins = t.lookup(p)
    idx = ((p - t.origin) / spacing).T
    for got, part in ((h, dist[..., :8]), (v, dist[..., 8:])):
        assert np.allclose(got, map_coordinates(part.min(axis=-1), idx, order=1, mode="nearest"), rtol=0, atol=1e-12)
    assert np.array_equal(ins, np.all((p >= t.origin - 1e-9) & (p <= hi + 1e-9), axis=1))
    assert ins[:4].all() and not ins[4:6].any()


@settings(max_examples=examples(100), deadline=None)
@given(seed=st.integers(0, 2**31), spacing=st.floats(0.05, 1.0), shape=st.tuples(*[st.integers(2, 7)] * 3),
       speed=st.floats(0.01, 2.0), accel=st.floats(1e-3, 1.0), vspeed=st.floats(0.01, 1.0))
def test_the_compiled_pass_s_time_to_limit_is_the_vectorised_route(seed, spacing, shape, speed, accel, vspeed):
    """The one compiled per-sample pass (kernel._samples) gives the design-drift time to a face of the
    vectorised route: the table's least distances (FloorTable.lookup) through breakout_time and the vertical
    speed, a distance at its cap beyond every lead (inf); bit for bit (the same operations on the same
    values), the z range too, over points inside the table, on its edges and beyond it."""
    from loadarm.studies.kernel import FloorTable, _samples

    rng = np.random.default_rng(seed)
    dist = rng.uniform(0.0, 5.0, (*shape, 10))
    dist[0, 0, 0, :] = 5.0                                      # a grid point at the caps
    t = FloorTable(rng.uniform(-5, 5, 3), spacing, dist, 5.0, 4.0)
    hi = t.origin + spacing * (np.array(shape) - 1)
    p = t.origin + rng.uniform(-0.2, 1.2, (300, 3)) * (hi - t.origin)
    p[:3] = [t.origin, hi, t.origin - 1.0]
    n = p.shape[0]
    level, ttl, ins = np.empty(n, dtype=np.int64), np.empty(n), np.empty(n, dtype=np.bool_)
    zero = np.zeros(n)
    x, y, z = (np.ascontiguousarray(p[:, k]) for k in range(3))
    *_, zmin, zmax = _samples(zero, zero, zero, x, y, z, (1.0, 2.0, 3.0), (1.0, 2.0, 3.0), (-3.0, 3.0),
                              (-3.0, 3.0), (-3.0, 3.0), t._hv, t.origin, float(spacing),
                              (t.cap, t.cap_v, speed, accel, vspeed), level, ttl, ins)
    h, v, inside = t.lookup(p)
    want = np.minimum(np.where(h >= t.cap - 1e-9, np.inf, breakout_time(h, speed, accel)),
                      np.where(v >= t.cap_v - 1e-9, np.inf, v / vspeed))
    assert np.array_equal(ttl, want) and np.array_equal(ins, inside)
    assert np.isinf(ttl[2]) and zmin == z.min() and zmax == z.max()


@settings(max_examples=examples(300), deadline=None)
@given(d=st.floats(0.0, 1e4), v=st.floats(1e-3, 5.0), a=st.floats(1e-4, 10.0))
def test_the_scalar_breakout_time_is_the_vectorised_one(d, v, a):
    """kernel._breakout_time (the compiled pass's) against breakout_time, bit for bit, the knee included."""
    from loadarm.studies.kernel import _breakout_time

    for x in (d, v * v / (2 * a)):
        assert _breakout_time(x, v, a) == float(breakout_time(x, v, a))


@settings(max_examples=examples(50), deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(1, 500))
def test_relative_record_is_the_vectorised_offset_and_std(seed, n):
    """kernel.relative_record (offset rows and the per-axis standard deviations in one compiled routine)
    against ``offset + (flange - reference)`` and ``numpy.std`` per axis: the rows bit for bit, the deviations
    to 1e-12 relative (numpy sums pairwise, the loop in order)."""
    from loadarm.studies.kernel import relative_record

    rng = np.random.default_rng(seed)
    flange = rng.normal(size=(n, 3)) * [3.0, 1.0, 0.5] + [80.0, -2.0, 14.0]
    ref, off = rng.normal(size=3) * 50, rng.normal(size=3) * 20
    out = np.empty((3, n))
    std = relative_record(flange, ref, off, out)
    assert np.array_equal(out.T, off + (flange - ref))
    assert np.allclose(std, np.std(flange, axis=0), rtol=1e-12, atol=1e-15)


_coords = st.one_of(st.floats(-60.0, 60.0), st.floats(allow_nan=True, allow_infinity=True))


@settings(max_examples=examples(300), deadline=None)
@given(pts=st.lists(st.tuples(_coords, _coords, _coords), min_size=1, max_size=64),
       lengths=st.tuples(st.floats(0.5, 30.0), st.floats(0.5, 30.0), st.floats(0.5, 30.0)))
@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
def test_the_record_s_inverse_kinematics_is_inverse3d_bit_for_bit(pts, lengths):
    """kernel.record_ik (the arithmetic in one compiled routine, NumPy's arctangents) against
    slew.inverse3d, unchecked, over any arm and any point (out of reach, huge, tiny, infinite, NaN: the same
    NaN where it gives NaN): bit for bit, so the kernel's angles are the closed loop's."""
    from loadarm.arm.geometry import Arm
    from loadarm.arm.slew import inverse3d
    from loadarm.studies.kernel import record_ik

    arm = Arm(*lengths)
    x, y, z = (np.ascontiguousarray(v, dtype=float) for v in np.array(pts, dtype=float).T)
    with np.errstate(all="ignore"):
        want = inverse3d(arm, x, y, z, check=False)
    got = record_ik(arm, x, y, z)
    for name, w, g in zip(("phi", "alpha", "beta"), want, got):
        assert np.array_equal(w, g, equal_nan=True), (name, w, g)


def test_persistence_counts_windows_and_loadings_by_hand():
    """A hand-made record: 20 h up, 3 h down, 10 h up, a 5-hour gap, 16 h up. With 14-hour loadings and 2 hours
    to reconnect: windows start in the first run's 7 hours (20 - 14 + 1) and the last run's 3, out of the
    operable hours with 14 h of record after them (the first 20 before the gap, 3 after it); loadings back to back: the first completes in hours 0-13, the second is interrupted at
    hour 20 after 6 hours, resumes after 2 of the next 10 hours, and has 8 more by hour 33 (14 in all, one
    disconnection); the record's gap drops the third's progress, which then needs 14 of the last 16 hours."""
    from loadarm.studies.operability import persistence

    up = [True] * 20 + [False] * 3 + [True] * 10 + [True] * 16
    t0 = np.datetime64("2026-01-01T00:00")
    hours = list(range(33)) + list(range(38, 54))
    times = np.array([t0 + np.timedelta64(h, "h") for h in hours])
    p = persistence(~np.array(up), times, 14.0, 2.0)
    assert p["windows_fraction"] == pytest.approx((7 + 3) / (20 + 3))
    assert p["loadings"] == 3 and p["loadings_uninterrupted"] == 2
    assert p["hours_per_loading"] == pytest.approx((14 + 19 + 14) / 3)


@settings(max_examples=examples(100), deadline=None)
@given(up=st.lists(st.booleans(), min_size=1, max_size=80), gaps=st.sets(st.integers(1, 79), max_size=4),
       need=st.integers(1, 20))
@example(up=[True] * 4, gaps=set(), need=14)     # found: a record shorter than a loading gave NaN, refused as JSON
def test_the_windows_are_the_brute_force_count(up, gaps, need):
    """persistence's windows against their definition, hour by hour: a start is an operable hour with ``need``
    hours of record after it in its segment; it is full when they are all operable."""
    from loadarm.studies.operability import persistence

    t0 = np.datetime64("2026-01-01T00:00")
    shift, hours = 0, []
    for k in range(len(up)):
        shift += 3 if k in gaps else 0
        hours.append(t0 + np.timedelta64(k + shift, "h"))
    times = np.array(hours)
    seg = np.cumsum([k == 0 or (k in gaps) for k in range(len(up))])
    starts = full = 0
    for k in range(len(up)):
        span = range(k, k + need)
        if up[k] and k + need <= len(up) and all(seg[j] == seg[k] for j in span):
            starts += 1
            full += all(up[j] for j in span)
    p = persistence(~np.array(up), times, float(need), 0.0)
    assert (starts == 0 and p["windows_fraction"] is None) or p["windows_fraction"] == pytest.approx(full / starts)


def test_each_criterion_takes_the_state_down():
    """judge_state: a quiet state is up; each limit passed takes it down under its own name and no other."""
    import dataclasses

    from loadarm.params.sections import Operability
    from loadarm.ship.motion import StateLoads
    from loadarm.studies.operability import CRITERIA, judge_state

    berth = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    mo = compile_ship(berth).moorings
    crit = Operability()
    quiet = StateLoads(0.3 * mo.mbl, np.full(4, 1e6), np.full(4, 0.3), 0.5, 0.4, 0.2, 0.01, 0.01, 0.01, 0, 0.0)
    env = berth.environment.model_copy(update={"wind_speed": 10.0, "wind_direction_deg": 90.0})
    assert not judge_state(crit, mo, quiet, env, True, 0)["down"]
    cases = {"lines": (dataclasses.replace(quiet, tension_max=0.51 * mo.mbl), env, True, 0),
             "wind": (quiet, env.model_copy(update={"wind_speed": 16.0, "wind_direction_deg": 30.0}), True, 0),
             "fenders": (dataclasses.replace(quiet, fender_deflection_max=np.full(4, 1.16)), env, True, 0),
             "motion": (dataclasses.replace(quiet, roll_pp=math.radians(2.5)), env, True, 0),
             "arm": (quiet, env, True, 2)}
    for name, (loads, e, conn, stage) in cases.items():
        v = judge_state(crit, mo, loads, e, conn, stage)
        assert v["down"] and [c for c in CRITERIA if v[f"down_{c}"]] == [name], name
    # 16 m/s along the berth is under the any-direction limit; a parted line is down whatever the tension
    assert not judge_state(crit, mo, quiet, env.model_copy(update={"wind_speed": 16.0}), True, 0)["down"]
    assert judge_state(crit, mo, dataclasses.replace(quiet, parted=1), env, True, 0)["down_lines"]


def test_the_beam_sea_state_is_judged_on_its_first_order_tension():
    """The issue's state, Hs 2 m, Tp 9.3 s, beam seas in the design wind: with the first-order motion in the
    tensions, each line's largest tension is at least the low-frequency motion's, more lines pass MEG4's 50 %
    (12 and 11 on this seed; 8 and 4 before the set-down, which now renders the brakes on the slow motion alone)
    and the brakes pay out more (3.39 m and 2.58 m: they render on the first-order peaks too); the state is down
    on its lines."""
    from loadarm.params.sections import Operability
    from loadarm.ship.motion import moored_state, simulate
    from loadarm.studies.operability import judge_state

    berth = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    ship = compile_ship(berth)
    env = berth.environment.model_copy(update={"hs": 2.0, "tp": 9.3, "wave_direction_deg": 0.0})
    _, _, loads = moored_state(ship, env, 3600.0, seed=4)
    full = simulate(ship, env, 3600.0, seed=4)
    lf = simulate(ship, env, 3600.0, seed=4, waves=False)
    mbl = ship.moorings.mbl
    assert np.array_equal(loads.tension_max, np.max(full.tension, axis=0))
    assert np.all(loads.tension_max >= np.max(lf.tension, axis=0) - 1.0)
    assert np.sum(loads.tension_max / mbl > 0.5) > np.sum(np.max(lf.tension, axis=0) / mbl > 0.5) > 0
    assert np.max(full.paid_out) > 1.2 * np.max(lf.paid_out)
    assert judge_state(Operability(), ship.moorings, loads, env, True, 0)["down_lines"]


def test_the_swell_moves_the_flange_as_the_free_floating_ship():
    """The issue's 1 m, 16 s swell (beam, long-crested enough: s = 20, no wind or current): the flange's
    first-order motion off the berth has the standard deviation of the free-floating RAOs at the manifold over
    the JONSWAP spectrum and the spreading (an independent double sum over frequency and direction), within
    10 % (one hour's sampling spread), and its 4-sigma is under 1.5 m (1.9 m with the moorings in the RAO
    before issue 28)."""
    from loadarm.ship.hydro import interp_heading
    from loadarm.ship.loads import jonswap, spreading
    from loadarm.ship.motion import simulate

    berth = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    ship = compile_ship(berth)
    env = berth.environment.model_copy(update={"hs": 1.0, "tp": 16.0, "wave_direction_deg": 0.0,
                                               "spreading": 20.0, "wind_speed": 0.0, "current_speed": 0.0})
    m = simulate(ship, env, 3600.0, seed=5, slow=False)
    off = m.flange[:, 0] - np.mean(m.flange[:, 0])
    w = np.linspace(0.2, 1.45, 400)
    th = np.linspace(-math.pi / 2, math.pi / 2, 181)
    h = ship.hydro
    ww, tt = np.meshgrid(w, th, indexing="ij")
    rao = interp_heading(ship.rao, h.heading, h.omega, ww.ravel(), tt.ravel() - ship.psi0)
    lever = ship.manifold - ship.cog
    flange = rao[:, :3] + np.cross(rao[:, 3:], lever)          # ship frame; off the berth is ship -y (port side)
    dens = (np.abs(flange[:, 1]) ** 2).reshape(ww.shape) * jonswap(w, 1.0, 16.0)[:, None] \
        * spreading(th, 0.0, 20.0)[None, :]
    var = np.trapezoid(np.trapezoid(dens, th, axis=1), w)
    assert np.std(off) == pytest.approx(math.sqrt(var), rel=0.10)
    assert 4 * np.std(off) < 1.6


def test_the_block_bootstrap_of_independent_hours_is_the_binomial_interval():
    """Blocks of one hour over independent hours: the bootstrap's 90 % interval of a fraction is the normal
    approximation's p -/+ 1.645 sqrt(p (1 - p) / n) (n = 2000, p about 0.15: each end within 15 % of the
    half-width, the quantiles of 4000 resamples moving by about 3 % of it); the same seed gives the same
    interval; a constant series gives itself; an empty one nan; bad arguments are refused."""
    from loadarm.studies.operability import block_bootstrap

    rng = np.random.default_rng(4)
    x = (rng.random(2000) < 0.15).astype(float)
    p = x.mean()
    half = 1.6449 * math.sqrt(p * (1 - p) / x.size)
    lo, hi = block_bootstrap(x, block=1, resamples=4000, seed=1)
    assert lo == pytest.approx(p - half, abs=0.15 * half) and hi == pytest.approx(p + half, abs=0.15 * half)
    assert block_bootstrap(x, block=1, resamples=4000, seed=1) == (lo, hi)
    assert block_bootstrap(np.full(500, 0.3)) == pytest.approx((0.3, 0.3), abs=1e-12)
    assert all(math.isnan(v) for v in block_bootstrap([]))
    with pytest.raises(ValueError, match="level"):
        block_bootstrap(x, level=1.5)


def test_weeks_resampled_widen_the_interval_of_persistent_weather():
    """Down hours that come in two-day storms: resampling single hours treats them as independent and gives too
    narrow an interval; resampling weeks keeps the storms whole and gives a wider one (measured 7x here)."""
    from loadarm.studies.operability import block_bootstrap

    rng = np.random.default_rng(5)
    storms = rng.random(8760 // 48) < 0.15
    x = np.repeat(storms, 48).astype(float)
    lo1, hi1 = block_bootstrap(x, block=1)
    lo7, hi7 = block_bootstrap(x)
    assert hi7 - lo7 > 2.0 * (hi1 - lo1)
    assert lo7 <= x.mean() <= hi7


def test_no_event_at_all_gives_the_rule_of_three_over_blocks_not_a_zero_width_interval():
    """A record without a single event (no ESD-1 in a calm year) has nothing to resample: the interval is
    (0, -ln(0.05) / m) over its m blocks (the rule of three, 3.0 / m), not (0, 0); and Poisson's exact 95 %
    one-sided bound of a zero count, found as the rate whose probability of no event in m blocks is 5 %, is the
    same number (an independent route)."""
    from scipy.stats import poisson
    from scipy.optimize import brentq

    from loadarm.studies.operability import BOOTSTRAP_BLOCK_H, block_bootstrap

    x = np.zeros(8760)
    lo, hi = block_bootstrap(x)
    m = -(-x.size // BOOTSTRAP_BLOCK_H)
    assert lo == 0.0 and hi == pytest.approx(3.0 / m, rel=0.002)
    rate = brentq(lambda r: poisson.cdf(0, r * m) - 0.05, 1e-9, 10.0)
    assert hi == pytest.approx(rate, rel=1e-9)
    assert block_bootstrap(np.zeros(100), block=1)[1] == pytest.approx(-math.log(0.05) / 100)
