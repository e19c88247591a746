"""Reading the user's files (JSON, GeoJSON, TOML) without ever ending in a traceback.

Every loader of citysynth (problem and structure files, GeoJSON, library manifests,
city.toml, part databases, run manifests and layouts for ``diff``) reads through here,
so each of these becomes one message that names the file and says how to fix it, raised
as the caller's own error class (the CLI prints it and exits 2):

- a path that is missing, a folder, unreadable, or larger than :data:`MAX_MB` megabytes
  (``$CITYSYNTH_MAX_INPUT_MB`` raises the limit; parsed JSON takes about 20 times its
  file size in memory, so the size is checked before anything is read);
- text that is not UTF-8 (Latin-1, a Windows code page, UTF-16): the offending byte and
  line are named; a UTF-8 byte-order mark is accepted;
- JSON that is not valid, is empty, uses ``NaN``/``Infinity`` (not JSON; a bound or
  coordinate that is not a number), or is nested deeper than :data:`MAX_DEPTH` levels
  (the parser's recursion is caught, and the parsed value is walked without recursion,
  so no later stage can overflow the stack on it);
- TOML that is not valid.

Text that is not JSON says what it looks like (junk or NUL bytes after the JSON, a
second JSON text, CSV, XML, an HTML page), and every message quotes a file's values as
the file spells them (:func:`shown`: ``null``, ``"a"``, not Python's ``None``, ``'a'``).

This module lives in the solver package only because that is the package every other
one imports; it depends on nothing but the standard library.
"""

from __future__ import annotations

import datetime
import json
import os
import re
import stat
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

MAX_MB = 100                 # default size limit of one input file: parsed, JSON takes
                             # about 20 times its size (a 228 MB problem file peaked at
                             # 5.1 GB), so 100 MB keeps within the 2 GB memory budget
MAX_DEPTH = 100              # deepest nesting of JSON accepted (GeoJSON needs about 8)
SIZE_ENV = "CITYSYNTH_MAX_INPUT_MB"
UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")
UTF8_BOM = b"\xef\xbb\xbf"


def limit_mb() -> float:
    """The size limit of one input file in MB (``$CITYSYNTH_MAX_INPUT_MB``, else
    :data:`MAX_MB`)."""
    try:
        v = float(os.environ.get(SIZE_ENV, MAX_MB))
    except ValueError:
        return MAX_MB
    return v if v > 0 and v == v else MAX_MB


def read_bytes(path: str | Path, what: str, error: type[Exception]) -> bytes:
    """The bytes of the ``what`` file at ``path`` (e.g. "GeoJSON", "problem")."""
    p = Path(path)
    check_file(p, what, error)
    try:
        return p.read_bytes()
    except OSError as exc:
        raise _unreadable(p, what, exc, error) from None


def check_file(path: str | Path, what: str, error: type[Exception]) -> int:
    """The size of the ``what`` file at ``path``, once it is known to be a regular file
    no larger than the limit (:data:`MAX_MB`): what any reader checks before it reads,
    this module's or another library's (GDAL's, for a GeoPackage)."""
    p = Path(path)
    try:
        if p.is_dir():
            raise error(f"{p}: a folder, not a {what} file; give the file's path")
        st = p.stat()
        if not stat.S_ISREG(st.st_mode):   # a FIFO or a device would block or never end
            raise error(f"{p}: not a regular file; give the path of a {what} file")
        size = st.st_size
        limit = limit_mb()
        if size > limit * 1e6:
            raise error(f"{p}: {size / 1e6:.0f} MB, larger than the {limit:g} MB a {what} "
                        f"file may have (reading it would take about {size * 20 / 1e9:.1f}"
                        f" GB of memory); split it, or raise ${SIZE_ENV}")
        return size
    except OSError as exc:
        raise _unreadable(p, what, exc, error) from None


def check_data_size(path: str | Path, size: int, how: str, fix: str,
                    error: type[Exception]) -> None:
    """Refuse a file whose data, ``how`` it is read (unzipped, with its dictionaries
    written out), is past the input limit, though the file itself is not: a few MB of
    archive or Parquet can hold gigabytes. ``fix``: how to keep less of it."""
    limit = limit_mb()
    if size > limit * 1e6:
        raise error(f"{path}: {size / 1e6:,.0f} MB of data {how}, more than the {limit:g} "
                    f"MB an input may hold (reading it would take about "
                    f"{size * 20 / 1e9:.1f} GB of memory); {fix}, or raise ${SIZE_ENV}")


def _unreadable(p: Path, what: str, exc: OSError, error: type[Exception]) -> Exception:
    if isinstance(exc, FileNotFoundError):
        return error(f"{p}: cannot read the {what} file: no such file; check the path")
    return error(f"{p}: cannot read the {what} file ({exc.strerror or exc}); check that "
                 "it exists and that you may read it")


BINARY_FORMATS = (   # the signatures of files GIS and other tools write instead of text
    (b"SQLite format 3\x00", "a GeoPackage or SQLite database"),
    (b"\x00\x00\x27\x0a", "an ESRI Shapefile"),
    (b"fgb\x03", "a FlatGeobuf file"),
    (b"\x1f\x8b", "gzip-compressed"),
    (b"PK\x03\x04", "a ZIP archive (a zipped Shapefile, KMZ or similar)"),
    (b"glTF", "a binary glTF (GLB) model"),
    (b"\x89PNG", "a PNG image"),
    (b"PAR1", "a (Geo)Parquet file"),
)


def _binary_format(data: bytes, p: Path | str, what: str) -> str | None:
    """What a binary file given for a text file is, and how to get the text, if known."""
    for magic, name in BINARY_FORMATS:
        if data.startswith(magic):
            how = (f"convert it, e.g. ogr2ogr -f GeoJSON out.geojson {p}"
                   if what == "GeoJSON" and "image" not in name and "model" not in name
                   else f"give the {what} file instead")
            if name == "gzip-compressed":
                how = f"uncompress it first (gunzip), then give the {what} file"
            return f"{p}: {name}, not a {what} file; {how}"
    return None


def decode(data: bytes, p: Path | str, what: str, error: type[Exception]) -> str:
    """``data`` as UTF-8 text (a UTF-8 byte-order mark dropped)."""
    binary = _binary_format(data, p, what)
    if binary:
        raise error(binary)
    if data.startswith(UTF16_BOMS):
        raise error(f"{p}: UTF-16 text; {what} files are UTF-8: save it as UTF-8")
    if data.startswith(UTF8_BOM):
        data = data[len(UTF8_BOM):]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        hint = "UTF-16 text" if b"\x00" in data[:64] else "another encoding, such as Latin-1"
        raise error(f"{p}: not UTF-8 text (byte 0x{data[exc.start]:02x} on line {line}; "
                    f"perhaps {hint}); {what} files are UTF-8: save it as UTF-8") from None


def read_text(path: str | Path, what: str, error: type[Exception]) -> str:
    return decode(read_bytes(path, what, error), path, what, error)


def depth_error(data: Any, max_depth: int = MAX_DEPTH) -> bool:
    """Whether ``data`` nests lists and objects more than ``max_depth`` deep (walked
    without recursion, one iterator a level: a stack of every child to visit took
    gigabytes for a file of 33 million empty lists, and the reader died of it). A list
    or object holding no list or object is seen whole, by the types of its values (in
    C), not value by value: the walk of a file of 4 million numbers took six times as
    long as parsing it."""
    if not isinstance(data, dict | list):
        return False
    stack: list[Iterator[Any]] = [_containers(data)]
    while stack:
        value = next(stack[-1], _END)
        if value is _END:
            stack.pop()
        else:
            if len(stack) >= max_depth:
                return True
            stack.append(_containers(value))
    return False


def _containers(value: Any) -> Iterator[Any]:
    """The lists and objects among ``value``'s values (an object's, or a list's items)."""
    values = value.values() if isinstance(value, dict) else value
    if len(values) > 8 and not any(issubclass(t, dict | list) for t in set(map(type, values))):
        return iter(())   # (a short one, such as a point's coordinates, is quicker walked)
    return (v for v in values if isinstance(v, dict | list))


_END = object()   # an iterator's end, in depth_error's walk


def parse_json(text: str, p: Path | str, what: str, error: type[Exception], *,
               max_depth: int = MAX_DEPTH) -> Any:
    """The JSON value of ``text`` (the ``what`` file ``p``); see the module. JSON that
    does not fit in memory once parsed (it takes 20 times its size and more: 33
    million empty lists in 99 MB) is refused, not a crash."""
    try:
        return _parse_json(text, p, what, error, max_depth)
    except MemoryError:
        raise error(f"{p}: {len(text) / 1e6:,.0f} MB of JSON that does not fit in the "
                    "memory this machine gives citysynth once parsed (JSON takes 20 times "
                    f"its size and more); a {what} file this large holds something else: "
                    "check that it is the right file") from None


FLOAT_DIGITS = 308   # an integer of more digits is past every float (1.8e308 at most)
_DIGITS = bytes(0x31 if 0x30 <= b <= 0x39 else 0x30 for b in range(256))   # "1" or "0"


def _past_float(text: str) -> bool:
    """Whether ``text`` holds a run of more than :data:`FLOAT_DIGITS` digits, found in
    C (bytes translated to "1" for a digit, "0" else, then searched): a regular
    expression took 1 s on a file of 4 million numbers, four times parsing it."""
    return b"1" * (FLOAT_DIGITS + 1) in text.encode("utf-8", "surrogatepass").translate(_DIGITS)


def _json_int(digits: str) -> int | float:
    """A JSON integer, as Python's parser reads it, except one past every float
    (``1`` and 309 zeros or more): read as the float it rounds to, infinity, as
    ``1e400`` is. As an int it passed every check of a value's type and then crashed
    the first sum or comparison with a float ("int too large to convert to float")."""
    if len(digits) - digits.startswith("-") > FLOAT_DIGITS:
        return float(digits)
    return int(digits)


def _parse_json(text: str, p: Path | str, what: str, error: type[Exception],
                max_depth: int) -> Any:
    def constant(name: str) -> Any:
        raise error(f"{p}: {name} is not a JSON number; write a number (or leave the "
                    "value out)")

    if not text.strip():
        raise error(f"{p}: empty; a {what} file holds JSON")
    twice: list[bool] = []
    try:
        # the integer hook only where an integer may be past every float: called for
        # each integer, it made a file of 4 million of them parse 65 % slower
        data = json.loads(text, parse_constant=constant,
                          parse_int=_json_int if _past_float(text) else None,
                          object_pairs_hook=_object_hook(twice))
    except json.JSONDecodeError as exc:
        raise error(_not_json(text, p, what, exc)) from None
    except error:        # NaN, Infinity: the message constant() gave (error may be a ValueError)
        raise
    except ValueError:   # Python's guard against integers of over 4,300 digits
        raise error(f"{p}: a number of thousands of digits; no {what} needs one: write it "
                    "with an exponent (1e300) or check that it is the right file") from None
    except RecursionError:
        data = None
        deep = True
    else:
        deep = depth_error(data, max_depth)
    if deep:
        raise error(f"{p}: JSON nested more than {max_depth} levels deep; a {what} file "
                    "never is: check that it is the right file")
    repeated = _duplicate_key(data) if twice else None
    if repeated:
        key, where = repeated
        raise error(f"{p}: key {key!r} is given twice in {where}; JSON keys must be unique "
                    "(the second would silently replace the first): keep one of them")
    if "\\u" in text and _lone_surrogate(data):
        raise error(f"{p}: a string holds half of a UTF-16 surrogate pair (a \\udXXX "
                    "escape without its partner), which is no character: fix the escape")
    return data


def _not_json(text: str, p: Path | str, what: str, exc: json.JSONDecodeError) -> str:
    """The message for text the JSON parser refused: where, and what the text looks
    like when that explains it (another format, junk or padding after the JSON, a
    GeoJSON Text Sequence), with the fix; else the parser's own words."""
    where = f"{p}: not valid JSON at line {exc.lineno}, column {exc.colno}"
    body = text.lstrip("\ufeff \t\r\n")
    if exc.msg == "Extra data":
        rest = text[exc.pos:]
        if not rest.strip("\x00 \t\r\n"):
            return (f"{p}: {rest.count(chr(0)):,} NUL bytes follow the end of its JSON "
                    f"(line {exc.lineno}): the file was padded or not written whole; "
                    "remove them, or write the file again")
        if what == "GeoJSON" and rest.lstrip(" \t\r\n").startswith(("{", "\x1e")):
            return (f"{where}: a second JSON text follows the first; it looks like a "
                    "GeoJSON Text Sequence (a feature per line, or RFC 8142's record "
                    "separators): give one FeatureCollection, e.g. ogr2ogr -f GeoJSON "
                    f"out.geojson {p}")
        return (f"{where}: text after the end of the JSON ({shown(rest.strip())}): a "
                f"{what} file holds one JSON value; remove what follows it, or check "
                "that the file was saved whole")
    if body and not body.strip("\x00"):
        return (f"{p}: {len(body):,} NUL bytes and no JSON: the file was never written "
                "whole (a crash or a full disk?); write it again")
    if exc.msg.startswith("Unterminated string") or not text[exc.pos:].strip("\x00 \t\r\n"):
        return (f"{where}: the file ends inside its JSON, cut short: write it again, or "
                "check that it was saved or downloaded whole")
    if what == "GeoJSON" and body.startswith("\x1e"):
        return (f"{where}: {exc.msg}; it looks like a GeoJSON Text Sequence (RFC 8142's "
                "record separators): give one FeatureCollection, e.g. ogr2ogr -f "
                f"GeoJSON out.geojson {p}")
    if exc.pos == len(text) - len(body):      # the very first character is not JSON
        kind = _other_format(body)
        if kind == "an HTML page":
            return (f"{p}: {kind}, not JSON; a {what} file holds JSON: check that it "
                    "is the right file (a download that saved a web or error page?)")
        if kind:
            fix = (f"convert it, e.g. ogr2ogr -f GeoJSON out.geojson {p}"
                   if what == "GeoJSON" else "check that it is the right file")
            return f"{p}: {kind}, not JSON; a {what} file holds JSON: {fix}"
    return f"{where}: {_PARSER_SAYS.get(exc.msg, exc.msg)}"


_PARSER_SAYS = {   # the JSON parser's words, as a user reads them
    "Expecting value": "a value (a number, text in double quotes, true, false, null, a "
                       "list or an object) was expected here",
    "Expecting property name enclosed in double quotes":
        "a key in double quotes was expected here (JSON has no comma before a closing "
        "brace, and no single quotes)",
    "Expecting ',' delimiter": "a comma was expected here, between two values",
    "Expecting ':' delimiter": "a colon was expected here, after a key",
    "Invalid control character at": "a line break or tab inside text in quotes (write "
                                    "it as \\n or \\t)",
    "Invalid \\escape": "a backslash that starts no escape (write a backslash as \\\\)",
}


def _other_format(body: str) -> str:
    """What text that is not JSON from its first character looks like, or ""."""
    head = body[:512].lower()
    if head.startswith("<"):
        if head.startswith(("<!doctype html", "<html")) or "<html" in head:
            return "an HTML page"
        return "XML (GML, KML or another XML format)"
    first = body.partition("\n")[0]
    if ("," in first or "\t" in first or ";" in first) and not first.lstrip().startswith(
            ("{", "[", '"')):
        return "CSV or other delimited text"
    return ""


def check_printable(text: str, where: str, what: str, error: type[Exception]) -> None:
    """Refuse a name holding a character that is not printed as itself (a line break,
    a NUL, a terminal escape, a right-to-left override): listings and summaries print
    names, and such a one broke their lines, cleared or recoloured the terminal, or
    reversed the text after it. The one check for part ids, style and library names
    and a problem's element ids and resource names."""
    if text.isprintable():
        return
    bad = next(c for c in text if not c.isprintable())
    raise error(f"{where}: {what} {shown(text)} holds a character that prints as no "
                f"letter (U+{ord(bad):04X}: a line break, tab, control or invisible mark); "
                "write it in printable characters")


def shown(v: Any, most: int = 60) -> str:
    """A value from a user's file as a message quotes it, in the file's own spelling
    (TOML, JSON, OSM tags): true, not True; "a", not 'a'; 1979-05-27T07:32:00+00:00,
    not datetime.datetime(...); cut to ``most`` characters."""
    if isinstance(v, bool):
        text = "true" if v else "false"
    elif v is None:
        text = "null"
    elif isinstance(v, int):
        text = f"{v:,}" if abs(v) >= 10_000 else repr(v)
    elif isinstance(v, float):
        # 1e+09 for 1e9 (repr: 1000000000.0) where it is exact and much shorter, but a
        # northing as written (5820000.0, not 5.82e+06)
        text, short = repr(v), f"{v:g}"
        text = short if len(short) <= len(text) - 4 and float(short) == v else text
    elif isinstance(v, datetime.date | datetime.time):
        text = v.isoformat()
    else:
        text = printable(json.dumps(v, ensure_ascii=False, default=str))
    return text if len(text) <= most else text[:most - 3] + "..."


def first_few(names: list[str], most: int, sep: str = ", ", total: int | None = None
              ) -> str:
    """The first ``most`` of ``names`` joined by ``sep``, and how many more there are:
    "a, b, c and 7 more". A message naming what a file holds, or what it refused,
    stays a line long however many there are. ``total``: how many there are in all,
    where only the first few were worth naming."""
    total = len(names) if total is None else total
    more = f" and {total - most:,} more" if total > most else ""
    return sep.join(names[:most]) + more


def printable(text: str) -> str:
    """``text`` with letters as themselves (é) and what prints as no letter escaped
    (``\\u000a``): JSON leaves a right-to-left override or a zero-width space raw, and
    the message's text after it read backwards, or two names looked one; a line break
    in a feature's id split a one-line message in three, and a terminal escape in one
    recoloured the terminal."""
    return "".join(c if c.isprintable() else _escaped(c) for c in text)


def _escaped(c: str) -> str:
    return f"\\u{ord(c):04x}" if ord(c) <= 0xFFFF else f"\\U{ord(c):08x}"


class _Twice(dict):
    """A JSON object that gave its key ``key`` twice. The parser keeps the last value,
    so the user's first one would vanish without a word; :func:`_object_hook` makes
    one, :func:`_duplicate_key` finds it, with its place, after parsing."""

    key: str = ""


def _object_hook(found: list[bool]) -> Callable[[list[tuple[str, Any]]], dict[str, Any]]:
    """The parser's ``object_pairs_hook``: a dict, or a :class:`_Twice` (noted in
    ``found``) when a key repeats."""
    def make(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        d = dict(pairs)
        if len(d) == len(pairs):
            return d
        twice = _Twice(d)
        seen: set[str] = set()
        for k, _ in pairs:
            if k in seen:
                twice.key = k
                break
            seen.add(k)
        found.append(True)
        return twice
    return make


def _duplicate_key(data: Any) -> tuple[str, str] | None:
    """The first repeated key of ``data`` (in document order) and the place of its
    object, e.g. ``features[2].properties`` (walked without recursion)."""
    stack: list[tuple[Any, str]] = [(data, "")]
    while stack:
        value, path = stack.pop()
        if isinstance(value, _Twice):
            return value.key, (f"the object at {path}" if path else "the top-level object")
        if isinstance(value, dict):
            stack.extend((v, f"{path}.{k}" if path else str(k))
                         for k, v in reversed(value.items()) if isinstance(v, dict | list))
        elif isinstance(value, list):
            stack.extend((v, f"{path}[{i}]") for i, v in reversed(list(enumerate(value)))
                         if isinstance(v, dict | list))
    return None


def _lone_surrogate(data: Any) -> bool:
    """Whether a string or key of ``data`` holds a lone surrogate (only a \\u escape
    makes one; it cannot be written out as UTF-8, so a name holding one crashed output)."""
    stack: list[Any] = [data]
    while stack:
        value = stack.pop()
        if isinstance(value, str):
            if not value.isascii():
                try:
                    value.encode("utf-8")
                except UnicodeEncodeError:
                    return True
        elif isinstance(value, dict):
            stack.extend(value.keys())
            stack.extend(value.values())
        elif isinstance(value, list):
            stack.extend(value)
    return False


def read_json(path: str | Path, what: str, error: type[Exception], *,
              max_depth: int = MAX_DEPTH) -> Any:
    """The JSON in the ``what`` file at ``path``; every failure is one ``error``."""
    return parse_json(read_text(path, what, error), path, what, error, max_depth=max_depth)


def read_toml(path: str | Path, what: str, error: type[Exception]) -> dict[str, Any]:
    """The TOML in the ``what`` file at ``path``; every failure is one ``error``."""
    text = read_text(path, what, error)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {_toml_words(str(exc), text)}") from None
    except RecursionError:
        raise error(f"{path}: TOML nested too deeply; check that it is the right "
                    "file") from None
    big = _int_past_64_bits(data)
    if big is not None:
        raise error(f"{path}: {big} is an integer past TOML's 64-bit range (19 digits); "
                    "write it with an exponent (1e30) or check the value")
    return data


def _toml_words(message: str, text: str) -> str:
    """The TOML reader's message in a user's words where its own are a parser's
    ("Cannot overwrite a value": a key given twice), with a fix."""
    where = message[message.find(" (at line"):] if " (at line" in message else ""
    if "\x00" in text:
        return f"it holds NUL bytes{where}, so it is no text file: check that it is the right file"
    other = _toml_lookalike(text)
    if other:
        return (f"it looks like {other}{where}; this file is TOML (key = value lines under "
                "[table] headers): write it so (see README)")
    if message.startswith("Cannot overwrite a value"):
        return (f"a key given a value twice{where} (or a key and a table of one name); "
                "keep one of them")
    m = re.match(r"Cannot declare \((.*)\) twice", message)
    if m:
        table = ".".join(part.strip(" '\"") for part in m.group(1).split(",") if part.strip())
        return f"the table [{table}] is declared twice{where}; merge them into one"
    return message


_YAML_LINE = re.compile(r"""^\s*(?:-\s|---\s*$|[\w"'.-]+\s*:(?:\s|$))""")


def _toml_lookalike(text: str) -> str:
    """The format a file TOML could not read looks like ("JSON", "YAML"), or ""."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        return ""
    if lines[0].lstrip().startswith("{"):
        return "JSON"
    if _YAML_LINE.match(lines[0]) and "=" not in lines[0]:
        return "YAML"
    return ""


def _int_past_64_bits(data: Any) -> str | None:
    """The key of the first integer TOML may not hold (past -2^63 .. 2^63 - 1, which
    its specification says a reader must refuse; Python's reader keeps them, and one
    past every float crashed the first check of it), or None. A walk with a stack: the
    TOML's nesting may be as deep as its reader allowed."""
    stack: list[tuple[str, Any]] = [("", data)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, int) and not isinstance(value, bool) \
                and not -2 ** 63 <= value < 2 ** 63:
            return where
        if isinstance(value, dict):
            stack.extend((f"{where}.{k}" if where else k, v)
                         for k, v in reversed(list(value.items())))
        elif isinstance(value, list):
            stack.extend((f"{where}[{n}]", v) for n, v in reversed(list(enumerate(value))))
    return None


def expect(value: Any, kind: type | tuple[type, ...], where: str, what: str,
           error: type[Exception]) -> Any:
    """``value`` when it is of ``kind`` (a bool is not a number); else one ``error``
    saying what was expected at ``where``."""
    bad_bool = isinstance(value, bool) and bool not in (kind if isinstance(kind, tuple)
                                                         else (kind,))
    if bad_bool or not isinstance(value, kind):
        got = type(value).__name__ if value is not None else "null"
        raise error(f"{where}: expected {what}, got {got} {value!r}"[:300])
    return value
