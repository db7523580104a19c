"""Maps for the ``[world]`` section: Moving AI grid maps, a 3-D stack of them, a maze and a C-shaped obstacle.

Resolved forms (what the world, the trace header and ``ctx.map`` carry; geometry in ``transport.space``):

* an obstacle: ``{"xy": [[x, y], ...], "z": [z_min, z_max] | None}`` (a convex polygon over an extent);
* a grid map: ``{"cell", "origin", "layers": [{"z": [lo, hi], "rows": [...]}], "water": [...] | None,
  "markers": {"A": [[x, y], ...], ...}, "source"}``; in ``rows`` ``@`` is blocked and ``.`` free, in
  ``water`` ``W`` stops ground robots only. Layers are contiguous and ascending; ``None`` is unbounded.

**Moving AI format** (movingai.com's grid benchmarks, the maps Swarm Relays' authors used)::

    type octile
    height H
    width W
    map
    <H rows of W characters>

``.`` ``G`` ``S`` passable; ``@`` ``O`` blocked at every height; ``T`` a tree, blocked up to
``tree_height``; ``W`` water, stopping ground robots only; ``A`` ``X`` markers (start, target) some copies
carry: passable, and reported in ``markers``. Any other character is an error naming line and column.

**A 3-D map** (``type octile3d``) is the same header with ``layers L`` after ``width``, then L blocks
``layer Z_LO Z_HI`` followed by H rows, in ascending, contiguous heights; above and below the stack is free.

**Limits** (a map is input, and reaches every host and the trace header): a map file is a regular file of at
most ``MAX_MAP_BYTES``, and a map (a file's H x W x L, or a generated maze) has at most ``MAX_MAP_CELLS``
cells, checked before anything of that size is read or allocated.
"""

from __future__ import annotations

import stat
from pathlib import Path

import numpy as np

PASSABLE = set(".GS")
MARKERS = set("AX")
BLOCKED = set("@O")
KNOWN = PASSABLE | MARKERS | BLOCKED | {"T", "W"}
MAX_MAP_CELLS = 2048 * 2048  # 4x the largest Moving AI benchmark maps (1024 x 1024); 16x the 511 x 511 maze we run
MAX_MAP_BYTES = 16 * 1024 * 1024  # a map file: its cells, line ends and header fit many times over


class MapError(ValueError):
    """A map that cannot be read: ``where`` names the file and line (and column)."""

    def __init__(self, where: str, message: str):
        super().__init__(f"{where}: {message}")
        self.where = where
        self.message = message


def read_map(path: str | Path, *, tree_height: float | None = None, cell: float = 1.0,
             origin: tuple[float, float] = (0.0, 0.0)) -> dict:
    """Read a Moving AI map (``octile``) or a 3-D stack (``octile3d``) into its resolved grid form."""
    path = Path(path)
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):  # /dev/zero never ends; a FIFO waits for a writer
            raise MapError(str(path), "not a regular file")
        if st.st_size > MAX_MAP_BYTES:
            raise MapError(str(path), f"{st.st_size:,} bytes, above the {MAX_MAP_BYTES >> 20} MiB a map file may have")
        with open(path, "rb") as f:
            data = f.read(MAX_MAP_BYTES + 1)  # a file that grew since, or that stat under-reports, is still bounded
        if len(data) > MAX_MAP_BYTES:
            raise MapError(str(path), f"more than the {MAX_MAP_BYTES >> 20} MiB a map file may have")
        lines = data.decode().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(str(path), f"cannot read the map ({exc.__class__.__name__}: {exc})") from None
    return parse_map(lines, str(path), tree_height=tree_height, cell=cell, origin=origin)


def parse_map(lines: list[str], name: str = "<map>", *, tree_height: float | None = None, cell: float = 1.0,
              origin: tuple[float, float] = (0.0, 0.0)) -> dict:
    """Parse the lines of a map file (module docstring) into its resolved grid form."""
    it = iter(enumerate(lines, start=1))

    def header(key: str) -> str:
        for no, line in it:
            if not line.strip():
                continue
            word, _, value = line.strip().partition(" ")
            if word != key:
                raise MapError(f"{name}:{no}", f"expected '{key}', found {line.strip()[:40]!r}")
            return value.strip()
        raise MapError(name, f"ends before '{key}'")

    def number(key: str) -> int:
        value = header(key)
        if not value.isdigit() or int(value) < 1:
            raise MapError(name, f"'{key}' must be a positive integer, not {value!r}")
        return int(value)

    kind = header("type")
    if kind not in ("octile", "octile3d"):
        raise MapError(name, f"type must be 'octile' or 'octile3d', not {kind!r}")
    h, w = number("height"), number("width")
    n_layers = number("layers") if kind == "octile3d" else 1
    _check_cells(name, h, w, n_layers)
    planes, extents = [], []
    for _ in range(n_layers):
        if kind == "octile3d":
            z = header("layer").split()
            try:
                lo, hi = (float(v) for v in z)
            except ValueError:
                raise MapError(name, f"a layer line must be 'layer Z_LO Z_HI', not 'layer {' '.join(z)}'") from None
            if extents and lo != extents[-1][1] or hi <= lo:
                raise MapError(name, f"layer {lo:g}..{hi:g} must be above and touch the previous one, with lo < hi")
            extents.append((lo, hi))
        else:
            header("map")
        rows = []
        for no, line in it:
            rows.append((no, line.rstrip("\r\n")))
            if len(rows) == h:
                break
        if len(rows) < h:
            raise MapError(name, f"has {len(rows)} map rows, the header says height {h}")
        for no, row in rows:
            if len(row) != w:
                raise MapError(f"{name}:{no}", f"row has {len(row)} characters, the header says width {w}")
            if not KNOWN.issuperset(row):
                col, ch = next((col, ch) for col, ch in enumerate(row, start=1) if ch not in KNOWN)
                raise MapError(f"{name}:{no}:{col}",
                               f"unknown map character {ch!r} (known: {''.join(sorted(KNOWN))})")
        planes.append([row for _, row in rows])
    return _resolve_planes(planes, extents if kind == "octile3d" else None, tree_height, cell, origin, name)


def _check_cells(name: str, h: int, w: int, layers: int = 1) -> None:
    """Refuse a map of more than ``MAX_MAP_CELLS`` cells, before anything of its size is read or allocated."""
    if h * w * layers > MAX_MAP_CELLS:
        shape = f"{h} x {w}" + (f" x {layers} layers" if layers > 1 else "")
        raise MapError(name, f"{shape} = {h * w * layers:,} cells, above the {MAX_MAP_CELLS:,} a map may have")


def _resolve_planes(planes, extents, tree_height, cell, origin, source) -> dict:
    h = len(planes[0])
    markers: dict[str, list] = {}
    for r, row in enumerate(planes[0]):
        for c, ch in enumerate(row):
            if ch in MARKERS:
                markers.setdefault(ch, []).append([origin[0] + (c + 0.5) * cell, origin[1] + (h - r - 0.5) * cell])

    def plane(rows, chars) -> list[str]:
        return ["".join("@" if ch in chars else "." for ch in row) for row in rows]

    layers = []
    if extents is None:
        if tree_height is None:
            layers.append({"z": None, "rows": plane(planes[0], BLOCKED | {"T"})})
        else:
            layers.append({"z": [None, float(tree_height)], "rows": plane(planes[0], BLOCKED | {"T"})})
            layers.append({"z": [float(tree_height), None], "rows": plane(planes[0], BLOCKED)})
    else:
        free = ["." * len(planes[0][0])] * h
        layers.append({"z": [None, extents[0][0]], "rows": free})
        for rows, (lo, hi) in zip(planes, extents, strict=True):
            layers.append({"z": [lo, hi], "rows": plane(rows, BLOCKED | {"T"})})
        layers.append({"z": [extents[-1][1], None], "rows": free})
    water = ["".join("W" if ch == "W" else "." for ch in row) for row in planes[0]]
    return {"cell": float(cell), "origin": [float(origin[0]), float(origin[1])], "layers": layers,
            "water": water if any("W" in row for row in water) else None, "markers": markers, "source": source}


def maze(cols: int, rows: int, seed: int = 0, corridor: int = 2, wall: int = 1) -> list[str]:
    """A perfect maze (one path between any two cells), drawn by a seeded depth-first search, as map rows.

    MapError if its grid would have more than ``MAX_MAP_CELLS`` cells.
    """
    step = corridor + wall
    _check_cells("maze", rows * step + wall, cols * step + wall)
    rng = np.random.default_rng(seed)
    grid = np.ones((rows * step + wall, cols * step + wall), dtype=bool)  # True: wall

    def carve(r, c):
        y, x = wall + r * step, wall + c * step
        grid[y: y + corridor, x: x + corridor] = False

    seen = np.zeros((rows, cols), dtype=bool)
    stack = [(0, 0)]
    seen[0, 0] = True
    carve(0, 0)
    while stack:
        r, c = stack[-1]
        nxt = [(r + dr, c + dc) for dr, dc in ((0, 1), (1, 0), (0, -1), (-1, 0))
               if 0 <= r + dr < rows and 0 <= c + dc < cols and not seen[r + dr, c + dc]]
        if not nxt:
            stack.pop()
            continue
        nr, nc = nxt[int(rng.integers(len(nxt)))]
        seen[nr, nc] = True
        carve(nr, nc)
        # open the wall between the two cells
        y0, x0 = wall + min(r, nr) * step, wall + min(c, nc) * step
        if nr != r:
            grid[y0 + corridor: y0 + step, x0: x0 + corridor] = False
        else:
            grid[y0: y0 + corridor, x0 + corridor: x0 + step] = False
        stack.append((nr, nc))
    return ["".join("@" if b else "." for b in line) for line in grid]


def c_shape(center: list[float], size: float, thickness: float, opening: str = "+x",
            z: list | None = None) -> list[dict]:
    """The C-shaped obstacle of Swarm Relays' open-arena experiments: three boxes, open towards ``opening``.

    ``size`` is the outer side of the C, ``thickness`` its walls'; ``opening`` one of +x, -x, +y, -y.
    """
    cx, cy = float(center[0]), float(center[1])
    s, t = size / 2, thickness
    # the C open towards +x, then rotated
    boxes = [((-s, -s), (-s + t, s)), ((-s, s - t), (s, s)), ((-s, -s), (s, -s + t))]
    turn = {"+x": 0, "+y": 1, "-x": 2, "-y": 3}[opening]
    out = []
    for (x0, y0), (x1, y1) in boxes:
        pts = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
        for _ in range(turn):
            pts = np.column_stack([-pts[:, 1], pts[:, 0]])
        out.append({"xy": (pts + [cx, cy]).round(9).tolist(), "z": z})
    return out


def box(lo: list[float], hi: list[float], z: list | None = None) -> dict:
    """An axis-aligned box obstacle from its corners."""
    (x0, y0), (x1, y1) = lo[:2], hi[:2]
    return {"xy": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]], "z": z}
