"""The bank's screen (issue 31, item 6): ``loadarm serve --bank ... --hmi HOST:PORT``.

One page (``/``, also ``/bank``) over a :class:`loadarm.opcua.bank.BankService`: a top view and a side view (seen
from the ship, the jetty behind) drawing every arm from its capsules (:mod:`loadarm.arm.clearance`, the same
segments the clearance is computed on), the manifold's flanges and the ship, and the nearest clash between two
arms (the pair, their parts, the distance), drawn grey while the clearance keeps the bank's minimum and
highlighted only below it (ISA-101: colour and emphasis for the abnormal only).

The login, sessions, users and security headers are the single arm's screen's (:mod:`loadarm.hmi.app`: the same
users file, the same roles). The bank's world has no controller to command: the page takes one command, the
acknowledgement of its alarms (an operator's, :data:`BANK_COMMANDS`; CSRF token, sequence number and role checked
as on the arm's screen), and refuses any other, logging the refusal. Each arm's row shows its flange load and its
manifold-load alarm (:mod:`loadarm.guidance.manifold_alarm`).
"""


import asyncio
import json
import math
import time
from collections.abc import Callable

import numpy as np

from loadarm.hmi.app import FRAME_RATE, KEEPALIVE, WS_MESSAGE, LoginScreen, ack, same_origin, screen_app
from loadarm.hmi.sessions import COOKIE
from loadarm.hmi.state import clock_text, ship_outline
from loadarm.opcua.bank import BankSnapshot
from loadarm.params.berth import BerthSection
from loadarm.vocab import BANK_FACE_WORDS, COMMANDS, FACE_WORDS, FACES, SWIVEL_FACE_TABLE, condition_text, priority

__all__ = ["BANK_COMMANDS", "bank_geometry", "bank_frame", "bank_journal_entry", "create_bank_app"]


#: The commands the bank's screen takes: the acknowledgement of its alarms (the bank's world has no controller).
BANK_COMMANDS = ("ack",)

def _r(v, nd: int = 4):
    """JSON has no NaN: None; else rounded (a frame is sent 20 times a second)."""
    v = float(v)
    return round(v, nd) if math.isfinite(v) else None


def bank_geometry(bank, berth=None) -> dict:
    """The bank's fixed drawing: its arms (riser, lengths, capsule radii), the flanges at the design case, the
    required clearance, the ship's deck edge and the berthing line, in the bank's frame.

    Parameters
    ----------
    bank : loadarm.params.bank.Bank
    berth : loadarm.params.berth.Berth, optional
        The ship drawn (default the design ship of :mod:`loadarm.params.berth`): its deck edge from the berth's
        hull (:func:`loadarm.hmi.state.ship_outline`), midships at the manifold's centre, its side on the first
        arm's berthing line.

    Returns
    -------
    dict
        JSON-ready.
    """
    m = bank.file.manifold
    first = bank.file.arms[0]
    ship = ship_outline(bank.models[0], berth)
    ship_y = (berth.berth if berth is not None else BerthSection()).ship_y
    outline = [[x + first.x, y - ship_y + m.position[1]] for x, y in ship["outline"]]
    arms = [{"name": a.name, "base": list(s.base), "a": mo.arm.a, "b": mo.arm.b, "c": mo.arm.c,
             "radii": list(s.radii), "flange": f.name, "product": f.product}
            for a, s, mo, f in zip(bank.file.arms, bank.shapes, bank.models, bank.flanges, strict=True)]
    flanges = [{"name": f.name, "arm": a.name, "product": f.product,
                "position": (bank.flange_position(i) + np.array([a.x, a.y, 0.0])).tolist()}
               for i, (a, f) in enumerate(zip(bank.file.arms, bank.flanges, strict=True))]
    return {"name": bank.file.bank.name, "arms": arms, "flanges": flanges, "manifold": list(m.position),
            "heading_deg": m.heading_deg, "required": bank.file.clearance.min_clearance,
            "berthing_line": bank.models[0].berth.berthing_line + first.x,
            "ship": {"outline": outline, "length": ship["length"], "beam": ship["beam"], "side": ship["side"]},
            "faces": list(FACES), "face_words": dict(FACE_WORDS),
            "swivel_faces": [f.name for f in SWIVEL_FACE_TABLE],
            "swivel_words": {f.name: f.words for f in SWIVEL_FACE_TABLE}}


def _arm_frame(snap: BankSnapshot, i: int) -> dict:
    """One arm in a frame: its capsules, flange, joints, stage, nearest neighbour, time to its nearest face (its own, a swivel's, a clash) and least
    margins."""
    state = snap.state
    k = state.nearest_of(i)
    a, b = state.pairs[k]
    clash = state.clash(k)
    mine = clash["parts"] if a == i else clash["parts"][::-1]
    margins, swm = state.margins[i], state.swivel_margins[i]
    f, s = int(np.argmin(margins)), int(np.argmin(swm))
    stage = snap.stage(i)
    ttl = snap.forecast.by_arm[i] if snap.forecast is not None else math.inf
    return {"name": state.names[i], "q_deg": [_r(math.degrees(v), 3) for v in state.q[i]],
            "flange": [_r(v) for v in state.flanges[i]],
            "capsules": [[[_r(v) for v in end] for end in part] for part in state.capsules[i]],
            "stage": int(stage), "stage_text": stage.label, "ttl": _r(ttl, 1),
            "nearest": {"arm": state.names[b if a == i else a], "clearance": _r(clash["clearance"], 3),
                        "parts": mine},
            "face": {"name": FACES[f], "margin_deg": _r(math.degrees(margins[f]), 2)},
            "swivel": {"name": SWIVEL_FACE_TABLE[s].name, "margin_deg": _r(math.degrees(swm[s]), 2)},
            "swivels_deg": [_r(math.degrees(v), 2) for v in state.swivels[i]],
            "load": _load_frame(snap, i)}


def _load_frame(snap: BankSnapshot, i: int) -> dict:
    """Arm ``i``'s manifold load: its largest share of the allowable, which load, the alarm and its ISA state."""
    loads = snap.loads
    if loads is None or not math.isfinite(float(loads.utilisation[i])):
        return {"utilisation": None, "governing": "", "active": False, "state": "normal"}
    return {"utilisation": _r(float(loads.utilisation[i]), 3), "governing": loads.governing[i],
            "active": bool(loads.active[i]), "state": loads.states[i].value}


def _alarm(a) -> dict:
    """One line of the alarm list, as the arm's screen draws its own (:class:`loadarm.hmi.state.AlarmEntry`)."""
    rank, name = priority(a.tag)
    return {"tag": a.code, "message": f"{a.arm}: {condition_text(a.tag)}", "priority": rank, "priority_name": name,
            "state": a.state.value, "raised_at": _r(a.raised_at, 1)}


def bank_frame(snap: BankSnapshot, *, sent_at: float) -> dict:
    """A frame of the bank's screen (JSON-ready): every arm, the nearest clash, the ship's motion.

    Parameters
    ----------
    snap : BankSnapshot
    sent_at : float
        Wall-clock time it is sent, s since the epoch.

    Returns
    -------
    dict
    """
    st, fc = snap.state, snap.forecast
    clash = st.clash(st.nearest_pair)
    face = fc.face if fc is not None else ""
    return {"type": "state", "seq": snap.seq, "t": _r(st.t, 3), "wall": snap.wall, "sent_at": sent_at,
            "arms": [_arm_frame(snap, i) for i in range(len(st.names))],
            "forecast": {"time": _r(fc.time if fc is not None else math.inf, 1), "face": face,
                         "words": BANK_FACE_WORDS.get(face) or FACE_WORDS.get(face, ""),
                         "arms": list(fc.arms) if fc is not None else []},
            "clash": {"arms": clash["arms"], "parts": clash["parts"], "clearance": _r(clash["clearance"], 3),
                      "abnormal": clash["abnormal"], "points": [[_r(v) for v in p] for p in clash["points"]]},
            "alarms": [_alarm(a) for a in snap.alarms],
            "required": st.required, "manifold": [_r(v) for v in st.manifold],
            "ship_deg": [_r(math.degrees(v), 3) for v in st.ship_angles],
            "stage": max(int(snap.stage(i)) for i in range(len(st.names)))}


def bank_journal_entry(wall: float, kind: str, reason: str, data: dict, now: float) -> dict:
    """One line of the bank's journal from one of its service's notes (an alarm's rise or clear, an operator's
    acknowledgement, a security event), in the fields of :func:`loadarm.hmi.state.journal_entry`: its text from
    its codes (the arm, the alarm's tag or the load alarm's event code, the user), a note without codes its
    message.

    Parameters
    ----------
    wall : float
        Wall-clock time of the note, s since the epoch.
    kind, reason : str
    data : dict
    now : float
        The server's wall clock (the date is shown when the day differs).

    Returns
    -------
    dict
    """
    tag = data.get("tag") or ("MANIFOLD_LOAD" if data.get("code") == "fault.manifold_load" else None)
    arm = data.get("arm")
    if kind == "operator" and data.get("action") == "ack":
        text = (f"{arm}: {condition_text(tag)}: acknowledged by {data.get('user', '?')}" if tag
                else f"every alarm acknowledged by {data.get('user', '?')}")
        if data.get("comment"):
            text += f" ({data['comment']})"
    elif kind == "alarm" and tag and arm:
        text = f"{arm}: {condition_text(tag)}" + ("" if data.get("active") else ": cleared")
        if "utilisation" in data:
            text += f" ({data.get('load', '?')} at {float(data['utilisation']):.2f} of its allowable)"
        if data.get("error"):                  # the event log's fault: why (found by review: it was lost)
            text += f" ({data['error']})"
    else:
        text = reason
    prio = priority(tag) if tag and kind == "alarm" else (None, None)
    t = data.get("t")
    return {"t": float(t) if isinstance(t, (int, float)) else None, "wall": wall, "clock": clock_text(wall, now),
            "mode": "", "kind": kind, "tag": tag, "priority": prio[0], "priority_name": prio[1], "text": text}


class _BankScreen(LoginScreen):
    """The bank's routes: the single arm's login, sessions and logout (inherited), its own geometry and frames."""

    def __init__(self, service, state_dir, clock, wall, frame_rate: float, name: str, berth=None):
        super().__init__(service, state_dir, clock, wall, frame_rate, name, bank_geometry(service.bank, berth))

    def session_json(self, s) -> dict:
        return {"user": s.user, "role": s.role.name.lower(), "csrf": s.csrf, "name": self.name, "bank": True,
                "replay": False, "last_seq": s.last_cmd,
                "commands": [a for a in BANK_COMMANDS if s.role >= COMMANDS[a]]}

    def journal(self) -> list[dict]:
        """The bank's journal, oldest first: its service's notes (:func:`bank_journal_entry`)."""
        now = self.wall()
        return [bank_journal_entry(wall, kind, reason, data, now) for wall, kind, reason, data in list(self.service.notes)]

    def command(self, s, msg: dict) -> tuple[bool, str]:
        """One command from the bank's screen: only the acknowledgement of its alarms (CSRF, sequence number and
        role checked as the arm's screen checks them); a refusal is logged as a security event."""
        action = msg.get("action")
        if not s.csrf_ok(msg.get("csrf")):
            why = "refused: no valid CSRF token"
        elif action not in BANK_COMMANDS:
            why = f"refused: the bank's screen takes no command {str(action)[:32]!r} (only {', '.join(BANK_COMMANDS)})"
        elif s.role < COMMANDS[action]:
            why = f"refused: {action} needs the {COMMANDS[action].name.lower()} role, {s.user} is {s.role.name.lower()}"
        else:
            why = s.take_seq(msg.get("seq"))
            why = None if why is None else f"refused: {why}"
        if why:
            self.note("security.command_refused", f"bank screen command of {s.user} refused: {why}", user=s.user,
                      action=str(action)[:64])
            return False, why
        self.service.acknowledge(s.user)
        return True, "ack sent"

    async def push(self, websocket, cursor, token: str | None) -> None:
        """Frames to one screen, at most ``frame_rate`` a second, a keep-alive at least every ``KEEPALIVE``."""
        last_seq, last_sent = None, -math.inf
        while True:
            snap = self.service.snapshot()
            now = time.monotonic()
            if snap is not None and (snap.seq != last_seq or now - last_sent >= KEEPALIVE):
                if self.sessions.get(token) is None:
                    await websocket.close(code=4401)
                    return
                await websocket.send_text(json.dumps(bank_frame(snap, sent_at=self.wall())))
                last_seq, last_sent = snap.seq, now
            await asyncio.sleep(1.0 / self.frame_rate)

    def _reply(self, s, text: str) -> str:
        """The acknowledgement of one message from the screen."""
        msg = _parsed(text)
        if msg is None:
            return ack(None, False, "refused: not a command")
        ok, message = self.command(s, msg)
        return ack(msg.get("seq"), ok, message, last_seq=s.last_cmd)

    async def ws(self, websocket) -> None:
        from fastapi import WebSocketDisconnect

        token = websocket.cookies.get(COOKIE)
        s = self.sessions.get(token)
        if s is None or not same_origin(websocket.headers.get("origin"), websocket.headers.get("host"),
                                        websocket.url.scheme):
            await websocket.close(code=4403)
            return
        await websocket.accept()
        sender = asyncio.create_task(self.push(websocket, None, token))
        try:
            while True:
                got = await websocket.receive()
                if got.get("type") == "websocket.disconnect":
                    break
                await websocket.send_text(self._reply(s, got.get("text") or ""))
        except WebSocketDisconnect:
            pass
        finally:
            sender.cancel()


def _parsed(text: str):
    """A WebSocket message as a dict, or None (too long, not JSON, not an object)."""
    if len(text) > WS_MESSAGE:
        return None
    try:
        msg = json.loads(text)
    except (ValueError, RecursionError):
        return None
    return msg if isinstance(msg, dict) else None


def create_bank_app(service, state_dir, *, clock: Callable[[], float] = time.monotonic,
                    wall: Callable[[], float] = time.time, frame_rate: float = FRAME_RATE, name: str | None = None,
                    berth=None):
    """The bank's screen, a FastAPI application.

    Parameters
    ----------
    service : BankService
        Its :meth:`snapshot`, :attr:`bank`, :meth:`note` and :meth:`acknowledge`.
    state_dir : path
        The OPC UA server's state directory: its ``users.toml``.
    clock : callable
        Monotonic seconds, for sessions and the login limit.
    wall : callable
        Wall-clock seconds, stamped on each frame.
    frame_rate : float
        Frames per second to each screen.
    name : str, optional
        Shown in the title (default the bank's name).
    berth : loadarm.params.berth.Berth, optional
        The ship drawn.

    Returns
    -------
    FastAPI
    """
    screen = _BankScreen(service, state_dir, clock, wall, frame_rate, name or service.bank.file.bank.name, berth)
    return screen_app(screen, f"loadarm bank ({screen.name})", "bank.html", ("/", "/bank"),
                      {"/api/bank": screen.get_geometry, "/api/journal": screen.get_journal})
