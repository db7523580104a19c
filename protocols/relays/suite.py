"""Swarm Relays: scenarios and the conformance family (``swarmactors check relays``).

A user's chain protocol replaces the built-in ``relays`` behaviour. It must publish, with ``set_status``,
``role`` (root | worker | networker | free), ``chain`` (its target's index), ``parent``, ``child`` and
``depth`` (the status contract the checks read), and report ``reached_at`` (the tick its worker reached the
target, or null) and ``plan_status``.
"""

from __future__ import annotations

import math

from swarmactors.robot.family import Case, Family

# The paper's parameters (002 Sec. V); our tick is dt = 0.2 s (ARGoS' step is 0.1 s).
PAPER = {"ds": 1.4, "dc": 1.6, "db": 1.8, "vmax": 0.5, "rcol": 0.25}


def cluster(n: int, spacing: float = 0.5) -> list[list[float]]:
    """The root at the origin and n - 1 robots beside it, on both sides of the x axis (the way out)."""
    pts = [[0.0, 0.0]]
    for i in range(n - 1):
        c, r = divmod(i, 4)
        side, row = (1, r // 2) if r % 2 == 0 else (-1, r // 2)
        pts.append([round(spacing * c, 6), round(side * (0.5 + spacing * row), 6)])
    return pts


def relays_scenario(n: int = 10, targets: list | None = None, *, ticks: int = 600, seed: int = 1,
                    dt: float = 0.2, loss: float = 0.0, obstacles: list | None = None, kills: list | None = None,
                    clock: str = "lockstep", name: str = "relays", checks: list | None = None, dims: int = 2,
                    bounds: list | None = None, positions: list | None = None, groups: list | None = None,
                    grid_map: dict | None = None, radio_range: float = 2.0, **params) -> dict:
    """A Swarm Relays run: ``n`` ground robots clustered at the root (robot 0), the targets given."""
    targets = targets if targets is not None else [[8.0, 0.0]]
    beh = {"use": "relays", "targets": targets, **params}
    run = {"name": name, "seed": seed, "clock": clock, "ticks": ticks, "dt": dt}
    radio = {"range": radio_range, "model": "distance", "delta": 0.15, "loss": loss}
    if clock == "realtime":
        radio.update(latency_s=dt / 4, latency_min_s=dt / 8)
    world: dict = {"dims": dims}
    if obstacles:
        world["obstacles"] = obstacles
    if bounds:
        world["bounds"] = bounds
    if grid_map:
        world["map"] = grid_map
    robots = groups or [{"positions": positions or cluster(n), "speed": params.get("vmax", PAPER["vmax"]),
                         "body_radius": 0.125,
                         "knows_map": True, "behaviors": [beh]}]
    sc = {"run": run, "radio": radio, "world": world, "robots": robots,
          "checks": checks if checks is not None else default_checks()}
    if kills:
        sc["events"] = [{"at": at, "kill": ids} for at, ids in kills]
    return sc


def default_checks(heal: bool = False) -> list[dict]:
    """The checks of a relays run; with ``heal``, a 20 s healing window and relays.healed."""
    connected = {"use": "relays.connected", "heal_window": 20.0} if heal else {"use": "relays.connected"}
    out = [connected, {"use": "relays.links_within_db"}, {"use": "relays.reached"}, {"use": "world.no_collisions"}]
    return out + ([{"use": "relays.healed"}] if heal else [])


def wall_scenario(ground: int = 7, flying: int = 6, *, ticks: int = 650, seed: int = 1, **kw) -> dict:
    """Build a 3-D arena cut from side to side by a wall 0.5 m high, with the target at (8, 0) beyond it.

    Ground robots cannot pass the wall; flying robots (at 0.7 m) fly over it. The root and ``ground - 1``
    ground robots stand nearer the target than the ``flying`` flying robots (behind the root), so the first
    worker elected is a ground robot and hands over to a flying one (Fig. 4).
    """
    pts = cluster(ground) + [[-0.6 - x, y] for x, y in cluster(flying + 1)[1:]]
    area = [[-3.0, -5.0], [11.0, 5.0]]
    beh = {"use": "relays", "targets": [[8.0, 0.0]], "area": area, **kw}
    common = {"speed": PAPER["vmax"], "body_radius": 0.125, "knows_map": True}
    groups = [{"positions": [p + [0.0] for p in pts[:ground]], **common, "behaviors": [beh]},
              {"positions": [p + [0.7] for p in pts[ground:]], "kind": "flying", "altitude": [0.7, 0.7], **common,
               "behaviors": [{**beh, "kind": "flying"}]}]
    return relays_scenario(ground + flying, ticks=ticks, seed=seed, dims=3, groups=groups,
                           bounds=[[-3.0, -5.0, 0.0], [11.0, 5.0, 2.0]],
                           obstacles=[{"box": [[4.0, -5.0], [4.6, 5.0]], "z": [0.0, 0.5]}])


def window_wall(x=(4.0, 4.5), y_span=(-5.0, 5.0), window_y=(-1.0, 1.0), window_z=(0.8, 1.8), top=2.5) -> list:
    """A wall across the arena (x in ``x``, y in ``y_span``, from the ground to ``top``) with a window.

    The window is the hole y in ``window_y``, z in ``window_z``; the wall is four boxes (prisms with a z-extent)
    round it: below, above, and on either side.
    """
    (xa, xb), (ya, yb), (wa, wb), (za, zb) = x, y_span, window_y, window_z
    return [{"box": [[xa, wa], [xb, wb]], "z": [0.0, za]}, {"box": [[xa, wa], [xb, wb]], "z": [zb, top]},
            {"box": [[xa, ya], [xb, wa]], "z": [0.0, top]}, {"box": [[xa, wb], [xb, yb]], "z": [0.0, top]}]


def window_scenario(flying: int = 9, ground: int = 1, *, ticks: int = 450, seed: int = 1, **kw) -> dict:
    """Build a 3-D arena cut by a wall from the ground to the ceiling (2.5 m) with a window, the target beyond it.

    The wall (x in [4, 4.5]) has a window y in [-1, 1], z in [0.8, 1.8]; the target is at (8, 0) on the ground.
    The root and ``ground - 1`` ground robots stand nearest the target, the ``flying`` flying robots (on the
    ground, free to fly between 0 and 2.5 m) behind the root. The 3-D planner (``air`` = [0, 2.5]) finds pi
    through the window: up from the root, through the window at about 1.1 m, down to the target.
    """
    pts = cluster(ground) + [[-0.6 - x, y] for x, y in cluster(flying + 1)[1:]]
    area = [[-3.0, -5.0], [11.0, 5.0]]
    beh = {"use": "relays", "targets": [[8.0, 0.0]], "area": area, "air": [0.0, 2.5], **kw}
    common = {"speed": PAPER["vmax"], "body_radius": 0.125, "knows_map": True}
    groups = [{"positions": [p + [0.0] for p in pts[:ground]], **common, "behaviors": [beh]},
              {"positions": [p + [0.0] for p in pts[ground:]], "kind": "flying", "altitude": [0.0, 2.5], **common,
               "behaviors": [{**beh, "kind": "flying"}]}]
    return relays_scenario(ground + flying, ticks=ticks, seed=seed, dims=3, groups=groups,
                           bounds=[[-3.0, -5.0, 0.0], [11.0, 5.0, 2.5]], obstacles=window_wall(top=2.5))


def maze_cells(cols: int, rows: int, corridor: int = 2, wall: int = 1, cell: float = 1.0):
    """Centre of maze cell (c, r) (r = 0 the top row, as ``swarmactors.runs.maps.maze`` draws it), in world units."""
    step, height = corridor + wall, rows * (corridor + wall) + wall

    def centre(c: int, r: int) -> list[float]:
        return [(wall + c * step + corridor / 2) * cell, (height - wall - r * step - corridor / 2) * cell]

    return centre


def maze_scenario(n: int = 16, cols: int = 3, rows: int = 3, *, maze_seed: int = 0, corridor: int = 2,
                  wall: int = 1, cell: float = 1.0, ticks: int = 700, spacing: float = 0.5, **kw) -> dict:
    """A generated perfect maze (world ``map = {maze = ...}``), the root and the target in opposite corners.

    The root stands in the top-left cell, the target in the bottom-right one, the other robots on a grid
    around the root inside the corridors. Every robot knows the map (``knows_map``); the planning area is
    the map's extent.
    """
    from swarmactors.runs.maps import maze

    plan = maze(cols, rows, seed=maze_seed, corridor=corridor, wall=wall)
    h = len(plan)
    centre = maze_cells(cols, rows, corridor, wall, cell)
    root, target = centre(0, 0), centre(cols - 1, rows - 1)

    def free(x: float, y: float, r: float = 0.3) -> bool:
        """The square of half-side r around (x, y) lies in the corridors."""
        corners = [((x + dx) / cell, (y + dy) / cell) for dx in (-r, r) for dy in (-r, r)]
        return all(0 <= u < len(plan[0]) and 0 <= v < h and plan[h - 1 - int(v)][int(u)] == "." for u, v in corners)

    k = int(n ** 0.5) + 4
    spots = sorted(((root[0] + i * spacing, root[1] + j * spacing) for i in range(-k, k + 1) for j in range(-k, k + 1)
                    if (i, j) != (0, 0)), key=lambda p: (round(math.dist(p, root), 6), p))
    spots = [p for p in spots if free(*p)][: n - 1]
    if len(spots) < n - 1:
        raise ValueError(f"maze_scenario: room for {len(spots) + 1} robots around the root, not {n}")
    positions = [root] + [[round(x, 4), round(y, 4)] for x, y in spots]
    grid_map = {"maze": {"cols": cols, "rows": rows, "seed": maze_seed, "corridor": corridor, "wall": wall},
                "cell": cell}
    return relays_scenario(n, [target], ticks=ticks, positions=positions, grid_map=grid_map, **kw)


C_SHAPE = [{"c_shape": {"center": [4.5, 0.0], "size": 3.0, "thickness": 0.4, "opening": "-x"}}]


def _case(name: str, sc: dict, checks: list[dict] | None = None) -> Case:
    sc = dict(sc)
    sc["run"] = {k: v for k, v in sc["run"].items() if k != "name"}
    sc.pop("checks", None)
    return Case(f"relays/{name}", sc, checks if checks is not None else default_checks())


def suite(mode: str) -> list[Case]:
    """Open field, three consecutive failures, realtime; the full suite adds more.

    The full suite adds the C-shape, loss, WP, two targets, ground + flying (over a low wall, and through a
    window with the 3-D planner), a generated maze and two redundant chains to one target.
    """
    cases = [
        _case("open-10", relays_scenario(10, [[8.0, 0.0]], ticks=260)),
        _case("open-12-kill-3", relays_scenario(12, [[8.0, 0.0]], ticks=560, kills=[(250, [2, 5, 1])]),
              default_checks(heal=True)),
        _case("open-6-realtime", relays_scenario(6, [[3.0, 0.0]], ticks=200, dt=0.1, clock="realtime",
                                                 bid_time=1.0)),
    ]
    if mode == "full":
        cases += [
            _case("c-shape-12", relays_scenario(12, [[8.0, 0.0]], ticks=600, obstacles=C_SHAPE)),
            _case("open-10-kill-1-loss-0.1", relays_scenario(10, [[8.0, 0.0]], ticks=700, loss=0.1,
                                                             kills=[(300, [5])]), default_checks(heal=True)),
            _case("open-10-wp", relays_scenario(10, [[8.0, 0.0]], ticks=260, wp=True)),
            _case("open-12-two-targets", relays_scenario(12, [[5.0, 3.0], [5.0, -3.0]], ticks=600)),
            _case("wall-ground-and-flying-13", wall_scenario(ticks=500)),
            _case("window-ground-and-flying-14", window_scenario(8, 6, ticks=450)),
            _case("maze-3x3-16", maze_scenario(16, 3, 3, maze_seed=0, ticks=450)),
            _case("open-18-two-chains", relays_scenario(18, [[8.0, 0.0]], ticks=400, chains_per_target=2)),
        ]
    return cases


FAMILY = Family(name="relays", behavior="relays",
                report={"reached_at": (int, type(None)), "plan_status": (str, type(None))},
                suite=suite,
                behaviors={"relays": "protocols.relays.behavior:Relays"},
                checks={f"relays.{c}": f"protocols.relays.oracle:{c}"
                        for c in ("connected", "links_within_db", "reached", "healed")})
