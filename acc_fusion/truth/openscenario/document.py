"""The XML side of scenario files: ``lxml`` imported on first use (with one ConfigError naming
the install command when it is missing), a file parsed with one InputError when it is missing
or malformed, and the one-sentence refusals and number checks that name the file, the line and
the element."""

from __future__ import annotations

from pathlib import Path

from acc_fusion.core.errors import ConfigError, InputError

#: The command that installs the scenario-file support.
INSTALL = "pip install 'acc_fusion[interop]'"


def etree():
    """``lxml.etree``, or one ConfigError naming the install command."""
    try:
        from lxml import etree
    except ImportError:
        raise ConfigError(f"reading scenario files needs lxml: {INSTALL}") from None
    return etree


def parse_xml(path: Path, what: str):
    """The root element of the XML file ``path``; one InputError if it is missing or not
    well-formed (``what`` names the kind of file)."""
    xml = etree()
    if not path.is_file():
        raise InputError(f"the {what} file {str(path)!r} does not exist")
    try:
        return xml.parse(str(path)).getroot()
    except xml.XMLSyntaxError as exc:
        raise InputError(f"{path.name} is not well-formed XML: {exc}") from None


def refusal(name: str, el, what: str) -> InputError:
    """The one-sentence error of file ``name`` for element ``el``: its line and tag, then
    ``what``."""
    return InputError(f"{name} line {el.sourceline}: <{el.tag}> {what}")


def number(el, attr: str, name: str, default: float | None = None) -> float:
    """Attribute ``attr`` of element ``el`` as a number (``default`` if absent); one
    InputError naming the file ``name``, the line and the attribute otherwise."""
    text = el.get(attr)
    if text is None and default is not None:
        return default
    try:
        return float(text)
    except (TypeError, ValueError):
        raise InputError(f"{name} line {el.sourceline}: <{el.tag}> {attr}={text!r} is not a "
                         "number") from None  # fmt: skip
