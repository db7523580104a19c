"""The scenario model as documents: its JSON Schema, and the key tables of docs/scenarios.md.

``swarmactors schema`` prints the JSON Schema of a scenario file (editors complete and check TOML with it);
``python -m swarmactors.runs.schema --markdown`` rewrites the key tables of docs/scenarios.md between their
``<!-- keys: NAME -->`` and ``<!-- end keys -->`` markers from the model (transport/scenario.py), and
``--check`` only says whether they are current (a unit test runs it).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

import msgspec
from msgspec import inspect as mi

from transport import scenario as model

DOC = Path("docs") / "scenarios.md"  # in a checkout of the project (the docs are not installed)
TABLES: dict[str, Any] = {"run": model.Run, "radio": model.Radio, "channel": model.Channel, "world": model.World,
                          "robots": model.RobotGroup, "events": model.Event}
_BLOCK = re.compile(r"(<!-- keys: (\w+) -->\n)(.*?)(<!-- end keys -->)", re.DOTALL)


def json_schema() -> str:
    """The JSON Schema of a scenario file, as indented JSON text."""
    return json.dumps(model.schema(), indent=2, ensure_ascii=False)


_SUPER = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def _fmt(v: float) -> str:
    """A limit as the docs write it: 0, 1, 0.5, 10⁹, −10⁶."""
    exp = f"{abs(v):e}".split("e")
    if abs(v) >= 1e5 and float(exp[0]) == 1.0:
        return ("−" if v < 0 else "") + "10" + str(int(exp[1])).translate(_SUPER)
    return f"{v:g}".replace("-", "−")


def _number(t: Any, word: str) -> str:
    """A number type's limits in words: ``number > 0``, ``integer ≥ 0``, ``number in [0, 1]``."""
    lo = t.ge if t.ge is not None and abs(t.ge) < model.FLOAT_MAX else None
    hi = t.le if t.le is not None and abs(t.le) < model.FLOAT_MAX else None
    if t.gt is not None:
        return f"{word} > {_fmt(t.gt)}" + (f", ≤ {_fmt(hi)}" if hi is not None else "")
    if lo is not None and hi is not None:
        return f"{word} in {_fmt(lo)}..{_fmt(hi)}" if word == "integer" else f"{word} in [{_fmt(lo)}, {_fmt(hi)}]"
    if lo is not None:
        return f"{word} ≥ {_fmt(lo)}"
    return word


def type_words(info: Any) -> str:
    """A key's type as the docs write it (``number > 0``, ``"lockstep"`` or ``"realtime"``, ``boolean``)."""
    info, _ = model._unwrap(info)
    members = model._members(info)
    numbers = [m for m in members if isinstance(m, mi.FloatType)]
    words: list[str] = []
    for m in members:
        if isinstance(m, (mi.NoneType,)) or (isinstance(m, mi.IntType) and numbers):
            continue
        if isinstance(m, mi.FloatType):
            words.append(_number(m, "number"))
        elif isinstance(m, mi.IntType):
            words.append(_number(m, "integer"))
        elif isinstance(m, mi.BoolType):
            words.append("boolean")
        elif isinstance(m, mi.LiteralType):
            words.append(" or ".join(f"`{json.dumps(v)}`" for v in sorted(m.values, key=str)))
        elif isinstance(m, mi.StrType):
            words.append("string")
        elif isinstance(m, mi.ListType):
            item = model._unwrap(m.item_type)[0]
            words.append("`[lo, hi]`" if m.min_length == m.max_length == 2 and not isinstance(item, mi.ListType)
                         else "array")
        else:
            words.append("table")
    return ", or ".join(words)


def _default(field: Any, extra: dict) -> str:
    if "default" in extra:
        return extra["default"]
    if field.required:
        return "required"
    value = field.default if field.default_factory is msgspec.NODEFAULT else field.default_factory()
    if value is None:
        return "none"
    return f"`{json.dumps(msgspec.to_builtins(value), ensure_ascii=False)}`"


def table(name: str) -> str:
    """The markdown key table of section ``name`` (``TABLES``), from the model."""
    info = model._info(TABLES[name])
    events = name == "events"
    rows = ["| action | value | effect |" if events else "| key | type | default | meaning |",
            "|---|---|---|" if events else "|---|---|---|---|"]
    for field in info.fields:
        if events and field.name == "at":
            continue
        extra = model._unwrap(field.type)[1] or {}
        meaning = _meaning(field.type)
        shape = extra.get("shape") or type_words(field.type)
        cells = [f"`{field.name}`", shape, meaning] if events else [f"`{field.name}`", shape,
                                                                        _default(field, extra), meaning]
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(rows) + "\n"


def _meaning(info: Any) -> str:
    while isinstance(info, mi.Metadata):
        if info.extra_json_schema and "description" in info.extra_json_schema:
            return info.extra_json_schema["description"]
        info = info.type
    return ""


def update(text: str) -> str:
    """``text`` (docs/scenarios.md) with every marked key table regenerated."""
    return _BLOCK.sub(lambda m: m[1] + table(m[2]) + m[4], text)


def main(argv: list[str] | None = None) -> int:
    """Print the JSON Schema; ``--markdown`` rewrites docs/scenarios.md's key tables (``--check``: only compare)."""
    p = argparse.ArgumentParser(prog="swarmactors schema", description=main.__doc__)
    p.add_argument("--markdown", action="store_true", help="regenerate the key tables of docs/scenarios.md")
    p.add_argument("--check", action="store_true", help="with --markdown: exit 1 if the tables are not current")
    p.add_argument("--doc", type=Path, default=DOC, help="the scenario reference to update (default: %(default)s)")
    args = p.parse_args(argv)
    if not args.markdown:
        print(json_schema())
        return 0
    try:
        text = args.doc.read_text(encoding="utf-8")
    except OSError as e:
        print(f"{args.doc}: cannot read the scenario reference ({e.strerror}); run from a checkout of the project "
              "or name it with --doc", file=sys.stderr)
        return 2
    new = update(text)
    if args.check:
        if new != text:
            print(f"{args.doc}: the key tables differ from the model; run python -m swarmactors.runs.schema --markdown",
                  file=sys.stderr)
            return 1
        return 0
    if new != text:
        args.doc.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
