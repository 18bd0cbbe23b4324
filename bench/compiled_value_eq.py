"""Every == / != in the compiled modules between two values mypy types as one @value class.

Compiled, mypyc makes such a comparison a pointer test: it sees no __eq__ in an @value class
(the decorator adds it at run time, and mypyc knows only dataclasses.dataclass). Issue 43: the
compiled test course drove 0.3 mm less for it. Each must go through operator.eq / operator.ne.
Exit 1, one line each (class, line, operator), when there is any; run from the checkout:

    .venv/bin/python bench/compiled_value_eq.py      # about a minute
"""

from __future__ import annotations

import runpy
import sys
from typing import Any

from mypy import build
from mypy.modulefinder import BuildSource
from mypy.nodes import ComparisonExpr, RefExpr, TypeInfo
from mypy.options import Options
from mypy.types import Instance, NoneType, UnionType, get_proper_type

VALUE = "bywire.control.values.value"


def _sources() -> list[BuildSource]:
    modules = runpy.run_path("setup.py", run_name="lists")["compiled_modules"]()
    return [
        BuildSource(f"src/{path}", path[:-3].replace("/", ".").removesuffix(".__init__"))
        for path in modules
    ]


def _value_class(info: TypeInfo) -> bool:
    return any(isinstance(d, RefExpr) and d.fullname == VALUE for d in info.defn.decorators)


def _without_none(typ: Any) -> Any:
    typ = get_proper_type(typ)
    if isinstance(typ, UnionType):
        items = [get_proper_type(i) for i in typ.items]
        kept = [i for i in items if not isinstance(i, NoneType)]
        return kept[0] if len(kept) == 1 else typ
    return typ


def main() -> int:
    options = Options()
    options.mypy_path = ["src"]
    options.python_version = (3, 11)
    options.preserve_asts = True
    options.export_types = True
    options.incremental = False
    result = build.build(_sources(), options)
    found = set()
    for expr in list(result.types):
        if not isinstance(expr, ComparisonExpr):
            continue
        pairs = zip(expr.operators, expr.operands, expr.operands[1:], strict=False)
        for operator, left, right in pairs:
            if operator not in ("==", "!="):
                continue
            left_type, right_type = (_without_none(result.types.get(x)) for x in (left, right))
            if (
                isinstance(left_type, Instance)
                and isinstance(right_type, Instance)
                and left_type.type is right_type.type
                and _value_class(left_type.type)
            ):
                found.add((left_type.type.fullname, expr.line, operator))
    for fullname, line, operator in sorted(found):
        print(f"{fullname}: {operator} at line {line} of the module comparing it")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
