"""A campaign's runs, one JSON line each, so that a campaign too long for one sitting is run in parts and merged
exactly.

``loadarm campaign --runs FILE.jsonl`` appends every run's verdict as its batch ends. Run again with the same
scenario, plant and ``--vary``, it runs only the seeds the file does not hold yet and reports over every seed of
its range: the medians and counts of the whole campaign, not a mean of the parts' medians. A campaign of a
thousand tracked seeds (a third of a CPU-hour per hundred) is run a hundred seeds at a time, on several days
or machines, into one file.

The file's first line is its header: loadarm's mark, the scenario's path and the digest of its contents (and of
the installation and berth files it names), the plant and the varied keys. A file with another header is
refused in one line. Every later line is one run, with the digest of loadarm's own code that ran it (the
result states how many runs each code ran: runs are reused across versions of the code, and the report says
so). A line cut short by a killed process is dropped when the file is read and cut off before the next append.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict
from pathlib import Path

from loadarm.errors import ConfigError
from loadarm.files import SIGNATURE

__all__ = ["RUNS_KIND", "RUNS_FILE_BATCH", "code_digest", "inputs_digest", "read_stored", "RunsFile", "Tally"]

#: The header's ``kind``.
RUNS_KIND = "campaign runs"
#: The most runs in one batch of a campaign that keeps a runs file (each batch's runs are appended as it ends; a
#: tracked run takes 10-20 s of a core, the moored ship compiled once a batch about 1 s; found: 250-run batches,
#: an hour of a worker each, none on file until done).
RUNS_FILE_BATCH = 8


def code_digest() -> str:
    """The digest of loadarm's own code: every module's source, by its path in the package (SHA-256, hex).

    Returns
    -------
    str
    """
    h = hashlib.sha256()
    package = Path(__file__).resolve().parents[1]
    for f in sorted(package.rglob("*.py")):
        h.update(str(f.relative_to(package)).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def inputs_digest(scenario: str, also: Sequence[str | Path] = ()) -> str:
    """The digest of a campaign's inputs: the scenario file's contents and those of the files it names
    (installation, berth), resolved as the scenario resolves them, and of the files ``also`` names (a bank and
    its installations).

    Parameters
    ----------
    scenario : str
        The scenario file.
    also : sequence of str or Path
        Further input files.

    Returns
    -------
    str
        SHA-256, hex.
    """
    import tomllib

    path = Path(scenario)
    h = hashlib.sha256(path.read_bytes())
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError):   # the scenario's own check names the fault
        return h.hexdigest()
    named = [data.get("scenario", {}).get("installation"), data.get("ship", {}).get("berth")]
    for rel in named:
        if isinstance(rel, str) and (path.parent / rel).is_file():
            h.update(rel.encode() + b"\0" + (path.parent / rel).read_bytes())
    for other in also:
        h.update(Path(other).name.encode() + b"\0" + Path(other).read_bytes())
    return h.hexdigest()


class RunsFile:
    """One campaign's runs file (see the module's text).

    Parameters
    ----------
    path : Path
        The JSON-lines file (created with its header if it does not exist).
    scenario : str
        The scenario file, as given.
    plant : str or None
    vary : sequence of (key, lo, hi)
        The varied keys and their ranges.
    bank : str or Path, optional
        A bank's campaign (``loadarm campaign --bank``): the bank file; its contents and those of ``also`` join
        the inputs' digest, and its name the header.
    also : sequence of str or Path
        Further input files (the bank's installations).

    Raises
    ------
    ConfigError
        The file exists and is not this campaign's runs file: not loadarm's, another scenario (or other contents
        of it), plant or draws.
    """

    def __init__(self, path: str | Path, scenario: str, plant: str | None, vary: Sequence[tuple[str, float, float]],
                 bank: str | Path | None = None, also: Sequence[str | Path] = ()):
        self.path = Path(path)
        self.header = {"generator": SIGNATURE, "kind": RUNS_KIND, "scenario": Path(scenario).name,
                       "inputs_sha256": inputs_digest(scenario, ([bank] if bank else []) + list(also)),
                       "plant": plant, "vary": [[k, float(lo), float(hi)] for k, lo, hi in vary]}
        if bank is not None:                        # a single arm's header has no such key (files before it)
            self.header["bank"] = Path(bank).name
        self.code = code_digest()[:16]
        self._lines: list[dict] = []
        if self.path.exists():
            self._read()

    def _read(self) -> None:
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        whole, cut = lines[:-1], lines[-1]          # the last piece has no newline: empty, or cut by a kill
        try:
            head = json.loads(whole[0]) if whole else None
        except (json.JSONDecodeError, UnicodeDecodeError):
            head = None
        if not isinstance(head, dict) or head.get("generator") != SIGNATURE or head.get("kind") != RUNS_KIND:
            raise ConfigError(f"--runs {self.path}: not a loadarm campaign runs file (its first line is not the "
                              "header loadarm writes); give a new file name")
        for key in ("scenario", "bank", "inputs_sha256", "plant", "vary"):
            if head.get(key) != self.header.get(key):
                raise ConfigError(f"--runs {self.path}: its runs are of another campaign ({key} "
                                  f"{_short(head.get(key))}, this one {_short(self.header.get(key))}); give a new "
                                  "file name")
        for n, line in enumerate(whole[1:], start=2):
            try:
                got = json.loads(line)
                ok = isinstance(got["run"]["seed"], int) and isinstance(got["code"], str)
            except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError):
                ok = False
            if not ok:
                raise ConfigError(f"--runs {self.path}: line {n} is not a run (JSON with its code and seed); the "
                                  "file was changed by hand: give a new file name")
            self._lines.append(got)
        if cut:                                     # a line cut short: dropped before the next append
            with open(self.path, "r+b") as fh:
                fh.truncate(len(raw) - len(cut))

    def seeds(self) -> set[int]:
        """The seeds the file holds.

        Returns
        -------
        set of int
        """
        return {int(line["run"]["seed"]) for line in self._lines}

    def runs(self, seeds: Iterable[int]) -> list[tuple[dict, str]]:
        """The stored runs of the given seeds, each as (the run's fields, the code digest that ran it).

        Parameters
        ----------
        seeds : iterable of int

        Returns
        -------
        list of (dict, str)
        """
        wanted = set(seeds)
        return [(line["run"], line["code"]) for line in self._lines if line["run"]["seed"] in wanted]

    def append(self, runs: Iterable) -> None:
        """Append runs (dataclasses with a ``seed``), the header first if the file is new; flushed to disk.

        Parameters
        ----------
        runs : iterable of dataclass
        """
        new = [{"code": self.code, "run": asdict(r)} for r in runs]
        self._lines.extend(new)
        text = "".join(json.dumps(line, separators=(",", ":")) + "\n" for line in new)
        if not self.path.exists():
            text = json.dumps(self.header, separators=(",", ":")) + "\n" + text
        with open(self.path, "a", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())


def _short(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 24 else text[:21] + "..."


class Tally:
    """A campaign's runs as its batches end: the runs so far (those a runs file held first), each new batch
    appended to the file, how many runs each code ran, and the progress. The one place of this bookkeeping (the
    arm's campaign and the bank's).

    Parameters
    ----------
    runs : list
        The runs held already (extended in place).
    store : RunsFile or None
    codes : Counter
        Runs per code digest, of those held (counted on in place).
    total : int
        Runs the campaign wants, for the progress.
    progress : callable, optional
        ``progress(done, total)``: called once now if runs are held, then after every batch.
    """

    def __init__(self, runs: list, store: RunsFile | None, codes: Counter, total: int,
                 progress: Callable[[int, int], None] | None = None):
        self.runs, self.store, self.codes, self.total, self.progress = runs, store, codes, total, progress
        if progress is not None and runs:
            progress(len(runs), total)

    def __call__(self, part: Sequence) -> None:
        """One batch's runs have ended.

        Parameters
        ----------
        part : sequence of dataclass
        """
        self.runs.extend(part)
        if self.store is not None:
            self.store.append(part)
            self.codes[self.store.code] += len(part)
        if self.progress is not None:
            self.progress(len(self.runs), self.total)


def _refuse(path: Path, n: int, what: str) -> ConfigError:
    return ConfigError(f"{path}: line {n}: {what}", source=str(path))


def _check_header(path: Path, lines: list[str], scenarios: Path) -> tuple[dict, Path]:
    try:
        head = json.loads(lines[0]) if lines else None
    except ValueError:
        head = None
    if not isinstance(head, dict) or head.get("generator") != SIGNATURE or head.get("kind") != RUNS_KIND:
        raise _refuse(path, 1, "not the header of a loadarm campaign runs file")
    if head.get("bank") or not isinstance(head.get("scenario"), str) or not isinstance(head.get("inputs_sha256"), str):
        raise _refuse(path, 1, f"scenario = {head.get('scenario')!r}, bank = {head.get('bank')!r}: a single arm's "
                               "campaign of one scenario expected")
    scenario = scenarios / head["scenario"]
    if not scenario.is_file():
        raise _refuse(path, 1, f"scenario = {head['scenario']!r}: no such file in {scenarios}")
    if inputs_digest(str(scenario)) != head["inputs_sha256"]:
        raise _refuse(path, 1, f"inputs_sha256 = {head['inputs_sha256'][:16]}...: {scenario} and the files it "
                               f"names now digest to {inputs_digest(str(scenario))[:16]}...: run on other inputs")
    return head, scenario


def read_stored(path: str | Path, scenarios: str | Path = "examples/scenarios") -> tuple[dict, Path, dict]:
    """A single arm's campaign runs file, read for a study and checked: its header is loadarm's, of one scenario
    (not a bank's) that is in ``scenarios`` and digests today as it did (the same inputs); every line a run with
    an integer seed and an object of draws. A later line for a seed wins, as the campaign reads it; a torn last
    line (the campaign cuts it before its next append) is skipped. The file is only read.

    Parameters
    ----------
    path : str or Path
        The runs file.
    scenarios : str or Path
        The folder its scenario is in.

    Returns
    -------
    header : dict
    scenario : Path
        The scenario file.
    runs : dict of int to (int, dict)
        By seed: the line number and the stored run.

    Raises
    ------
    ConfigError
        One line naming the file, the line and what is wrong.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read it ({exc})", source=str(path)) from None
    lines = text.splitlines()
    head, scenario = _check_header(path, lines, Path(scenarios))
    runs = {}
    for n, line in enumerate(lines[1:], start=2):
        try:
            run = json.loads(line)["run"] if line else None
            seed, draws = run["seed"], run["draws"]
        except (ValueError, KeyError, TypeError):
            if n == len(lines) and not text.endswith("\n"):
                continue                                    # a torn last line: the campaign cuts it
            raise _refuse(path, n, "not a run: {\"run\": {\"seed\": ..., \"draws\": {...}}} expected") from None
        if isinstance(seed, bool) or not isinstance(seed, int) or not isinstance(draws, dict):
            raise _refuse(path, n, f"seed = {seed!r}, draws = {draws!r}: an integer and an object expected")
        runs[seed] = (n, run)
    return head, scenario, runs
