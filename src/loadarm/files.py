"""The file edges: every input read through one size-limited reader, every output written atomically.

Inputs (:func:`read_input`): regular files only (a FIFO, ``/dev/zero`` or a directory is refused before it is
opened, so nothing can hang), at most :data:`MAX_INPUT_BYTES`, UTF-8; parsed TOML nested at most
:data:`MAX_DEPTH` levels (:func:`check_depth`).

Outputs (:func:`atomic_write`, :func:`guard_outputs`): written to a temporary file in the same directory,
flushed to disk and renamed over the target, so a reader sees the old file or the new one, never half of one,
and a crash leaves no partial output. Before a command computes anything, :func:`guard_outputs` refuses an
output that is one of the command's inputs, two outputs that are one file, and an existing file that loadarm
did not write (:func:`written_by_loadarm`) unless ``force``: loadarm overwrites its own outputs (so ``make demo``
can run again), never a file it cannot recognise as its own.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import stat
import tempfile
import tomllib
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

from loadarm.errors import ConfigError, OutputError

__all__ = ["compact_json", "MAX_INPUT_BYTES", "MAX_DEPTH", "SIGNATURE", "HTML_MARK", "JSON_MARK", "PDF_TITLE_MARK", "read_input", "check_depth", "atomic_path",
           "atomic_write", "atomic_open", "written_by_loadarm", "guard_outputs", "read_toml", "printable",
           "check_input", "read_binary"]

#: Characters a terminal acts on rather than shows: C0 and C1 controls (tab and newline kept), and the invisible
#: and bidirectional format characters that make a line read other than it is.
_UNPRINTABLE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u200b-\u200f\u2028-\u202e\u2060-\u2069\ufeff"
                          "\ud800-\udfff]")       # lone surrogates (a path's undecodable bytes) cannot be written


def printable(text: str) -> str:
    """User text made safe for a terminal: every control or format character shown as its escape (``\\x1b``),
    never sent raw (found: a scenario named ``"\\u001b[2J"`` cleared the screen of ``run``, ``serve`` and ``log``).

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    return _UNPRINTABLE.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100
                            else f"\\u{ord(m.group()):04x}", text)

#: Largest input file read, bytes. An installation or scenario file is a few kilobytes.
MAX_INPUT_BYTES = 1 << 20
#: Deepest nesting of tables and arrays accepted in a TOML input (the deepest loadarm uses is 3).
MAX_DEPTH = 32
#: What loadarm writes into each output it makes (PNG text chunk, HTML meta, JSON key), to recognise it later.
SIGNATURE = "loadarm"

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def _kind(mode: int) -> str:
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def read_input(path: str | Path, what: str = "config", *, limit: int = MAX_INPUT_BYTES) -> str:
    """Read a text input: a regular file of at most ``limit`` bytes, UTF-8.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What it is, for messages ("config", "scenario").
    limit : int
        Largest size accepted, bytes.

    Returns
    -------
    str

    Raises
    ------
    ConfigError
        Missing, not a regular file (checked before opening: a FIFO or a device cannot block the read), too
        large, unreadable or not UTF-8; one line naming the file.
    """
    p = Path(path)
    data = read_binary(p, what, limit=limit)
    what = what if what.endswith("file") else f"{what} file"
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: {what} is not UTF-8 text (byte {exc.start})") from None


def check_input(path: str | Path, what: str, *, limit: int = MAX_INPUT_BYTES) -> int:
    """That an input is a regular file of at most ``limit`` bytes, without opening it (a FIFO or a device would
    block the read; a directory or a sparse terabyte is not a file of ours to read).

    Parameters
    ----------
    path : str or Path
    what : str
        What it is, for messages ("metocean", "certificate"; "file" is added unless it ends with it).
    limit : int
        Largest size accepted, bytes.

    Returns
    -------
    int
        Its size, bytes.

    Raises
    ------
    ConfigError
        One line naming the file and what it is instead.
    """
    p = Path(path)
    what = what if what.endswith("file") else f"{what} file"
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise ConfigError(f"{p}: {what} not found") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{p}: cannot read {what} ({exc.__class__.__name__})") from None
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{p}: {what} must be a regular file, this is {_kind(st.st_mode)}")
    if st.st_size > limit:
        raise ConfigError(f"{p}: {what} is {st.st_size} bytes; at most {limit} bytes are read")
    return st.st_size


def read_binary(path: str | Path, what: str, *, limit: int = MAX_INPUT_BYTES) -> bytes:
    """Read an input's bytes after :func:`check_input` (never more than ``limit``).

    Parameters
    ----------
    path : str or Path
    what : str
        What it is, for messages.
    limit : int
        Largest size accepted, bytes.

    Returns
    -------
    bytes

    Raises
    ------
    ConfigError
        As :func:`check_input`, or unreadable.
    """
    p = Path(path)
    check_input(p, what, limit=limit)
    what = what if what.endswith("file") else f"{what} file"
    try:
        with open(p, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read {what} ({exc.__class__.__name__})") from None
    if len(data) > limit:                              # grew since the stat
        raise ConfigError(f"{p}: {what} is larger than {limit} bytes")
    return data


#: The kind of input (:mod:`loadarm.params.kinds`) a reader of :func:`read_toml` expects, by its ``what``.
_KIND_OF = {"config": "installation", "scenario": "scenario", "berth": "berth"}


def read_toml(path: str | Path, what: str = "config") -> dict[str, Any]:
    """Read a TOML file into a mapping, with one-line errors.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str, optional
        What the file is, for messages ("config", "scenario").

    Returns
    -------
    dict
        The parsed TOML.

    Raises
    ------
    ConfigError
        If the file is missing, not a regular file, larger than :data:`loadarm.files.MAX_INPUT_BYTES`,
        unreadable, not valid TOML, or nested deeper than :data:`loadarm.files.MAX_DEPTH`.
    """
    p = Path(path)
    text = read_input(p, what)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML: {exc}", source=str(p), expected=_KIND_OF.get(what)) from None
    except RecursionError:
        raise ConfigError(f"{p}: not valid TOML: values nested too deeply") from None
    check_depth(data, str(p))
    return data


def check_depth(obj: Any, source: str, limit: int = MAX_DEPTH) -> None:
    """Refuse a parsed document nested deeper than ``limit`` (iteratively: no recursion to exhaust).

    Parameters
    ----------
    obj : Any
        Parsed TOML (dicts, lists, scalars).
    source : str
        File name for the message.
    limit : int
        Deepest nesting accepted.

    Raises
    ------
    ConfigError
    """
    stack = [(obj, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > limit:
            raise ConfigError(f"{source}: values nested more than {limit} levels deep; at most {limit} are accepted")
        if isinstance(node, dict):
            stack.extend((v, depth + 1) for v in node.values())
        elif isinstance(node, list):
            stack.extend((v, depth + 1) for v in node)


@contextlib.contextmanager
def atomic_path(path: str | Path, *, private: bool = False) -> Iterator[Path]:
    """A temporary file's path next to ``path``, for writers that take a path (NetCDF); on a clean exit it is
    given the permissions of a new file (``private``: its owner's alone, 0600, as it was created) and renamed
    over ``path``, on an error removed.

    Parameters
    ----------
    path : str or Path
        The target; parent directories are created.
    private : bool
        Keep the file readable by its owner only (a private key, a password file).

    Yields
    ------
    Path
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o600 if private else 0o666 & ~_umask())
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", *, private: bool = False, **kwargs) -> Iterator[IO]:
    """Open a temporary file next to ``path``; on a clean exit flush it to disk and rename it over ``path``
    (:func:`atomic_path`).

    Parameters
    ----------
    path : str or Path
        The target; parent directories are created.
    mode : {'w', 'wb'}
        Text or binary.
    private : bool
        Owner-only permissions (:func:`atomic_path`).
    **kwargs
        Passed to :func:`open` (``encoding``, ``newline``).

    Yields
    ------
    file object
    """
    with atomic_path(path, private=private) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh
        fh.flush()
        os.fsync(fh.fileno())


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def compact_json(doc: Any, *, allow_nan: bool = True) -> str:
    """``doc`` as indented JSON with each innermost list on one line (a stored run's numbers a line), ending in a
    newline: the studies' basis files.

    Parameters
    ----------
    doc : object
        JSON-serialisable.
    allow_nan : bool
        As :func:`json.dumps`'s.

    Returns
    -------
    str
    """
    text = json.dumps(doc, indent=2, allow_nan=allow_nan)
    return re.sub(r"\[\s*([^\[\]{}]*?)\s*\]", lambda m: "[" + " ".join(m.group(1).split()) + "]", text) + "\n"


def atomic_write(path: str | Path, data: str | bytes, *, private: bool = False) -> Path:
    """Write text (UTF-8) or bytes to ``path`` atomically (:func:`atomic_open`).

    Parameters
    ----------
    path : str or Path
    data : str or bytes
    private : bool
        Owner-only permissions, 0600 from the file's creation on (:func:`atomic_path`).

    Returns
    -------
    Path
    """
    if isinstance(data, bytes):
        with atomic_open(path, "wb", private=private) as fh:
            fh.write(data)
    else:
        with atomic_open(path, "w", private=private, encoding="utf-8", newline="") as fh:
            fh.write(data)
    return Path(path)


#: How loadarm's CSV outputs begin (the plan's samples, 2D and 3D).
_CSV_HEADERS = (b"t_s,x_m,y_m,alpha_deg,", b"t_s,x_m,y_m,z_m,slew_deg,alpha_deg,")
_PNG = b"\x89PNG\r\n\x1a\n"
#: The end of the first line of a metocean record loadarm wrote (``# loadarm <version> metocean record``).
METOCEAN_MARK = b" metocean record"
#: The HTML report's mark, in its head.
HTML_MARK = f'<meta name="generator" content="{SIGNATURE}'
#: The JSON summary's first key.
JSON_MARK = f'{{\n  "generator": "{SIGNATURE}'
#: The report's PDF mark: its title (the HTML's ``<title>``, which Chromium writes into the PDF's first object)
#: ends with ``[loadarm <version>]``.
PDF_TITLE_MARK = f"[{SIGNATURE} "


def written_by_loadarm(path: str | Path) -> bool:
    """Whether an existing file carries loadarm's mark, by its format: a PNG with a ``Software`` text chunk
    starting with :data:`SIGNATURE`, an HTML file with :data:`HTML_MARK` in its head, a JSON file whose first
    key is loadarm's ``generator`` (:data:`JSON_MARK`), the report's PDF (:data:`PDF_TITLE_MARK` in its title), a
    CSV with one of loadarm's headers, or a Parquet file
    whose key-value metadata has loadarm's ``generator``. A text that
    merely mentions loadarm is not loadarm's.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError:
        return False
    if head.startswith(_PNG):
        return b"Software\x00" + SIGNATURE.encode() in head
    if head[:15].lower() == b"<!doctype html>":
        return HTML_MARK.encode() in head[:4096]
    if head.startswith(b"{"):
        return head.startswith(JSON_MARK.encode())
    if head.startswith(b"%PDF-"):                     # the report printed by Chromium: the mark in its title
        title = head[:2048].split(b"/Title", 1)[1:]
        return bool(title) and PDF_TITLE_MARK.encode() in title[0].split(b"\n", 1)[0]
    if head.startswith(b"PAR1"):                      # Parquet: the generator in its key-value metadata
        try:
            import pyarrow.parquet as pq

            meta = pq.read_metadata(path).metadata or {}
        except (ImportError, OSError, ValueError):
            return False
        return meta.get(b"generator", b"").startswith(SIGNATURE.encode())
    first = head.split(b"\n", 1)[0]
    if first.startswith(b"# " + SIGNATURE.encode() + b" ") and first.endswith(METOCEAN_MARK):
        return True                                   # a metocean record loadarm wrote
    return head.startswith(_CSV_HEADERS)


def _same(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def guard_outputs(outputs: Mapping[str, Path | None] | Iterable[tuple[str, Path | None]], inputs: Iterable[Path] = (),
                  *, force: bool = False, appended: Iterable[str] = ()) -> None:
    """Refuse outputs that would destroy something, before any work is done.

    Parameters
    ----------
    outputs : mapping or iterable of (str, Path or None)
        Option name (for the message) and output file; None for an output not asked for.
    inputs : iterable of Path
        The command's input files.
    force : bool
        Overwrite an existing file loadarm did not write.
    appended : iterable of str
        Options whose file is appended to, not replaced (the event log, which identifies itself): only the
        same-file checks apply to them.

    Raises
    ------
    OutputError
        An output is an input of the same command, two outputs are one file, an output is a directory or a
        special file, or an existing file is not loadarm's and ``force`` is off.
    """
    pairs = outputs.items() if isinstance(outputs, Mapping) else outputs
    given = [(k, Path(v)) for k, v in pairs if v is not None]
    ins = [Path(i) for i in inputs]
    appends = set(appended)
    seen: dict[Path, str] = {}
    for name, p in given:
        key = Path(os.path.abspath(p))
        if key in seen:
            raise OutputError(f"{name} {p} and {seen[key]} name the same file")
        seen[key] = name
        for i in ins:
            if key == Path(os.path.abspath(i)) or _same(p, i):
                raise OutputError(f"{name} {p} is an input of this command ({i}); choose another output file")
        if name not in appends and os.path.lexists(p):
            try:
                st = os.stat(p)
            except OSError as exc:
                raise OutputError(f"{name} {p}: cannot be replaced ({exc.__class__.__name__})") from None
            if not stat.S_ISREG(st.st_mode):
                raise OutputError(f"{name} {p} is {_kind(st.st_mode)}, not a file loadarm can replace")
            if not force and not written_by_loadarm(p):
                raise OutputError(f"{name} {p} exists and was not written by loadarm; --force replaces it")
