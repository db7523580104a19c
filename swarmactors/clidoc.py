"""The command line as a document: the reference tables of docs/cli.md, generated from the argparse parser.

``python -m swarmactors.clidoc`` rewrites the part of docs/cli.md between ``<!-- cli -->`` and
``<!-- end cli -->`` from ``swarmactors.cli.build_parser()``: one section per command with its help and a table
of its arguments and options (their help strings as the parser has them, ``%(default)s`` expanded). ``--check``
only says whether the page is current (a unit test runs it), so a new option cannot go undocumented.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

DOC = Path("docs") / "cli.md"  # in a checkout of the project (the docs are not installed)
_BLOCK = re.compile(r"(<!-- cli -->\n)(.*?)(<!-- end cli -->)", re.DOTALL)


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """(name, help, parser) of each subcommand, in the order they were added."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            out += [(name, helps.get(name, ""), sub) for name, sub in action.choices.items()]
    return out


def _metavar(action: argparse.Action) -> str:
    if action.metavar is not None:
        mv = action.metavar if isinstance(action.metavar, str) else " ".join(action.metavar)
    elif action.choices is not None:
        mv = "{" + ",".join(str(c) for c in action.choices) + "}"
    else:
        mv = action.dest if not action.option_strings else action.dest.upper()
    nargs = action.nargs
    if nargs == "?":
        return f"[{mv}]"
    if nargs == "*":
        return f"[{mv} ...]"
    if nargs == "+":
        return f"{mv} [{mv} ...]"
    if isinstance(nargs, int):
        return " ".join([mv] * nargs)
    return mv


def _name(action: argparse.Action) -> str:
    if not action.option_strings:
        return _metavar(action)
    names = ", ".join(action.option_strings)
    return names if action.nargs == 0 else f"{names} {_metavar(action)}"


def _help(action: argparse.Action, prog: str) -> str:
    """The help string as argparse prints it (``%(default)s``, ``%(choices)s``, ``%(prog)s`` expanded)."""
    text = action.help or ""
    if "%" in text:
        params = {k: v for k, v in dict(vars(action), prog=prog).items() if v is not argparse.SUPPRESS}
        params = {k: getattr(v, "__name__", v) for k, v in params.items()}
        if params.get("choices") is not None:
            params["choices"] = ", ".join(str(c) for c in params["choices"])
        text = text % params
    return text


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def _table(parser: argparse.ArgumentParser) -> list[str]:
    rows = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)) or action.help == argparse.SUPPRESS:
            continue
        rows.append(f"| `{_cell(_name(action))}` | {_cell(_help(action, parser.prog))} |")
    return ["| argument | meaning |", "|---|---|", *rows] if rows else []


def _section(prog: str, help_text: str, parser: argparse.ArgumentParser, level: int) -> list[str]:
    lines = [f"{'#' * level} `{prog}`", ""]
    if help_text:
        lines += [_cell(help_text[0].upper() + help_text[1:]).rstrip(".") + ".", ""]
    table = _table(parser)
    if table:
        lines += [*table, ""]
    for name, sub_help, sub in _subcommands(parser):
        lines += _section(f"{prog} {name}", sub_help, sub, level + 1)
    return lines


def reference() -> str:
    """The generated part of docs/cli.md: the global options, then every command and its options."""
    from swarmactors.cli import build_parser

    parser = build_parser()
    lines = ["## `swarmactors`", "", "Options before the command:", "", *_table(parser), ""]
    for name, help_text, sub in _subcommands(parser):
        lines += _section(f"swarmactors {name}", help_text, sub, 3)
    return "\n".join(lines).rstrip() + "\n"


def update(text: str) -> str:
    """``text`` (docs/cli.md) with its marked block regenerated; a page without the markers is an error."""
    if not _BLOCK.search(text):
        raise ValueError("no <!-- cli --> ... <!-- end cli --> block to fill")
    return _BLOCK.sub(lambda m: m[1] + reference() + m[3], text)


def main(argv: list[str] | None = None) -> int:
    """Rewrite the command-line reference of docs/cli.md from the parser (``--check``: only compare)."""
    p = argparse.ArgumentParser(prog="python -m swarmactors.clidoc", description=main.__doc__)
    p.add_argument("--check", action="store_true", help="exit 1 if the page is not current, change nothing")
    p.add_argument("--doc", type=Path, default=DOC, help="the command-line reference to update (default: %(default)s)")
    args = p.parse_args(argv)
    try:
        text = args.doc.read_text(encoding="utf-8")
        new = update(text)
    except (OSError, ValueError) as e:
        print(f"{args.doc}: {getattr(e, 'strerror', None) or e}; run from a checkout of the project or name the page "
              "with --doc", file=sys.stderr)
        return 2
    if args.check:
        if new != text:
            print(f"{args.doc}: the command-line reference differs from the parser; run python -m swarmactors.clidoc",
                  file=sys.stderr)
            return 1
        return 0
    if new != text:
        args.doc.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
