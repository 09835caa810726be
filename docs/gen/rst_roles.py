"""A griffe extension: the reST of acc_fusion's docstrings rendered as Markdown on the docs site.

The docstrings are written for readers of the source (Google style with reST roles, as filterpy
and Stone Soup do): ``:math:`x``` and ``.. math::`` blocks become TeX that arithmatex keeps from
Markdown and ``math.py`` renders to MathML, ``:class:`~a.b.C``` and the other cross-reference
roles become code spans with the short name, ``literal`` double back-quotes become single ones.
"""

from __future__ import annotations

import re

import griffe

_MATH = re.compile(r":math:`([^`]+)`")
_LITERAL = re.compile(r"``([^`]+)``")


def _short(target: str, tilde: bool) -> str:
    return target.rsplit(".", 1)[-1] if tilde else target


def _has_rows(tex: str) -> bool:
    """Whether an equation breaks lines (``\\\\``) outside its environments: Sphinx then
    aligns its rows, and so does the site."""
    depth = 0
    for token in re.findall(r"\\begin\{|\\end\{|\\\\", tex):
        if token == "\\\\" and depth == 0:
            return True
        depth += {"\\begin{": 1, "\\end{": -1}.get(token, 0)
    return False


def _math_blocks(text: str) -> str:
    """reST ``.. math::`` blocks as display maths: as in Sphinx, each paragraph of the body is
    one equation, its lines one TeX expression (a line break is a space, not a new row).

    Each equation is written on one line as ``\\(\\displaystyle …\\)``, which ``math.py``
    renders as a block equation: a line of the paragraph it stands in, it needs no blank line
    around it, so it keeps a list or a definition it belongs to whole, and no line of its TeX
    can start a Markdown list."""
    out, lines, i = [], text.split("\n"), 0
    while i < len(lines):
        line = lines[i]
        m = re.match(r"^(\s*)\.\. math::\s*(.*)$", line)
        if not m:
            out.append(line)
            i += 1
            continue
        indent, body = m.group(1), [m.group(2)]
        i += 1
        while i < len(lines) and (not lines[i].strip() or lines[i].startswith(indent + " ")):
            body.append(lines[i].strip())
            i += 1
        for equation in re.split(r"\n\n+", "\n".join(body).strip()):
            tex = " ".join(equation.split())
            if _has_rows(tex):  # rows aligned at their & as Sphinx does, or centred
                env = "split" if "&" in tex else "matrix"
                tex = f"\\begin{{{env}}} {tex} \\end{{{env}}}"
            out.append(f"{indent}\\(\\displaystyle {tex}\\)")
    return "\n".join(out)


_RULE = re.compile(r"^\s*=+(?: +=+)+\s*$")


def _simple_tables(text: str) -> str:
    """reST simple tables (columns under runs of ``=``, a rule above and below, and one
    under the header if any) as Markdown tables; a line whose first column is empty goes on
    with the row above."""
    lines, out, i = text.split("\n"), [], 0
    while i < len(lines):
        if not _RULE.match(lines[i]):
            out.append(lines[i])
            i += 1
            continue
        end = i
        while end < len(lines) and lines[end].strip():
            end += 1
        block = lines[i:end]
        rules = [k for k, line in enumerate(block) if _RULE.match(line)]
        starts = [m.start() for m in re.finditer(r"=+", block[0])]
        bounds = list(zip(starts, [*starts[1:], None], strict=True))
        rows, header = [], 0
        for k, line in enumerate(block):
            if k in rules:
                header = len(rows) if k == rules[1] and len(rules) > 2 else header
                continue
            cells = [line[a:b].strip().replace("|", "\\|") for a, b in bounds]
            if rows and not cells[0]:
                rows[-1] = [
                    f"{old} {new}".strip() for old, new in zip(rows[-1], cells, strict=True)
                ]
            else:
                rows.append(cells)
        head = rows[:header] or [[""] * len(bounds)]
        table = [*head[:1], ["---"] * len(bounds), *rows[header:]]
        out += ["", *("| " + " | ".join(row) + " |" for row in table), ""]
        i = end
    return "\n".join(out)


def _doctests(text: str) -> str:
    """Fence doctest examples (``>>>`` lines and their output) as ``pycon`` code blocks."""
    out, lines, i = [], text.split("\n"), 0
    while i < len(lines):
        m = re.match(r"^(\s*)>>> ", lines[i])
        if not m:
            out.append(lines[i])
            i += 1
            continue
        indent, block = m.group(1), []
        while i < len(lines) and lines[i].strip():
            block.append(lines[i][len(indent) :])
            i += 1
        out += [f"{indent}```pycon", *(indent + b for b in block), f"{indent}```"]
    return "\n".join(out)


def _flatten_definitions(text: str) -> str:
    """reST definition lists (a term, then its body indented) as a bold term and a paragraph;
    Markdown would read the indented body as code."""
    lines, out = text.split("\n"), []
    for k, line in enumerate(lines):
        nxt = lines[k + 1] if k + 1 < len(lines) else ""
        if line.startswith("    "):
            body = line.lstrip()
            out.append(("\n" if body.startswith(("* ", "- ")) and out and out[-1] else "") + body)
        elif line.strip() and not line.startswith(" ") and nxt.startswith("    "):
            out += ["", f"**{line.strip()}**", ""]
        else:
            out.append(line)
    return "\n".join(out)


def render(text: str, module: bool = False) -> str:
    """The Markdown form of a docstring written with reST roles (``module``: a module's
    docstring, whose indented blocks are reST definition lists)."""
    parts = re.split(r"(^\s*```.*?^\s*```)", _doctests(_simple_tables(text)), flags=re.S | re.M)
    return "".join(
        p
        if i % 2
        else _inline(_flatten_definitions(_math_blocks(p)) if module else _math_blocks(p))
        for i, p in enumerate(parts)
    )


def _inline(text: str) -> str:
    """Inline roles and literals; the TeX of the equations (``\\(…\\)``) is left as it is,
    but for its literals, which lose their quotes."""
    text = _MATH.sub(lambda m: f"\\({' '.join(m.group(1).split())}\\)", text)
    parts = re.split(r"(\\\(.*?\\\))", text, flags=re.S)
    return "".join(_LITERAL.sub(r"\1", p) if i % 2 else _roles(p) for i, p in enumerate(parts))


def _roles(text: str) -> str:
    text = re.sub(
        r":(?:class|func|meth|mod|attr|data|exc|obj|const):`(~?)([^`]+)`",
        lambda m: f"`{_short(m.group(2), bool(m.group(1)))}`",
        text,
    )
    return _LITERAL.sub(lambda m: f"`{m.group(1)}`", text)


class RstRoles(griffe.Extension):
    """Rewrite every docstring once it is loaded."""

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = render(obj.docstring.value, module=obj.is_module)
