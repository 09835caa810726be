"""OpenSCENARIO parameters and expressions: the file's global ``ParameterDeclarations``
substituted into every attribute (ASAM OpenSCENARIO XML 1.3: a parameter ``$Name``, an
expression ``${...}``, as the schema's ``parameter`` and ``expression`` patterns write them).

The expressions read are arithmetic: numbers, parameters, ``+ - * / %``, ``**`` is not in the
standard and is refused; unary minus; parentheses; and the standard's functions ``round``,
``floor``, ``ceil``, ``sqrt`` and ``pow``.  Boolean expressions, parameter declarations below
the top level and parameter distributions are outside the subset (refused by the reader).
"""

from __future__ import annotations

import ast
import math
import operator
import re

from acc_fusion.core.errors import InputError

_NAME = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Mod: operator.mod}  # fmt: skip
_FUNCTIONS = {"round": round, "floor": math.floor, "ceil": math.ceil, "sqrt": math.sqrt,
              "pow": math.pow}  # fmt: skip


def evaluate(text: str, values: dict[str, str], where: str) -> str:
    """The value of an attribute: ``$Name`` a parameter's value, ``${expr}`` the expression's
    (as text, ``repr`` of a float), anything else as it is; one InputError (``where`` tells
    from where) for an unknown parameter or an expression outside the subset."""
    if not text.startswith("$"):
        return text
    if not text.startswith("${"):
        name = text[1:]
        if name not in values:
            raise InputError(f"{where}: parameter ${name} is not declared")
        return values[name]
    if not text.endswith("}"):
        raise InputError(f"{where}: expression {text!r} has no closing brace")
    source = _NAME.sub(lambda m: f"_p_{m.group(1)}", text[2:-1])
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError:
        raise InputError(f"{where}: expression {text!r} is not arithmetic") from None

    def value(node):
        if isinstance(node, ast.Expression):
            return value(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id.startswith("_p_"):
            return float(evaluate(f"${node.id[3:]}", values, where))
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return -value(node.operand) if isinstance(node.op, ast.USub) else value(node.operand)
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in _FUNCTIONS and not node.keywords):  # fmt: skip
            return float(_FUNCTIONS[node.func.id](*(value(a) for a in node.args)))
        raise InputError(f"{where}: expression {text!r} is outside the arithmetic subset")

    try:
        return repr(value(tree))
    except (ValueError, ZeroDivisionError, TypeError):
        raise InputError(f"{where}: expression {text!r} cannot be evaluated") from None


def substitute(root, name: str) -> None:
    """Resolve the top-level ``ParameterDeclarations`` of the OpenSCENARIO document ``root``
    (in order: a value may use those before it) and replace every ``$`` attribute below it by
    its value, in place; ``name`` (the file's) goes into the errors."""
    values: dict[str, str] = {}
    for decl in root.iterfind("ParameterDeclarations/ParameterDeclaration"):
        where = f"{name} line {decl.sourceline}"
        values[decl.get("name", "")] = evaluate(decl.get("value", ""), values, where)
    for el in root.iter():
        if not isinstance(el.tag, str) or el.tag == "ParameterDeclaration":
            continue  # comments, processing instructions and the declarations
        for key, text in el.attrib.items():
            if text.startswith("$"):
                el.set(key, evaluate(text, values, f"{name} line {el.sourceline}"))
