"""``swarmactors figures``: every family's paper figures, listed, re-drawn from saved results, or re-run.

Each family declares its figures in its experiments package (``protocols/<family>/experiments/__init__.py``)
as a list ``FIGURES`` of plain dicts, so that reading them imports nothing heavy::

    FIGURES = [{
        "id": "lambda2-fig2",                       # unique across families
        "paper": "seed 003, Fig. 2",                # the paper's figure or table
        "title": "iterations until λ2 is within 1 % against packet drop p",
        "results": "results/fig2.json",             # saved results, relative to the experiments package
        "plot": "protocols.lambda2.experiments.fig2:replot",   # fn(results: Path, out_dir: Path) -> [Path]
        "images": ["lambda2-fig2.png", "lambda2-error.png"],  # what the plot writes (docs/img/ in a checkout)
        "sweep": "protocols/lambda2/experiments/fig2.toml",   # re-run: a sweep file (relative to the checkout)
        "script": ["-m", "protocols.lambda2.experiments.fig2", "--jobs", "2"],  # or a script's arguments
        "trials": "--graphs0",                      # the script's option for --trials (optional)
        "docs": "protocols/lambda2.md#fig-2-iterations-to-converge-against-packet-drop",
        "repetitions": "20 graphs per point",       # the paper's count
    }]

The families are found through the ``swarmactors.families`` entry points (``protocols.x.suite:FAMILY`` ->
``protocols.x.experiments``), imported only when this command runs: the core imports no protocol code.
``plot`` is ``None`` for a figure drawn only from a run (a trajectory, say); ``sweep`` and ``script`` may both be
given (``--run`` prefers the sweep, the only one that takes ``--cluster``).
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Figure", "FigureError", "add_parser", "command", "figures", "plot", "run"]

_KEYS = {"id", "paper", "title", "results", "plot", "images", "sweep", "script", "trials", "docs", "repetitions"}
_REQUIRED = ("id", "paper", "title", "docs")


class FigureError(ValueError):
    """A bad figure declaration or request: names the family, the figure and the key."""


@dataclass(frozen=True)
class Figure:
    """One paper figure (or table) as a family declares it, its paths resolved."""

    id: str
    family: str
    paper: str
    title: str
    docs: str  # the docs page and section, relative to docs/
    package_dir: Path  # the experiments package's folder
    results: Path | None = None
    plot: str | None = None  # "module:function"
    images: tuple[str, ...] = ()
    sweep: str | None = None
    script: tuple[str, ...] = ()
    trials: str | None = None
    repetitions: str = ""
    extra: dict = field(default_factory=dict, compare=False)

    @property
    def checkout(self) -> Path:
        """The repository checkout the package sits in (protocols/<family>/experiments -> three levels up)."""
        return self.package_dir.parents[2]

    @property
    def saved(self) -> bool:
        return self.results is not None and self.results.is_file()


def _experiments_packages() -> dict[str, str]:
    """Family name -> its experiments package, from the ``swarmactors.families`` entry points (nothing imported)."""
    from swarmactors.robot.plugins import FAMILIES, available

    out = {}
    for name, value in sorted(available(FAMILIES).items()):
        module = value.partition(":")[0]
        out[name] = module.rpartition(".")[0] + ".experiments" if "." in module else module + ".experiments"
    return out


def _figure(family: str, package_dir: Path, raw: object, where: str) -> Figure:
    if not isinstance(raw, dict):
        raise FigureError(f"{where}: each entry of FIGURES must be a dict, not {type(raw).__name__}")
    fid = raw.get("id", "?")
    unknown = sorted(set(raw) - _KEYS)
    if unknown:
        raise FigureError(f"{where}: figure {fid!r} has unknown key(s) {', '.join(unknown)} "
                          f"(known: {', '.join(sorted(_KEYS))})")
    for key in _REQUIRED:
        if not isinstance(raw.get(key), str) or not raw[key]:
            raise FigureError(f"{where}: figure {fid!r} needs {key!r} as a non-empty string")
    plot_ref = raw.get("plot")
    if plot_ref is not None and (not isinstance(plot_ref, str) or ":" not in plot_ref):
        raise FigureError(f"{where}: figure {fid!r}: plot {plot_ref!r} must be a 'module:function' string or None")
    if plot_ref and not raw.get("results"):
        raise FigureError(f"{where}: figure {fid!r} has a plot but no 'results' file to draw it from")
    script = raw.get("script") or ()
    if not isinstance(script, (list, tuple)) or not all(isinstance(a, str) for a in script):
        raise FigureError(f"{where}: figure {fid!r}: script must be a list of strings")
    if not raw.get("sweep") and not script:
        raise FigureError(f"{where}: figure {fid!r} needs 'sweep' or 'script' (how to re-run it)")
    return Figure(id=raw["id"], family=family, paper=raw["paper"], title=raw["title"], docs=raw["docs"],
                  package_dir=package_dir, results=package_dir / raw["results"] if raw.get("results") else None,
                  plot=plot_ref, images=tuple(raw.get("images") or ()), sweep=raw.get("sweep"),
                  script=tuple(script), trials=raw.get("trials"), repetitions=raw.get("repetitions", ""))


def checkout_root(start: Path | None = None) -> Path | None:
    """The source checkout the figures' files live in, found from ``start`` (default: the current directory).

    The first of ``start`` and its parents holding ``protocols/`` and ``docs/``. Saved results, sweep files and
    docs/img are part of the checkout, not of an installed package, so a non-editable install finds them only here.
    """
    here = (start or Path.cwd()).resolve()
    for d in (here, *here.parents):
        if (d / "protocols").is_dir() and (d / "docs").is_dir():
            return d
    return None


def _package_dir(package: str, module_file: str, root: Path | None) -> Path:
    """The experiments package's folder in the checkout when it has one, else where the module was imported from."""
    if root is not None:
        candidate = root.joinpath(*package.split("."))
        if (candidate / "__init__.py").is_file():
            return candidate.resolve()
    return Path(module_file).resolve().parent


def figures(packages: dict[str, str] | None = None, root: Path | None = None) -> dict[str, Figure]:
    """Every declared figure by id, in family order. A family without an experiments package declares none.

    Paths resolve in ``root`` (default: the checkout around the current directory, `checkout_root`).
    """
    root = root if root is not None else checkout_root()
    out: dict[str, Figure] = {}
    for family, package in (packages or _experiments_packages()).items():
        try:
            mod = importlib.import_module(package)
        except ModuleNotFoundError as exc:
            if exc.name and package.startswith(exc.name):
                continue  # no experiments package: no figures
            raise
        declared = getattr(mod, "FIGURES", None)
        if declared is None:
            continue
        where = f"{package}.FIGURES"
        if not isinstance(declared, (list, tuple)):
            raise FigureError(f"{where} must be a list of dicts, not {type(declared).__name__}")
        package_dir = _package_dir(package, mod.__file__, root)
        for raw in declared:
            fig = _figure(family, package_dir, raw, where)
            if fig.id in out:
                raise FigureError(f"{where}: figure id {fig.id!r} is already declared by family "
                                  f"{out[fig.id].family!r}")
            out[fig.id] = fig
    return out


def pick(known: dict[str, Figure], ids: list[str]) -> list[Figure]:
    """The figures named, in order; an unknown id is an error naming it and listing the known ones."""
    bad = [i for i in ids if i not in known]
    if bad:
        raise FigureError(f"unknown figure id{'s' if len(bad) > 1 else ''} {', '.join(map(repr, bad))}; "
                          f"known: {', '.join(known)}")
    return [known[i] for i in ids]


def _function(ref: str):
    module, _, name = ref.partition(":")
    fn = getattr(importlib.import_module(module), name, None)
    if not callable(fn):
        raise FigureError(f"{ref}: module {module!r} has no function {name!r}")
    return fn


def default_out(fig: Figure) -> Path:
    """Where ``--plot`` draws by default: the checkout's docs/img (the images the docs show)."""
    return fig.checkout / "docs" / "img"


def plot(fig: Figure, out_dir: Path) -> list[Path]:
    """Re-draw one figure from its saved results into ``out_dir``; the paths written."""
    if fig.plot is None:
        raise FigureError(f"figure {fig.id!r} is drawn only from a run (no saved-results plot): "
                          f"swarmactors figures --run {fig.id}")
    if not fig.saved:
        raise FigureError(f"figure {fig.id!r}: no saved results at {fig.results}; run it first "
                          f"(swarmactors figures --run {fig.id})")
    out_dir.mkdir(parents=True, exist_ok=True)
    return [Path(p) for p in _function(fig.plot)(fig.results, out_dir) or []]


def run_command(fig: Figure, cluster: str | None = None, trials: int | None = None,
                out: Path | None = None) -> list[str]:
    """The command line ``--run`` executes for one figure (a sweep where declared, else the family's script)."""
    if fig.sweep:
        cmd = [sys.executable, "-m", "swarmactors", "sweep", str(fig.checkout / fig.sweep)]
        if cluster:
            cmd += ["--cluster", cluster]
        if trials is not None:
            cmd += ["--trials", str(trials)]
        if out is not None:
            cmd += ["--out", str(out)]
        return cmd
    if cluster:
        raise FigureError(f"figure {fig.id!r} runs through its family's script, which takes no --cluster: "
                          f"{' '.join(fig.script)}")
    cmd = [sys.executable, *fig.script]
    if trials is not None:
        if not fig.trials:
            raise FigureError(f"figure {fig.id!r}: its script ({' '.join(fig.script)}) has no repetition option; "
                              "leave --trials out")
        cmd += [fig.trials, str(trials)]
    if out is not None:
        raise FigureError(f"figure {fig.id!r} runs through its family's script, which chooses its own output; "
                          "leave --out out")
    return cmd


def run(fig: Figure, cluster: str | None = None, trials: int | None = None, out: Path | None = None) -> int:
    """Re-run one figure's experiment (in the checkout, so relative paths resolve); its exit code."""
    cmd = run_command(fig, cluster, trials, out)
    print("$ " + " ".join(cmd[1:] if cmd[1:3] == ["-m", "swarmactors"] else cmd), flush=True)
    t0 = time.perf_counter()
    code = subprocess.call(cmd, cwd=fig.checkout, env={**os.environ, "PYTHONHASHSEED": "0"})
    print(f"{fig.id}: exit {code} after {time.perf_counter() - t0:.0f} s", flush=True)
    return code


def listing(known: dict[str, Figure]) -> list[tuple[str, ...]]:
    rows = [("id", "paper", "saved results", "plot", "re-run")]
    for f in known.values():
        saved = ("yes" if f.saved else "MISSING") if f.results is not None else "-"
        rows.append((f.id, f.paper, saved, "from results" if f.plot else "from a run",
                     "sweep" if f.sweep else "script"))
    return rows


def add_parser(sub) -> None:
    """Register ``swarmactors figures`` on the command line's subparsers."""
    sp = sub.add_parser("figures", help="the families' paper figures: list them, re-draw them from saved results "
                                        "(--plot) or re-run them (--run)")
    sp.add_argument("ids", nargs="*", metavar="ID", help="figure ids (default with --plot: every figure)")
    what = sp.add_mutually_exclusive_group()
    what.add_argument("--plot", action="store_true", help="re-draw the figures from their saved results")
    what.add_argument("--run", action="store_true", help="re-run the figures' experiments (a sweep or a script)")
    what.add_argument("--command", dest="show_command", action="store_true",
                      help="print the command --run would execute, and run nothing")
    sp.add_argument("--out", type=Path, help="--plot: draw into this directory (default: the checkout's "
                                             "docs/img); --run: the sweep's output directory")
    sp.add_argument("--cluster", metavar="tcp://HOST:8786", help="--run: the sweep's Dask scheduler")
    sp.add_argument("--trials", type=int, help="--run: repetitions per point (default: the paper's count)")


def command(args) -> int:
    """``swarmactors figures``: exit 0, 2 on an unknown id or bad request, else the run's exit code."""
    from swarmactors.exitcodes import EXIT_INPUT, EXIT_OK, EXIT_RUNTIME

    try:
        known = figures()
        chosen = pick(known, args.ids) if args.ids else list(known.values())
        acting = args.plot or args.run or args.show_command
        if not acting and (args.cluster or args.trials is not None or args.out):
            raise FigureError("--out, --cluster and --trials go with --plot or --run")
        if args.plot and (args.cluster or args.trials is not None):
            raise FigureError("--cluster and --trials go with --run, not --plot")
        if (args.run or args.show_command) and not args.ids:
            raise FigureError(f"--run needs figure ids; known: {', '.join(known)}")
        if args.trials is not None and args.trials < 1:
            raise FigureError(f"--trials must be at least 1, not {args.trials}")
        if args.show_command:
            for fig in chosen:
                print(" ".join(run_command(fig, args.cluster, args.trials, args.out)))
            return EXIT_OK
        if args.run:
            for fig in chosen:
                run_command(fig, args.cluster, args.trials, args.out)  # every request checked before any runs
            codes = [run(fig, args.cluster, args.trials, args.out) for fig in chosen]
            return next((c for c in codes if c), EXIT_OK)
        if args.plot:
            todo = [f for f in chosen if f.plot] if not args.ids else chosen
            failed = 0
            for fig in todo:
                t0 = time.perf_counter()
                try:
                    paths = plot(fig, args.out or default_out(fig))
                except FigureError:
                    raise
                except Exception as exc:  # one figure's failure costs that figure, not the others
                    print(f"{fig.id}: failed: {exc.__class__.__name__}: {exc}", file=sys.stderr)
                    failed += 1
                    continue
                shown = ", ".join(str(p) for p in paths if p.suffix == ".png") or "no image"
                print(f"{fig.id}: {shown} ({time.perf_counter() - t0:.1f} s)")
            return EXIT_RUNTIME if failed else EXIT_OK
    except FigureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    rows = listing({f.id: f for f in chosen})
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
    for row in rows:
        print("  ".join([*(f"{c:<{w}}" for c, w in zip(row[:-1], widths, strict=True)), row[-1]]).rstrip())
    return EXIT_OK
