"""Pages of the K37 manual generated from the code when the site is built.

Six MyST directives, each of which renders Markdown made from one source of truth:

* ``k37-registers MAP``: a chip's register map (:mod:`k37.hdl.bus.registers` tables);
* ``k37-pins BLOCK``: the pins of an exported chip (:func:`k37.sim.fpga.export.pins`);
* ``k37-board-pins AXES``: the ULX3S's pin map of the board top (:mod:`k37.hdl.board.pins`);
* ``k37-cli``: every ``k37`` command and option (:func:`k37.sim.cli.build_parser`);
* ``k37-architecture``: the packages and modules, with their docstrings' first sentences;
* ``k37-layers``: the import contracts that ``lint-imports`` checks (``pyproject.toml``).

The functions that make the Markdown are plain Python, so the tests call them too.
"""

from __future__ import annotations

import argparse
import ast
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: The three packages of the product, in the order of the layers (top first).
PACKAGES = ("sim", "firmware_model", "hdl")


def _rst_to_md(text: str) -> str:
    """Docstring RST (roles, double back-quotes) as Markdown inline code."""
    text = re.sub(r":(?:mod|class|func|data|meth|attr|exc):`~?([^`]+)`", r"`\1`", text)
    text = text.replace("``", "`")
    return " ".join(text.split()).replace("|", "\\|")


# --- register maps -------------------------------------------------------------------------

def _maps() -> dict:
    from k37.hdl.board.map import BOARD_MAP
    from k37.hdl.encoder.map import ENCODER_MAP
    from k37.hdl.feed.map.decel_control import DECEL_MAP
    from k37.hdl.feed.map.feed_rate import FEED_MAP
    from k37.hdl.k3701.map import K3701_MAP, K3701_MAP_3
    from k37.hdl.k3702.map import K3702_MAP

    return {"K3701": K3701_MAP, "K3701_3": K3701_MAP_3, "K3702": K3702_MAP,
            "ENCODER": ENCODER_MAP, "FEED": FEED_MAP, "DECEL": DECEL_MAP, "BOARD": BOARD_MAP}


def register_tables(name: str) -> str:
    """The register map ``name`` (a key of :func:`_maps`) as Markdown without headings."""
    regmap = _maps()[name]
    text = regmap.markdown()
    text = re.sub(r"^## (.*)$", r"**\1**", text, flags=re.M)
    return re.sub(r"^### (.*)$", r"**\1**", text, flags=re.M)


# --- pins ----------------------------------------------------------------------------------

def pin_table(block: str) -> str:
    """The pins of exported block ``block`` as a Markdown table."""
    from k37.sim.fpga.export import pins

    rows = ["| pin | label | direction | bits | meaning |", "|---|---|---|---:|---|"]
    for p in pins(block):
        rows.append(f"| `{p.name}` | {p.label or ''} | {p.direction} | {p.width} "
                    f"| {_rst_to_md(p.doc)} |")
    return "\n".join(rows) + "\n"


def board_pin_table(axes: str) -> str:
    """The ULX3S's pin map of the ``axes``-axis board top as a Markdown table."""
    from k37.hdl.board.pins import ulx3s_pins
    from k37.sim.fpga.build import pin_map

    return pin_map(ulx3s_pins(int(axes)))


# --- the command line ----------------------------------------------------------------------

def _option_row(action: argparse.Action) -> str:
    names = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.dest}`"
    if action.metavar and action.option_strings:
        names += f" {action.metavar}"
    elif action.choices and action.option_strings:
        names += " {" + ",".join(str(c) for c in action.choices) + "}"
    default = action.default
    shown = "" if default in (None, False, [], "", argparse.SUPPRESS) else f"`{default}`"
    return f"| {names} | {shown} | {_rst_to_md(action.help or '')} |"


def cli_reference() -> str:
    """Every ``k37`` command with its usage and options, from the argument parser."""
    from k37.sim.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {a.dest: a.help for a in sub._choices_actions}
    out = [f"`{parser.prog}`: {parser.description}", ""]
    for name, p in sub.choices.items():
        out += [f"**`k37 {name}`**: {helps.get(name, '')}", "", "```text",
                p.format_usage().strip(), "```", "",
                "| argument | default | meaning |", "|---|---|---|"]
        out += [_option_row(a) for a in p._actions if not isinstance(a, argparse._HelpAction)]
        out.append("")
    return "\n".join(out)


# --- architecture --------------------------------------------------------------------------

def _first_sentence(path: Path) -> str:
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    paragraph = doc.split("\n\n")[0]
    return _rst_to_md(paragraph)


def source_packages() -> list[Path]:
    """Every package folder of the product, top layer first."""
    found = []
    for top in PACKAGES:
        found += sorted(p.parent for p in (ROOT / top).rglob("__init__.py"))
    return found


def architecture() -> str:
    """One table per package: its docstring, then each module with its first paragraph."""
    out = []
    for pkg in source_packages():
        dotted = ".".join(("k37", *pkg.relative_to(ROOT).parts))
        out += [f"**`{dotted}`**: {_first_sentence(pkg / '__init__.py')}", "",
                "| module | what it holds |", "|---|---|"]
        files = sorted(p for p in pkg.iterdir()
                       if (p.suffix in (".py", ".cc", ".h") and p.name != "__init__.py"))
        for f in files:
            what = _first_sentence(f) if f.suffix == ".py" else _cc_comment(f)
            out.append(f"| `{f.relative_to(ROOT)}` | {what} |")
        out.append("")
    return "\n".join(out)


def _names(modules: list[str]) -> str:
    return ", ".join(f"`{m}`" for m in modules)


def import_contracts() -> str:
    """Every import contract of ``pyproject.toml`` as a Markdown list, in the file's order."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    out = []
    for contract in config["contracts"]:
        kind = contract["type"]
        if kind == "acyclic_siblings":
            rule = (f"no import cycle between the sibling packages or modules of "
                    f"{_names(contract['ancestors'])}, at any depth")
        elif kind == "layers":
            layers = " then ".join(" / ".join(f"`{name.strip()}`" for name in layer.split("|"))
                                   for layer in contract["layers"])
            rule = (f"in {_names(contract['containers'])}, from the top: {layers} (a layer "
                    f"imports only from the layers below it; `a` / `b` import nothing of "
                    f"each other)")
        elif kind == "forbidden":
            sources = contract["source_modules"]
            verb = "import" if len(sources) > 1 else "imports"
            rule = f"{_names(sources)} {verb} nothing of {_names(contract['forbidden_modules'])}"
        else:
            raise ValueError(f"pyproject.toml: import contract of unknown type {kind!r}")
        out.append(f"- **{contract['name']}**: {rule}.")
    return "\n".join(out)


def _cc_comment(path: Path) -> str:
    """The leading comment block of a C++ file, as one paragraph."""
    lines = []
    for line in path.read_text().splitlines():
        s = line.strip()
        if not s.startswith("//"):
            break
        lines.append(s.lstrip("/ "))
    return _rst_to_md(" ".join(lines).split(". ")[0].rstrip(".") + ".") if lines else ""


# --- Sphinx --------------------------------------------------------------------------------

def setup(app):
    from docutils import nodes
    from docutils.statemachine import StringList
    from sphinx.util.docutils import SphinxDirective

    def directive(make, nargs):
        class Generated(SphinxDirective):
            required_arguments = nargs
            has_content = False

            def run(self):
                node = nodes.container()
                text = make(*self.arguments)
                lines = StringList(text.splitlines(), source=self.get_source_info()[0])
                self.state.nested_parse(lines, self.content_offset, node)
                return node.children

        return Generated

    app.add_directive("k37-registers", directive(register_tables, 1))
    app.add_directive("k37-pins", directive(pin_table, 1))
    app.add_directive("k37-board-pins", directive(board_pin_table, 1))
    app.add_directive("k37-cli", directive(cli_reference, 0))
    app.add_directive("k37-architecture", directive(architecture, 0))
    app.add_directive("k37-layers", directive(import_contracts, 0))
    return {"parallel_read_safe": True, "parallel_write_safe": True}
