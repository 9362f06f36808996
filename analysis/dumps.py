"""Readers for LAMMPS text dumps: `dump local` (bond lists) and `dump custom` (atoms).

Frames are found by scanning for `ITEM: TIMESTEP`, never by a fixed number of lines per frame:
`dump local` bond lists change length every frame, and an atom dump can lose atoms. Each
frame's body is parsed as one block by pyarrow's CSV reader (multithreaded, correctly rounded,
and strict about the number of fields per line), never line by line in Python: 1 GB files
read at about 215 MB/s (atoms, 14 columns) and 230 MB/s (bonds) on this 2-core machine
(bench/dump_reading.py). The per-line checks only run when that block parse fails.

Columns are read by their header names (`ITEM: ATOMS` / `ITEM: ENTRIES`), in any order: atom
frames by id, type, x y z (or another coordinate convention) and vx vy vz; bond frames'
atom ids and type or state by `bond_columns`, which refuses names it cannot tell apart.

Failure contract (both kinds of dump): a truncated or inconsistent frame raises DumpError
naming the file, the frame index, its timestep and the file line. The frames before it are
complete and usable: they travel on the exception (`DumpError.frames`), and
`on_error="keep"` returns them with a warning instead of raising. Plain or gzip files (told
by their magic bytes, not their name); a truncated gzip stream is reported the same way.

MDAnalysis (`MDAnalysis.coordinates.LAMMPS.DumpReader`) is an optional engine for atom
dumps' positions and velocities. It is not the default, because for what we need it cannot:
it stores positions and velocities as float32; it converts scaled coordinates (xs ys zs) as
L*xs - xlo rather than xlo + L*xs (MDAnalysis issue #4788); it indexes frames by a fixed number of lines,
so it silently drops a truncated last frame and misreads frames whose atom count changes;
its timestep does not expose per-frame atom ids or types; and it parses line by line in
Python (7 MB/s here, 20x slower than the block parser). We therefore parse
every column with pyarrow/numpy; `engine="mdanalysis"` takes positions, velocities from
MDAnalysis after our own scan has validated the file, and serves as a cross-check.
"""

from __future__ import annotations

import io
import mmap
import os
import tempfile
import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Literal

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv

OnError = Literal["raise", "keep"]

# Position columns by LAMMPS coordinate convention, in MDAnalysis' order of preference.
COORDINATE_CONVENTIONS = {
    "unscaled": ("x", "y", "z"),
    "scaled": ("xs", "ys", "zs"),
    "unwrapped": ("xu", "yu", "zu"),
    "scaled_unwrapped": ("xsu", "ysu", "zsu"),
}
VELOCITY_COLUMNS = ("vx", "vy", "vz")
QUATERNION_COLUMNS = ("quatw", "quati", "quatj", "quatk")  # atom_style ellipsoid's names


class DumpError(ValueError):
    """A dump is truncated or inconsistent.

    The message names file, frame index, timestep and line (1-based); the same facts are
    attributes. `frames` holds the complete frames read before the bad one.
    """

    def __init__(self, message: str, *, path: Path | str | None = None, frame: int | None = None,
                 timestep: int | None = None, line: int | None = None, frames: list | None = None):
        where = []
        if path is not None:
            where.append(str(path))
        if frame is not None:
            where.append(f"frame {frame}" + (f" (timestep {timestep})" if timestep is not None else ""))
        if line is not None:
            where.append(f"line {line}")
        super().__init__(": ".join([", ".join(where), message]) if where else message)
        self.path, self.frame, self.timestep, self.line = path, frame, timestep, line
        self.frames: list = list(frames or [])


class DumpWarning(UserWarning):
    """A dump was cut short and only its complete frames were kept (`on_error="keep"`)."""


@dataclass
class LocalFrame:
    """One frame of a `dump local` file: columns by header name, shape (n,) float64 each.

    box: (3, 2) lo, hi of the simulation box (for a triclinic box: the box itself, not the
    bounding box a triclinic dump writes; tilt holds xy, xz, yz).
    """

    timestep: int
    box: np.ndarray
    columns: dict[str, np.ndarray]
    tilt: np.ndarray | None = None
    boundary: tuple[str, ...] = ()
    path: Path | None = None  # the file it came from, for messages

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0


@dataclass
class AtomFrame:
    """One frame of a `dump custom` atom file, every per-atom array sorted by atom id.

    ids: (n,) int64 ascending; types: (n,) int64 or None; positions: (n, d) float64 in box
    coordinates (scaled conventions converted, d = 2 or 3 by the columns present) or None;
    velocities: (n, d) or None; extra: every other column by header name, (n,) float64
    (quaternion components, mass, radius, image flags ...). box/tilt as in LocalFrame.
    names: the header's column names in file order; path: the file it came from.
    """

    timestep: int
    box: np.ndarray
    ids: np.ndarray
    types: np.ndarray | None
    positions: np.ndarray | None
    velocities: np.ndarray | None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    tilt: np.ndarray | None = None
    boundary: tuple[str, ...] = ()
    coordinate_convention: str | None = None
    time: float | None = None
    names: tuple[str, ...] = ()
    path: Path | None = None

    def __len__(self) -> int:
        return len(self.ids)

    def vector(self, prefix: str) -> np.ndarray:
        """Stack the columns prefix[1], prefix[2], ... into (n, k), e.g. vector("c_q")."""
        cols = []
        while f"{prefix}[{len(cols) + 1}]" in self.extra:
            cols.append(self.extra[f"{prefix}[{len(cols) + 1}]"])
        if not cols:
            raise KeyError(f"no columns {prefix}[1], {prefix}[2], ... in this dump "
                           f"(columns: {', '.join(self.extra)})")
        return np.column_stack(cols)

    def quaternions(self, prefix: str | None = None) -> np.ndarray:
        """Orientation quaternions (w, x, y, z) per atom, (n, 4).

        prefix names a bracketed vector (`c_q`, `d2_bcm_quat`); without it, quatw..quatk are
        used, else the only 4-component bracketed vector whose name contains 'quat' or ends
        with 'q'.
        """
        if prefix is not None:
            q = self.vector(prefix)
        elif all(c in self.extra for c in QUATERNION_COLUMNS):
            q = np.column_stack([self.extra[c] for c in QUATERNION_COLUMNS])
        else:
            prefixes = {nm.split("[")[0] for nm in self.extra if nm.endswith("[1]")}
            cands = [p for p in sorted(prefixes) if ("quat" in p or p.endswith("q"))
                     and f"{p}[4]" in self.extra and f"{p}[5]" not in self.extra]
            if len(cands) != 1:
                raise KeyError(f"cannot tell the quaternion columns (candidates {cands}); pass prefix=")
            q = self.vector(cands[0])
        if q.shape[1] != 4:
            raise KeyError(f"quaternion vector has {q.shape[1]} components, expected 4")
        return q


# ---------------------------------------------------------------------------------------
# Public readers


def read_local_dump(path: str | Path, on_error: OnError = "raise") -> list[LocalFrame]:
    """All frames of a `dump local` / `write_dump local` file (plain or gzip).

    on_error="raise": a bad frame raises DumpError (the good frames are on `.frames`);
    "keep": the frames before the bad one are returned and a DumpWarning is issued.
    """
    _check_on_error(on_error)
    return _collect(iter_local_dump(path), on_error)


def iter_local_dump(path: str | Path) -> Iterator[LocalFrame]:
    """Frames of a `dump local` file one at a time (the file is memory-mapped, not loaded)."""
    path = Path(path)
    for hdr, data in _iter_frames(path, "ENTRIES"):
        yield LocalFrame(hdr.timestep, hdr.box, {nm: data[:, k] for k, nm in enumerate(hdr.names)},
                         hdr.tilt, hdr.boundary, path)


def read_atom_dump(path: str | Path, on_error: OnError = "raise",
                   engine: Literal["numpy", "mdanalysis"] = "numpy") -> list[AtomFrame]:
    """All frames of a `dump custom` atom file (plain or gzip), arrays sorted by atom id.

    engine="numpy" parses every column in float64. engine="mdanalysis" replaces positions
    and velocities by MDAnalysis' DumpReader values (float32 precision), after this module's
    scan has checked the file; it needs the same atom count and columns in every frame.
    on_error as in read_local_dump. Columns must be numeric (no `element` strings).
    """
    _check_on_error(on_error)
    if engine not in ("numpy", "mdanalysis"):
        raise ValueError(f"engine must be 'numpy' or 'mdanalysis', not {engine!r}")
    try:
        frames = _collect(iter_atom_dump(path), on_error)
    except DumpError as exc:
        if engine == "mdanalysis" and exc.frames:  # the complete frames it carries get them too
            _positions_from_mdanalysis(Path(path), exc.frames)
        raise
    if engine == "mdanalysis" and frames:
        _positions_from_mdanalysis(Path(path), frames)
    return frames


def iter_atom_dump(path: str | Path) -> Iterator[AtomFrame]:
    """Frames of a `dump custom` atom file one at a time."""
    path = Path(path)
    for index, (hdr, data) in enumerate(_iter_frames(path, "ATOMS")):
        yield _atom_frame(path, index, hdr, data)


def bond_pairs(frame: LocalFrame) -> tuple[np.ndarray, np.ndarray]:
    """(pairs of 1-based atom ids (n, 2) int, bond types or states (n,) int) of a bond dump
    frame, its columns found by their header names (`bond_columns`): in any order, an
    `index` column or other extra columns beside them. DumpError naming the file and the
    columns found when the names do not tell, or when an id column holds non-integers."""
    try:
        a1, a2, state = bond_columns(list(frame.columns))
    except ValueError as exc:
        raise DumpError(f"bond dump at timestep {frame.timestep}: {exc}", path=frame.path) from None
    pairs = np.empty((len(frame), 2), dtype=np.int64)
    for k, name in enumerate((a1, a2)):
        col = frame.columns[name]
        if not np.all(np.isfinite(col) & (np.floor(col) == col)):
            raise DumpError(f"bond dump at timestep {frame.timestep}: column {name!r}, read as an atom id, holds "
                            f"values that are not integers (found columns: {' '.join(frame.columns)})", path=frame.path)
        pairs[:, k] = col
    return pairs, frame.columns[state].astype(np.int64)


# Bond `dump local` columns by the names LAMMPS writes (read by name, never by position).
# Plain names (a converted or hand-written file): compute property/local's keywords or the
# bare words, one of each role.
BOND_NAMES = {"atom1": ("batom1", "atom1"), "atom2": ("batom2", "atom2"), "state": ("btype", "type", "state")}
# `dump local` itself names a compute's vector c_ID[k]. Two layouts, the tool's own:
#  - `compute ID property/local batom1 batom2 btype` (driver/bpm/shear.py, ID bl):
#    c_ID[1] c_ID[2] c_ID[3], for any ID whose vector has exactly these three components;
#  - the BCM interface dumps of early runs, before their columns were named (batom1 batom2
#    state ..., runfiles/records.py; now written by the plugin's fix bcm/interfaces/dump):
#    `compute ifc property/local batom1 batom2` and `compute ifs bond/local b1 ...` of bond
#    bcm/griffith, whose b1 is the interface state (1 intact, 0 broken): c_ifc[1] c_ifc[2]
#    c_ifs[1].
BCM_INTERFACE_NAMES = ("c_ifc[1]", "c_ifc[2]", "c_ifs[1]")
BOND_NAMES_NEEDED = ("the two atom ids and the bond type or state: batom1 batom2 btype (or atom1 atom2 type|state), "
                     "c_ID[1] c_ID[2] c_ID[3] of `compute ID property/local batom1 batom2 btype`, or "
                     + " ".join(BCM_INTERFACE_NAMES) + "; an index column is skipped")


def bond_columns(names: list[str]) -> tuple[str, str, str]:
    """Header names of (atom1, atom2, type or state) among a bond dump's column names.

    Exactly one of the layouts above must fit; none, or more than one (two candidate compute
    vectors, batom1 beside atom1 ...), is a ValueError listing the names found: the columns
    are never guessed by position. `index` and any other column are left alone.
    """
    found = f"found: {' '.join(names)}; needed: {BOND_NAMES_NEEDED}"
    layouts = []
    plain = {role: [nm for nm in names if nm in options] for role, options in BOND_NAMES.items()}
    if any(len(v) > 1 for v in plain.values()):
        raise ValueError(f"ambiguous bond columns {sum(plain.values(), [])}; {found}")
    if all(plain.values()):
        layouts.append(tuple(v[0] for v in plain.values()))
    components: dict[str, set[str]] = {}
    for nm in names:
        if nm.startswith("c_") and nm.endswith("]") and "[" in nm:
            prefix, _, k = nm[:-1].partition("[")
            components.setdefault(prefix, set()).add(k)
    layouts += [(f"{p}[1]", f"{p}[2]", f"{p}[3]") for p, ks in components.items() if ks == {"1", "2", "3"}]
    if components.get("c_ifc") == {"1", "2"} and BCM_INTERFACE_NAMES[2] in names:
        layouts.append(BCM_INTERFACE_NAMES)
    if len(layouts) > 1:
        raise ValueError(f"ambiguous bond columns: {' and '.join(' '.join(lay) for lay in layouts)} both fit; {found}")
    if not layouts:
        raise ValueError(f"cannot tell the bond columns by name; {found}")
    return layouts[0]


# ---------------------------------------------------------------------------------------
# Frame scanning


@dataclass
class _Header:
    index: int
    timestep: int
    n: int
    box: np.ndarray
    tilt: np.ndarray | None
    boundary: tuple[str, ...]
    names: list[str]
    line: int  # file line of ITEM: TIMESTEP
    body_line: int  # file line of the first body line
    time: float | None = None


def _check_on_error(on_error: str) -> None:
    if on_error not in ("raise", "keep"):
        raise ValueError(f"on_error must be 'raise' or 'keep', not {on_error!r}")


def _collect(frames: Iterator, on_error: OnError) -> list:
    good: list = []
    try:
        for fr in frames:
            good.append(fr)
    except DumpError as exc:
        exc.frames = good
        if on_error == "raise":
            raise
        warnings.warn(f"{exc} -- keeping the {len(good)} complete frame(s) before it", DumpWarning, stacklevel=3)
    return good


def _load(path: Path) -> tuple[bytes | mmap.mmap, bool]:
    """The file's bytes (mmap for a plain file) and whether a gzip stream was cut short."""
    with open(path, "rb") as f:
        magic = f.read(2)
        if magic != b"\x1f\x8b":
            if os.fstat(f.fileno()).st_size == 0:
                return b"", False
            return mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ), False
        f.seek(0)
        out, dec = [], zlib.decompressobj(16 + zlib.MAX_WBITS)
        try:
            while chunk := f.read(1 << 24):
                while chunk:
                    out.append(dec.decompress(chunk))
                    # Concatenated gzip members (appended dumps): start a fresh stream.
                    chunk = dec.unused_data if dec.eof else b""
                    if chunk:
                        dec = zlib.decompressobj(16 + zlib.MAX_WBITS)
            out.append(dec.flush())
        except zlib.error:
            return b"".join(out), True  # corrupt data: keep what decoded before it
        return b"".join(out), not dec.eof


def _iter_frames(path: Path, kind: str) -> Iterator[tuple[_Header, np.ndarray]]:
    buf, gz_cut = _load(path)
    try:
        size, pos, line, index, last = len(buf), 0, 1, 0, None
        while pos < size:
            hdr, body_pos = _read_header(buf, pos, line, index, path, kind)
            nxt = buf.find(b"ITEM: TIMESTEP", body_pos)
            end = size if nxt < 0 else nxt
            data = _parse_body(buf[body_pos:end], hdr, path, at_eof=nxt < 0)
            yield hdr, data
            last = hdr
            pos, line, index = end, hdr.body_line + hdr.n, index + 1
        if gz_cut:
            raise DumpError("the gzip stream ends early (truncated or corrupt .gz); frames after "
                            "the last complete one may be lost", path=path,
                            frame=None if last is None else last.index + 1, line=line)
    finally:
        if isinstance(buf, mmap.mmap):
            buf.close()


def _read_header(buf, pos: int, line: int, index: int, path: Path, kind: str) -> tuple[_Header, int]:
    """Parse the ITEM lines of one frame starting at byte pos; return it and the body offset."""
    size, p, cur = len(buf), pos, line
    timestep = None

    def fail(msg: str, at: int):
        raise DumpError(msg, path=path, frame=index, timestep=timestep, line=at)

    def next_line() -> tuple[str, int]:
        nonlocal p, cur
        e = buf.find(b"\n", p) if p < size else -1
        if e < 0:
            fail("is truncated in its header", cur)
        text = bytes(buf[p:e]).decode("ascii", "replace").strip()
        p, cur = e + 1, cur + 1
        return text, cur - 1

    first, _ = next_line()
    if first != "ITEM: TIMESTEP":
        fail(f"expected 'ITEM: TIMESTEP', found {first[:60]!r}", line)
    box = tilt = n = time = None
    boundary: tuple[str, ...] = ()
    names: list[str] = []
    item, at = first, line
    try:
        timestep = int(next_line()[0])
        while True:
            item, at = next_line()
            if item == "ITEM: UNITS":
                next_line()
            elif item == "ITEM: TIME":
                time = float(next_line()[0])
            elif item.startswith("ITEM: NUMBER OF"):
                n = int(next_line()[0])
                if n < 0:
                    raise ValueError("negative count")
            elif item.startswith("ITEM: BOX BOUNDS"):
                flags = item.split()[3:]
                if flags[:2] == ["abc", "origin"]:
                    fail("general triclinic boxes ('abc origin') are not supported", at)
                tri = flags[:3] == ["xy", "xz", "yz"]
                boundary = tuple(flags[3:] if tri else flags)
                rows = np.array([[float(v) for v in next_line()[0].split()] for _ in range(3)])
                if rows.shape != (3, 3 if tri else 2):
                    raise ValueError(f"box rows of shape {rows.shape}")
                box, tilt = _box_from_bounds(rows, tri)
            elif item.startswith(f"ITEM: {kind}"):
                names = item.split()[2:]
                break
            elif item.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
                other = "read_atom_dump" if kind == "ENTRIES" else "read_local_dump"
                fail(f"has {item.split()[1]!r} where this reader expects {kind!r}: use {other}", at)
            else:
                fail(f"unexpected header line {item[:60]!r}", at)
    except DumpError:
        raise
    except ValueError as exc:
        fail(f"bad header after {item[:60]!r}: {exc}", at)
    if n is None or box is None:
        fail("header lacks 'NUMBER OF ...' or 'BOX BOUNDS'", cur - 1)
    if not names or len(set(names)) != len(names):
        fail(f"bad column names {names}", cur - 1)
    return _Header(index, timestep, n, box, tilt, boundary, names, line, cur, time), p


def _box_from_bounds(rows: np.ndarray, triclinic: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """LAMMPS box lo/hi (and tilt) from a dump's BOX BOUNDS rows.

    A triclinic dump writes the bounding box; the box itself is (Howto_triclinic)
    xlo = xlo_b - min(0, xy, xz, xy+xz), xhi = xhi_b - max(0, xy, xz, xy+xz),
    ylo = ylo_b - min(0, yz), yhi = yhi_b - max(0, yz).
    """
    if not triclinic:
        return rows[:, :2].astype(float), None
    xy, xz, yz = rows[:, 2]
    box = rows[:, :2].astype(float).copy()
    box[0, 0] -= min(0.0, xy, xz, xy + xz)
    box[0, 1] -= max(0.0, xy, xz, xy + xz)
    box[1, 0] -= min(0.0, yz)
    box[1, 1] -= max(0.0, yz)
    return box, np.array([xy, xz, yz], dtype=float)


def _parse_body(body: bytes, hdr: _Header, path: Path, at_eof: bool) -> np.ndarray:
    """(n, k) float64 of one frame body (columns contiguous), or DumpError naming the first bad line."""
    n, k = hdr.n, len(hdr.names)
    if n == 0:
        if body.strip():
            _fail_body(hdr, path, "has lines beyond the 0 announced", hdr.body_line)
        return np.empty((0, k))
    # Fast path: arrow's multithreaded CSV reader (correctly rounded float parsing) refuses
    # any line whose field count differs from the first line's, so one pass both parses and
    # checks the block. LAMMPS writes `dump local` lines with a trailing space (an empty last
    # field), `dump custom` lines without. A body that does not end in a newline may end
    # inside a number: the careful path reports it.
    if body.endswith(b"\n"):
        first = body[:body.find(b"\n")]
        data = _parse_block(body, k, trailing=first.endswith(b" "))
        if data is not None and data.shape == (n, k):
            return data
    return _parse_body_careful(body, hdr, path, at_eof)


_ARROW_PARSE = pacsv.ParseOptions(delimiter=" ", quote_char=False, double_quote=False, escape_char=False)


def _parse_block(body: bytes, k: int, trailing: bool) -> np.ndarray | None:
    """(rows, k) float64 view of k space-separated numeric columns (plus an empty last field
    when `trailing`), column-major so that each column is contiguous; None when any line
    does not have the fields of the first, a value is not a number or a field is empty."""
    names = [f"c{j}" for j in range(k + trailing)]
    types = {nm: pa.float64() for nm in names[:k]}
    if trailing:
        types[names[k]] = pa.null()  # accepts only empty fields: a stray extra value is an error
    try:
        table = pacsv.read_csv(
            pa.py_buffer(body), parse_options=_ARROW_PARSE,
            read_options=pacsv.ReadOptions(column_names=names, block_size=1 << 24),
            convert_options=pacsv.ConvertOptions(column_types=types, null_values=[""], strings_can_be_null=False))
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return None
    if any(table.column(j).null_count for j in range(k)):  # an empty field: doubled spaces, a gap
        return None
    out = np.empty((k, table.num_rows))
    for j in range(k):
        at = 0
        for chunk in table.column(j).chunks:
            m = len(chunk)
            out[j, at:at + m] = chunk.to_numpy(zero_copy_only=True)
            at += m
    return out.T


def _parse_body_careful(body: bytes, hdr: _Header, path: Path, at_eof: bool) -> np.ndarray:
    n, k = hdr.n, len(hdr.names)
    lines = body.split(b"\n")
    tail = lines.pop()  # what follows the last newline: b"" for a complete body
    if at_eof and not tail.strip():  # tolerate blank lines at the very end of the file
        tail = b""
        while len(lines) > n and not lines[-1].strip():
            lines.pop()
    if tail:
        i = len(lines)
        if at_eof:
            _fail_body(hdr, path, f"is truncated: the file ends inside line {i + 1} of {n}", hdr.body_line + i)
        _fail_body(hdr, path, f"is inconsistent: the next frame starts inside line {i + 1} of {n}",
                   hdr.body_line + i)
    if len(lines) < n:
        what = "is truncated" if at_eof else "is inconsistent"
        _fail_body(hdr, path, f"{what}: {n} lines announced, {len(lines)} present", hdr.body_line + len(lines))
    if len(lines) > n:
        _fail_body(hdr, path, f"has more lines than the {n} announced", hdr.body_line + n)
    counts = np.fromiter((len(ln.split()) for ln in lines), dtype=np.int64, count=n)
    bad = np.flatnonzero(counts != k)
    if len(bad):
        i = int(bad[0])
        _fail_body(hdr, path, f"line has {counts[i]} values, the header names {k} ({' '.join(hdr.names)})",
                   hdr.body_line + i)
    try:
        return pd.read_csv(io.BytesIO(body), sep=r"\s+", header=None, nrows=n, usecols=range(k),
                           dtype=np.float64, engine="c").to_numpy()
    except (ValueError, pd.errors.ParserError):
        for i, ln in enumerate(lines):
            try:
                [float(v) for v in ln.split()]
            except ValueError:
                _fail_body(hdr, path, f"has a non-numeric value in {ln.decode(errors='replace')[:60]!r}",
                           hdr.body_line + i)
        raise


def _fail_body(hdr: _Header, path: Path, msg: str, line: int):
    raise DumpError(f"frame body {msg}", path=path, frame=hdr.index, timestep=hdr.timestep, line=line)


# ---------------------------------------------------------------------------------------
# Atom frames


def _atom_frame(path: Path, index: int, hdr: _Header, data: np.ndarray) -> AtomFrame:
    col = {nm: j for j, nm in enumerate(hdr.names)}

    def fail(msg: str):
        raise DumpError(msg, path=path, frame=index, timestep=hdr.timestep, line=hdr.body_line - 1)

    if "id" not in col:
        fail(f"atom dump has no 'id' column; found: {' '.join(hdr.names)}")
    ids = data[:, col["id"]].astype(np.int64)
    order = _id_order(ids)
    if order is not None:
        ids = ids[order]
        if np.any(ids[1:] == ids[:-1]):
            fail(f"atom id {int(ids[1:][ids[1:] == ids[:-1]][0])} appears twice")

    def column(j: int) -> np.ndarray:
        c = data[:, j]
        return np.ascontiguousarray(c) if order is None else c[order]

    def stack(names) -> np.ndarray:
        out = np.empty((len(ids), len(names)))
        for m, nm in enumerate(names):
            out[:, m] = column(col[nm])
        return out

    used = {"id"}
    types = None
    if "type" in col:
        types = column(col["type"]).astype(np.int64)
        used.add("type")
    positions, convention = None, None
    for conv, names in COORDINATE_CONVENTIONS.items():
        present = [nm for nm in names if nm in col]
        if len(present) >= 2 and present == list(names[:len(present)]):
            positions = stack(present)
            convention = conv
            used.update(present)
            if conv.startswith("scaled"):
                positions = _unscale(positions, hdr.box, hdr.tilt)
            break
    velocities = None
    vel = [nm for nm in VELOCITY_COLUMNS if nm in col]
    if len(vel) >= 2 and vel == list(VELOCITY_COLUMNS[:len(vel)]):
        velocities = stack(vel)
        used.update(vel)
    extra = {nm: column(j) for nm, j in col.items() if nm not in used}
    return AtomFrame(hdr.timestep, hdr.box, ids, types, positions, velocities, extra, hdr.tilt,
                     hdr.boundary, convention, hdr.time, tuple(hdr.names), path)


def _id_order(ids: np.ndarray) -> np.ndarray | None:
    """Permutation that sorts ids ascending (None when already sorted). Ids that are a
    permutation of a contiguous range (every dump of a fixed set of atoms) are placed by one
    scatter, O(n); anything else (gaps, repeats) by a stable argsort."""
    n = len(ids)
    if n < 2 or np.all(ids[1:] > ids[:-1]):
        return None
    lo = int(ids.min())
    if int(ids.max()) - lo + 1 == n:
        slot = ids - lo
        order = np.full(n, -1, dtype=np.int64)
        order[slot] = np.arange(n)
        if order.min() >= 0:  # every slot filled by n ids: no repeats
            return order
    return np.argsort(ids, kind="stable")


def _unscale(s: np.ndarray, box: np.ndarray, tilt: np.ndarray | None) -> np.ndarray:
    """Box coordinates from fractional ones: x = lo + h s, h the (upper-triangular) box matrix."""
    d = s.shape[1]
    h = np.diag(box[:d, 1] - box[:d, 0])
    if tilt is not None:
        xy, xz, yz = tilt
        h[0, 1] = xy
        if d == 3:
            h[0, 2], h[1, 2] = xz, yz
    return box[:d, 0] + s @ h.T


def _append_z_column(path: Path, out: Path, name: str) -> None:
    """Copy of the atom dump `path` (plain or gzip) with a column `name` of zeros last."""
    import gzip  # noqa: PLC0415

    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as src, open(out, "w") as dst:
        atoms = False
        for line in src:
            if line.startswith("ITEM:"):
                atoms = line.startswith("ITEM: ATOMS")
                dst.write(line.rstrip("\n") + (f" {name}\n" if atoms else "\n"))
            elif atoms and line.strip():
                dst.write(line.rstrip("\n") + " 0\n")
            else:
                dst.write(line)


def _positions_from_mdanalysis(path: Path, frames: list[AtomFrame], flat: bool = False) -> None:
    """Replace positions/velocities by MDAnalysis' (float32) values, in place. flat: `path`
    is a 2D dump's copy with z = 0 added (the frames keep x, y)."""
    from MDAnalysis.coordinates.LAMMPS import DumpReader  # noqa: PLC0415 (optional engine)

    n0, conv = len(frames[0]), frames[0].coordinate_convention
    if any(len(fr) != n0 or fr.coordinate_convention != conv for fr in frames):
        raise ValueError("engine='mdanalysis' needs the same atoms and coordinate columns in every "
                         "frame (MDAnalysis indexes frames by a fixed line count); use engine='numpy'")
    if conv is None:
        raise ValueError("engine='mdanalysis' needs coordinate columns (x y [z], or xs ys [zs], xu yu [zu] ...)")
    if frames[0].positions.shape[1] == 2 and not flat:
        # a 2D dump has no z column (so OVITO reads it as 2D); MDAnalysis needs one: it reads
        # a copy with z = 0 appended, and its x and y are compared as usual
        with tempfile.TemporaryDirectory() as tmp:
            padded = Path(tmp) / "dump.lammpstrj"
            _append_z_column(path, padded, "zs" if conv.startswith("scaled") else "z")
            _positions_from_mdanalysis(padded, frames, flat=True)
        return

    if conv.startswith("scaled") and any(np.any(fr.box[:, 0] != 0) for fr in frames):
        # MDAnalysis 2.x converts scaled coordinates as L*xs - xlo instead of L*xs + xlo
        # (MDAnalysis issue #4788, open): its positions would be off by twice the box origin.
        raise ValueError("engine='mdanalysis' misplaces scaled coordinates when the box origin is not 0 "
                         "(MDAnalysis issue #4788); use engine='numpy'")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its unit and mass-guessing chatter
        reader = DumpReader(str(path), lammps_coordinate_convention=conv)
        try:
            for fr, ts in zip(frames, reader):
                if ts.data["step"] != fr.timestep:
                    raise ValueError(f"MDAnalysis frame at step {ts.data['step']}, ours at {fr.timestep}")
                # MDAnalysis moves the box origin to 0: put the LAMMPS origin back.
                pos = ts.positions.astype(np.float64) + fr.box[:, 0]
                fr.positions = pos[:, :2] if flat else pos
                if fr.velocities is not None and ts.has_velocities and not flat:
                    fr.velocities = ts.velocities.astype(np.float64)
        finally:
            reader.close()
