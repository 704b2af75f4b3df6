"""Driving the operator's screen in a real browser: Debian's Chromium through Playwright (its own browser download
cannot work offline, so ``executable_path``). The browser tests use it, and ``make docs`` takes the screenshots
of docs/hmi.md with :func:`tour`."""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from pathlib import Path

from loadarm.eventlog import EventLog
from loadarm.hmi.app import HmiServer, create_app
from loadarm.hmi.replay import ReplayService
from loadarm.opcua.security import Role, StateDir
from loadarm.opcua.service import GuidanceService
from loadarm.params.scenario import load_scenario
from loadarm.sim.loop import ClosedLoop, run_scenario

__all__ = ["CHROMIUM_HINT", "SCREENSHOTS", "SCREEN_SIZE", "find_chromium", "launch", "log_in", "wait_for", "tour",
           "scenario_screen", "screenshots"]

#: The screenshots of docs/hmi.md (:func:`screenshots`): the live drift-off's modes, then its replay and journal.
SCREENSHOTS = ("hmi-approach.png", "hmi-connected.png", "hmi-alarm1.png", "hmi-release.png", "hmi-journal.png",
               "hmi-replay.png")
#: They are taken at a jetty console's size.
SCREEN_SIZE = (1920, 1080)

#: What to do when no Chromium is found.
CHROMIUM_HINT = ("no Chromium found: install Debian's (`apt-get install chromium`) or set LOADARM_CHROMIUM to a "
                 "Chromium or Chrome executable")

#: Chromium's flags here: headless, no sandbox as root, and none of its own network traffic (on a closed
#: network its background connections fail, many at a time).
_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--disable-default-apps"]


def find_chromium() -> str | None:
    """The Chromium to drive.

    Returns
    -------
    str or None
        ``$LOADARM_CHROMIUM``, else ``chromium``, ``chromium-browser`` or ``google-chrome`` on the PATH; None if
        there is none.
    """
    env = os.environ.get("LOADARM_CHROMIUM")
    if env:
        return env if Path(env).is_file() else None
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def launch(playwright, executable: str | None = None):
    """A headless Chromium.

    Parameters
    ----------
    playwright : Playwright
        From ``sync_playwright()``.
    executable : str, optional
        The browser (default :func:`find_chromium`'s).

    Returns
    -------
    Browser

    Raises
    ------
    FileNotFoundError
        With :data:`CHROMIUM_HINT` when there is no Chromium.
    """
    exe = executable or find_chromium()
    if exe is None:
        raise FileNotFoundError(CHROMIUM_HINT)
    return playwright.chromium.launch(executable_path=exe, headless=True, args=_ARGS)


def wait_for(page, js: str, timeout: float = 10.0, what: str = ""):
    """Poll a JS expression on a page until it is truthy.

    Parameters
    ----------
    page : Page
    js : str
        The expression.
    timeout : float
        s.
    what : str
        For the message.

    Returns
    -------
    object
        The expression's value.

    Raises
    ------
    AssertionError
        After ``timeout``.
    """
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        v = page.evaluate(js)
        if v:
            return v
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout:g} s waiting for {what or js}")


def log_in(page, url: str, user: str, password: str) -> None:
    """Open the screen and log in; return once the first frame has been drawn.

    Parameters
    ----------
    page : Page
    url : str
        The HMI's address.
    user, password : str
    """
    page.goto(url)
    page.fill("#login-user", user)
    page.fill("#login-password", password)
    page.click("#login-button")
    page.wait_for_selector("#screen:not([hidden])")
    wait_for(page, "window.hmi && hmi.frames > 0", what="the first frame")


def tour(page, url: str, user: str, password: str, out_dir: Path | None, *, timeout: float = 120.0) -> dict:
    """Watch a scripted run (the drift-off) on the screen: the modes in the order the screen showed them, the
    alarms in the order they first appeared, and a screenshot ``hmi-MODE.png`` of each mode it was in when
    polled (every mode at real time; a fast run may change mode during a screenshot) in ``out_dir``.

    Parameters
    ----------
    page : Page
    url : str
        The HMI's address.
    user, password : str
    out_dir : Path or None
        Where the screenshots go (None: none taken).
    timeout : float
        The longest the run is watched, s.

    Returns
    -------
    dict
        ``modes`` and ``alarms`` (lists of str), ``shots`` (paths).
    """
    log_in(page, url, user, password)
    modes, shots = [], []              # the modes polled here (for the screenshots); the page keeps them all
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        mode = page.evaluate("hmi.frame && hmi.frame.mode")
        if mode and (not modes or modes[-1] != mode):
            modes.append(mode)
            if out_dir is not None:
                path = Path(out_dir) / f"hmi-{mode.lower()}.png"
                page.screenshot(path=str(path))
                shots.append(path)
        if mode == "RETURN":
            break
        time.sleep(0.05)
    return {"modes": page.evaluate("hmi.seenModes"), "alarms": page.evaluate("hmi.seenAlarms"), "shots": shots}


@contextlib.contextmanager
def scenario_screen(scenario, state_dir, *, speedup: float = 1.0, scripted: bool = True, plant: str | None = None,
                    name: str | None = None):
    """A screen to drive: the guidance service over a scenario (its own thread, on the wall clock) and the HMI
    server on it (uvicorn in its own, loopback, an ephemeral port), both started; both stopped on leaving. The
    browser tests, ``make docs``'s screenshots and the bench each used to build this themselves.

    Parameters
    ----------
    scenario : path
        Scenario TOML.
    state_dir : path
        The server's state directory (users, certificates).
    speedup : float
        The service's clock against the wall's.
    scripted : bool
        Run the scenario's scripted operator too.
    plant : {'hydraulic', 'kinematic'}, optional
        Default the scenario's.
    name : str, optional
        Shown on the screen (default the scenario's name).

    Yields
    ------
    (GuidanceService, HmiServer)
        ``service.loop`` is the run; ``server.url`` the screen's address.
    """

    sc, model = load_scenario(scenario)
    service = GuidanceService(ClosedLoop(sc, model, scripted=scripted, plant=plant), speedup=speedup)
    server = HmiServer(create_app(service, state_dir, model, name=name or sc.scenario.name), "127.0.0.1", 0)
    server.start()
    try:
        service.start()
        yield service, server
    finally:
        service.stop()
        server.stop()


def screenshots(scenario, dest, *, speedup: float = 4.0) -> list[Path]:
    """The screenshots of docs/hmi.md (:data:`SCREENSHOTS`, at :data:`SCREEN_SIZE`): the scripted run of
    ``scenario`` live at ``speedup`` (a screenshot of each mode, :func:`tour`), then the same run logged and
    replayed on ``serve --replay``'s screen: the replay one second into the release, and the alarm journal.

    Parameters
    ----------
    scenario : path
        The drift-off's scenario file.
    dest : str or Path
        Where they go.
    speedup : float
        Run seconds per wall second of the live run.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    FileNotFoundError
        No Chromium (the message says how to install it).
    RuntimeError
        The live screen never showed one of the modes.
    """
    import math
    import tempfile

    from playwright.sync_api import sync_playwright

    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    w, h = SCREEN_SIZE
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as p:
        st = StateDir(Path(tmp) / "state")
        st.users().add("operator", Role.OPERATOR, "docs-only")
        browser = launch(p)
        try:
            with scenario_screen(scenario, st.path, speedup=speedup) as (_service, server):
                page = browser.new_page(viewport={"width": w, "height": h})
                got = tour(page, server.url, "operator", "docs-only", Path(tmp))
                page.close()
            out = []
            for name in SCREENSHOTS[:4]:
                if not (Path(tmp) / name).exists():
                    raise RuntimeError(f"the screen never showed {name} (modes seen: {got['modes']})")
                out.append(Path(shutil.copy(Path(tmp) / name, dest / name)))
            sc, model = load_scenario(scenario)
            with EventLog(Path(tmp) / "events.db", run="docs") as log:
                res = run_scenario(sc, model, log=log)
            with EventLog.open_existing(Path(tmp) / "events.db") as log:
                service = ReplayService(log.query(run="docs"), model)
            server = HmiServer(create_app(service, st.path, model, name=f"{sc.scenario.name} (replay)"),
                               "127.0.0.1", 0)
            server.start()
            try:
                page = browser.new_page(viewport={"width": w, "height": h})
                log_in(page, server.url, "operator", "docs-only")
                t = math.ceil(res.first("alarm", "RELEASE") + 1.0)
                page.evaluate(f"control('pause'); control('seek', {{t: {t}}})")
                wait_for(page, f"hmi.frame.t === {t}", what=f"the replay at {t} s")
                time.sleep(0.3)
                page.screenshot(path=str(dest / "hmi-replay.png"))
                page.click("#pages button[data-page='journal']")
                wait_for(page, "document.querySelectorAll('#journal tbody tr').length > 0", what="the journal")
                time.sleep(0.2)
                page.screenshot(path=str(dest / "hmi-journal.png"))
                out += [dest / "hmi-journal.png", dest / "hmi-replay.png"]
            finally:
                server.stop()
        finally:
            browser.close()
    return out
