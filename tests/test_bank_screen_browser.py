"""The bank's screen in a real browser (issue 31, item 6): Debian's Chromium driven by Playwright against ``loadarm
serve --bank``'s screen on an ephemeral loopback port, over the bank's world (the example bank connected to the
Hs 1.5 m moored ship). Skipped with the reason when no Chromium is installed (`apt-get install chromium`); CI
installs it. Seconds each: in the slow suite (`make test SLOW=1`, CI)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from loadarm.opcua.security import Role, StateDir
from loadarm.testing.browser import CHROMIUM_HINT, find_chromium, log_in, wait_for

ROOT = Path(__file__).resolve().parents[1]
BANK = ROOT / "examples" / "banks" / "lng150k_bank.toml"
SCENARIO = ROOT / "examples" / "scenarios" / "hs15_moored.toml"
#: A jetty console and a laptop.
SIZES = [(1920, 1080), (1366, 768)]

pytestmark = [pytest.mark.skipif(find_chromium() is None, reason=CHROMIUM_HINT), pytest.mark.slow]


@pytest.fixture(scope="module")
def state(tmp_path_factory):
    st = StateDir(tmp_path_factory.mktemp("bank-screen") / "state")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    return st


@pytest.fixture(scope="module", params=["normal", "abnormal"])
def bank_screen(request, state):
    """The bank's service and screen: as the file says ("normal"), or with 2.3 m required between arms that keep
    2.1 m ("abnormal": the nearest clash below the required clearance)."""
    from loadarm.testing.bank_screen import bank_screen, bank_world

    world = bank_world(BANK, SCENARIO, min_clearance=None if request.param == "normal" else 2.3)
    with bank_screen(world, state.path, speedup=2.0) as (service, server):
        yield {"world": world, "service": service, "url": server.url, "abnormal": request.param == "abnormal"}


def _sized(browser, w, h):
    ctx = browser.new_context(viewport={"width": w, "height": h})
    pg = ctx.new_page()
    pg.errors = []
    pg.on("pageerror", lambda e: pg.errors.append(str(e)))
    pg.on("console", lambda m: pg.errors.append(m.text) if m.type == "error" else None)
    return ctx, pg


#: Every text box of the two views against every other, every drawn line (sampled along its length, widened by
#: half its stroke: the pipes and counterweights at their capsules' thickness, the deck, the berthing line, the
#: clash) and every circle (the swivels, a capsule seen end on, the clash's ends).
_OVERLAPS = """() => {
  const hits = [];
  const meet = (a, b) => a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height;
  for (const id of ['bank-top', 'bank-side']) {
    const svg = document.getElementById(id);
    const texts = [...svg.querySelectorAll('text')].map((t) => [t.textContent, t.getBBox()]);
    const near = (b, x, y, d) => x >= b.x - d && x <= b.x + b.width + d && y >= b.y - d && y <= b.y + b.height + d;
    texts.forEach(([a, b], i) => {
      texts.slice(i + 1).forEach(([c, d]) => { if (meet(b, d)) { hits.push(`${id}: ${a} / ${c}`); } });
      for (const g of svg.querySelectorAll('line')) {
        const half = parseFloat(getComputedStyle(g).strokeWidth) / 2, n = g.getTotalLength();
        for (let s = 0; s <= n; s += 1) {
          const p = g.getPointAtLength(s);
          if (near(b, p.x, p.y, half)) { hits.push(`${id}: ${a} / ${g.getAttribute('class')}`); break; }
        }
      }
      for (const g of svg.querySelectorAll('circle')) {
        if (meet(b, g.getBBox())) { hits.push(`${id}: ${a} / ${g.getAttribute('class')}`); }
      }
    });
  }
  return hits;
}"""

#: The primary state's elements whose box is not wholly inside the window, and tile text cut off.
_OUTSIDE = """() => [...document.querySelectorAll('#primary .tile, #bank-top, #bank-side, #arms')].filter((e) => {
  const r = e.getBoundingClientRect();
  return !(r.width > 0 && r.height > 0 && r.left >= 0 && r.top >= 0 && r.right <= innerWidth && r.bottom <= innerHeight);
}).map((e) => e.id)"""
_CUT = """() => [...document.querySelectorAll('#primary .tile .v, #primary .tile .d, #primary .tile .k')]
  .filter((e) => e.scrollWidth > e.clientWidth + 1
          || e.getBoundingClientRect().right > e.closest('.tile').getBoundingClientRect().right + 1)
  .map((e) => `${e.id || e.className}: ${e.textContent}`)"""

#: What the screen shows, read at once (between two frames): the frame; per view and arm, the parts drawn and where
#: the swivel's circle is against the arm's flange projected by the view's own scale; the arms' names; the clash's
#: tile, its lines, the rows marked abnormal.
_SHOWN = """() => ({frame: hmi.frame, clash: $('clash-value').innerText, detail: $('clash-detail').innerText,
  tileAbnormal: $('tile-clash').classList.contains('abnormal'), required: $('required-value').innerText,
  abnormalRows: document.querySelectorAll('#arms tr.abnormal').length,
  names: Object.fromEntries(['top', 'side'].map((v) => [v, [...document.querySelectorAll(`#bank-${v} text.arm-name`)]
    .map((e) => e.textContent)])),
  lines: Object.fromEntries(['top', 'side'].map((v) => [v, [...document.querySelectorAll(`#bank-${v} line.clash`)]
    .map((e) => [e.dataset.arms, e.classList.contains('abnormal')])])),
  parts: Object.fromEntries(['top', 'side'].map((v) => [v, hmi.frame.arms.map((a) => {
  const svg = document.getElementById(`bank-${v}`), view = hmi.views[v];
  const parts = [...svg.querySelectorAll(`[data-arm="${a.name}"]`)].map((e) => +e.dataset.part).sort();
  const sw = svg.querySelector(`circle.swivel[data-arm="${a.name}"]`);
  const want = v === 'top' ? [view.u(a.flange[1]), view.v(a.flange[0])] : [view.u(a.flange[1]), view.v(a.flange[2])];
  return [a.name, parts, Math.hypot(+sw.getAttribute('cx') - want[0], +sw.getAttribute('cy') - want[1]),
          +sw.getAttribute('r') / view.k];
})]))})"""


@pytest.mark.parametrize("w, h", SIZES)
def test_the_bank_s_screen_draws_every_arm_and_the_nearest_clash(browser, bank_screen, w, h):
    """At a 1920x1080 console and a 1366x768 laptop: every arm drawn in both views (its six capsules, its swivel on
    its flange at the capsule's radius), its name in both; the nearest clash's pair and distance in the tile are
    the least of every pair's clearance computed here (pair by pair, on the world at the frame's time), its line
    between those two arms in both views, emphasised only when below the required clearance (ISA-101); no text
    box of either view meets another, a drawn line or a circle; the primary state in the window, nothing cut, the
    page not scrolled; no console error."""
    from loadarm.arm.clearance import pair_clearance

    world, abnormal = bank_screen["world"], bank_screen["abnormal"]
    bank = world.bank
    ctx, page = _sized(browser, w, h)
    try:
        log_in(page, bank_screen["url"], "alice", "pw-alice")
        wait_for(page, "hmi.frames >= 3", what="three frames")
        shown = page.evaluate(_SHOWN)
        frame, parts = shown["frame"], shown["parts"]
        for view in ("top", "side"):
            assert [p[0] for p in parts[view]] == list(bank.names)
            for name, drawn, off, radius in parts[view]:
                assert drawn == [0, 1, 2, 3, 4, 5], (view, name, drawn)
                assert off < 0.5 and radius == pytest.approx(bank.file.clearance.swivel_radius, rel=1e-3)
            assert shown["names"][view] == list(bank.names), (view, shown["names"])
        # the nearest clash against the world at the frame's time, pair by pair
        st = world.state(frame["t"])
        gaps = {(bank.names[i], bank.names[j]): float(pair_clearance(bank.shapes[i], bank.shapes[j], st.q[i],
                                                                     st.q[j])[0])
                for i in range(len(bank.names)) for j in range(i + 1, len(bank.names))}
        pair = tuple(frame["clash"]["arms"])
        assert gaps[pair] == pytest.approx(min(gaps.values()), abs=1e-9)
        assert shown["clash"].startswith(f"{pair[0]} / {pair[1]}: {gaps[pair]:.2f} m"), shown["clash"]
        assert shown["detail"] == ("below the required 2.30 m: " if abnormal else "") + (
            f"inboard counterweight of {pair[0]} to inboard counterweight of {pair[1]}")
        for view in ("top", "side"):
            assert shown["lines"][view] == [["/".join(pair), abnormal]], (view, shown["lines"])
        assert shown["tileAbnormal"] is abnormal and shown["abnormalRows"] == (4 if abnormal else 0)
        assert shown["required"] == ("2.30 m" if abnormal else "0.50 m")
        assert page.evaluate(_OVERLAPS) == []
        assert page.evaluate(_OUTSIDE) == [] and page.evaluate(_CUT) == []
        assert page.evaluate("document.scrollingElement.scrollHeight <= innerHeight"
                             " && document.scrollingElement.scrollWidth <= innerWidth")
        flanges = page.evaluate("[...document.querySelectorAll('#bank-top text')].map(e => e.textContent)")
        assert {"F1", "F2", "F3", "F4", "berthing line"} <= set(flanges) and any(
            x.startswith("ship (") for x in flanges), flanges
        assert page.errors == []
    finally:
        ctx.close()


@pytest.mark.parametrize("bank_screen", ["normal"], indirect=True)
def test_the_bank_s_screen_follows_the_ship(browser, bank_screen):
    """Frames keep coming at the screen's rate and the arms follow the ship: the flanges drawn move with the
    manifold, and each frame's are the world's at its time."""
    world = bank_screen["world"]
    ctx, page = _sized(browser, 1366, 768)
    try:
        log_in(page, bank_screen["url"], "alice", "pw-alice")
        first = wait_for(page, "hmi.frames >= 2 && hmi.frame")
        later = wait_for(page, f"hmi.frame.t >= {first['t'] + 3} && hmi.frame", timeout=15.0)
        for f in (first, later):
            got = np.array([a["flange"] for a in f["arms"]])
            assert np.allclose(got, world.flanges(f["t"])[0], atol=1e-4)
        moved = np.array([a["flange"] for a in later["arms"]]) - np.array([a["flange"] for a in first["arms"]])
        assert np.all(np.abs(moved).max(axis=1) > 1e-3)
        assert page.evaluate("hmi.frames") >= 10 and page.errors == []
    finally:
        ctx.close()


def test_the_flange_load_alarm_shows_and_an_operator_acknowledges_it(browser, state):
    """The overloaded example bank: V1's flange load over its allowable rises to an unacknowledged alarm after the
    window and the delay (its row emphasised, the Acknowledge button shown to an operator); a click acknowledges it
    on the server, the row then says ACK; the other arms' loads are shown as shares of their allowable."""
    from loadarm.testing.bank_screen import bank_screen, bank_world

    world = bank_world(ROOT / "examples" / "banks" / "overloaded_manifold.toml", SCENARIO)
    with bank_screen(world, state.path, speedup=2.0) as (service, server):
        ctx, page = _sized(browser, 1366, 768)
        try:
            log_in(page, server.url, "alice", "pw-alice")
            wait_for(page, "hmi.frame && hmi.frame.arms[2].load.state === 'unacknowledged'", timeout=20.0,
                     what="V1's manifold-load alarm")
            row = "[...document.querySelectorAll('#arms tbody tr')][2]"
            assert page.evaluate(f"{row}.classList.contains('abnormal')")
            assert page.evaluate(f"{row}.lastChild.textContent").startswith("UNACK ")
            assert page.evaluate("!$('ack-loads').hidden")
            page.click("#ack-loads")
            wait_for(page, "hmi.frame.arms[2].load.state === 'acknowledged'", timeout=10.0, what="the acknowledgement")
            assert page.evaluate("$('ack-result').textContent") == "ack sent"
            wait_for(page, f"{row}.lastChild.textContent.startsWith('ACK ')", timeout=5.0, what="the row's ACK")
            assert service.snapshot().loads.states[2].value == "acknowledged"
            assert page.evaluate(_OUTSIDE) == [] and page.errors == []
        finally:
            ctx.close()


def test_the_bank_s_alarm_list_shows_each_arm_s_stage_and_an_operator_acknowledges_it(browser, state):
    """Found: the bank's screen had no alarm list (each arm's stage only in its table). With 2.3 m required between
    arms that keep 2.1 m, every arm's clash is past: each arm's ERS-2 alarm (the most severe of its stage alarms;
    the lower stages of the same escalation suppressed) is listed, critical (its colour with its shape and name),
    unacknowledged; a click acknowledges every alarm on the server and the list then says so. The journal page
    lists the alarms risen (with their priority) and the acknowledgement with its user."""
    from loadarm.testing.bank_screen import bank_screen, bank_world

    world = bank_world(BANK, SCENARIO, min_clearance=2.3)
    with bank_screen(world, state.path, speedup=2.0) as (service, server):
        ctx, page = _sized(browser, 1366, 768)
        try:
            log_in(page, server.url, "alice", "pw-alice")
            wait_for(page, "hmi.frame && hmi.frame.alarms.length === 4", timeout=20.0, what="four arms' alarms")
            rows = page.evaluate("[...document.querySelectorAll('#alarms tbody tr')].map((tr) => [tr.className, "
                                 "tr.querySelector('.prio').textContent, tr.querySelector('.msg').textContent, "
                                 "tr.querySelector('.state .text').textContent])")
            assert [r[2] for r in rows] == [f"{n}: ERS-2: release of the coupler" for n in ("L1", "L2", "V1", "L3")]
            assert all(r[0] == "alarm p1 unacknowledged" and r[1] == "critical" and r[3] == "unacknowledged"
                       for r in rows), rows
            colour = page.evaluate("getComputedStyle(document.querySelector('#alarms tr.p1 .prio span'))"
                                   ".backgroundColor")
            assert colour == "rgb(212, 0, 0)"                           # --p1: an alarm's colour, for an alarm
            assert page.evaluate("!$('ack-loads').hidden")
            page.click("#ack-loads")
            wait_for(page, "hmi.frame.alarms.every((a) => a.state === 'acknowledged')", timeout=10.0,
                     what="the acknowledgement")
            assert all(a.state.value == "acknowledged" for a in service.snapshot().alarms)
            assert page.evaluate("$('ack-loads').hidden")
            assert any("ERS-2: release of the coupler: arm L1" in n[2] for n in service.notes)
            page.click("#pages button[data-page=journal]")                 # the journal: the service's notes
            wait_for(page, "hmi.journal && hmi.journal.entries.length >= 4", timeout=10.0, what="the journal")
            assert page.evaluate("$('page-bank').hidden && !$('page-journal').hidden")
            texts = page.evaluate("[...document.querySelectorAll('#journal tbody tr')].map((tr) => "
                                  "[tr.className, tr.querySelector('.msg').textContent])")
            assert ["entry alarm p1", "L1: ERS-2: release of the coupler"] in texts, texts
            page.select_option("#journal-kind", "operator")
            wait_for(page, "hmi.journal.entries.length >= 1 && hmi.journal.entries.every((e) => e.kind !== 'alarm')",
                     timeout=10.0, what="the operator's actions")
            assert page.evaluate("hmi.journal.entries[0].text") == "every alarm acknowledged by alice"
            page.click("#pages button[data-page=bank]")
            assert page.evaluate("!$('page-bank').hidden && $('page-journal').hidden")
            assert page.evaluate(_OUTSIDE) == [] and page.errors == []
        finally:
            ctx.close()
