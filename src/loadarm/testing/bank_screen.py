"""The bank's screen to drive in a browser (issue 31): its service and screen started on a loopback port for the
browser tests and ``make docs``'s screenshot of docs/bank.md."""

from __future__ import annotations

import contextlib
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from loadarm.hmi.app import HmiServer
from loadarm.hmi.bank import create_bank_app
from loadarm.opcua.bank import BankService
from loadarm.opcua.security import Role, StateDir
from loadarm.params.bank import load_bank
from loadarm.sim.bank import BankWorld
from loadarm.sim.spec import load_run
from loadarm.testing.browser import SCREEN_SIZE, launch, log_in, wait_for

__all__ = ["BANK_SCREENSHOT", "bank_world", "bank_screen", "bank_screenshot"]

#: The screenshot of docs/bank.md.
BANK_SCREENSHOT = "bank-screen.png"


def bank_world(bank_file, scenario, *, min_clearance: float | None = None) -> BankWorld:
    """A bank on a scenario's ship.

    Parameters
    ----------
    bank_file : path
        The bank file.
    scenario : path
        The scenario whose ship (and sea) the bank is connected to.
    min_clearance : float, optional
        Require this clearance instead of the file's (a test's way to an abnormal clash without moving an arm).

    Returns
    -------
    BankWorld
    """
    bank = load_bank(bank_file)
    if min_clearance is not None:
        clearance = bank.file.clearance.model_copy(update={"min_clearance": min_clearance})
        bank = replace(bank, file=bank.file.model_copy(update={"clearance": clearance}))
    spec = load_run(scenario)
    return BankWorld.from_scenario(bank, spec.scenario, spec.ship)


@contextlib.contextmanager
def bank_screen(world: BankWorld, state_dir, *, speedup: float = 1.0, berth=None):
    """The bank's service (its own thread, on the wall clock) and its screen (uvicorn, loopback, an ephemeral
    port), both started; both stopped on leaving.

    Parameters
    ----------
    world : BankWorld
    state_dir : path
        Users and certificates.
    speedup : float
        Run seconds per wall second.
    berth : Berth, optional
        The ship drawn.

    Yields
    ------
    (BankService, HmiServer)
    """
    service = BankService(world, speedup=speedup)
    server = HmiServer(create_bank_app(service, state_dir, berth=berth), "127.0.0.1", 0)
    server.start()
    try:
        service.start()
        yield service, server
    finally:
        service.stop()
        server.stop()


def bank_screenshot(bank_file, scenario, dest) -> Path:
    """docs/bank.md's screenshot (:data:`BANK_SCREENSHOT`, at :data:`loadarm.testing.browser.SCREEN_SIZE`): the
    bank on the scenario's ship, ten seconds in.

    Parameters
    ----------
    bank_file, scenario : path
    dest : path
        The directory it goes to.

    Returns
    -------
    Path
    """
    from playwright.sync_api import sync_playwright

    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    world = bank_world(bank_file, scenario)
    w, h = SCREEN_SIZE
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as p:
        st = StateDir(Path(tmp) / "state")
        st.users().add("operator", Role.OPERATOR, "docs-only")
        browser = launch(p)
        try:
            with bank_screen(world, st.path, speedup=4.0) as (_service, server):
                page = browser.new_page(viewport={"width": w, "height": h})
                log_in(page, server.url, "operator", "docs-only")
                wait_for(page, "hmi.frame && hmi.frame.t >= 10", timeout=30.0, what="ten seconds of the bank")
                time.sleep(0.2)
                out = dest / BANK_SCREENSHOT
                page.screenshot(path=str(out))
        finally:
            browser.close()
    return out
