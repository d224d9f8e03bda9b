"""MkDocs hooks: the command-line and API reference pages are generated from the code.

- ``<!-- colloc-cli -->`` becomes the help of ``colloc`` and of every subcommand, from the
  argument parser itself, so the page cannot drift from the command.
- ``<!-- colloc-api: PACKAGE -->`` becomes the package's docstring and one mkdocstrings entry
  per public name (``PACKAGE.__all__``), each pointed at the module that defines it.
- Sphinx roles in docstrings (``:func:`lqr```) are shown as plain code.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import re
import sys
import types
from typing import Any

API = re.compile(r"<!-- colloc-api: ([\w.]+) -->")
# Sphinx roles in the docstrings (":func:`name`") render as plain code on this site.
ROLE = re.compile(r":(?:func|class|data|meth|attr|mod|obj|exc|ref):(?=<code>)")
CLI = "<!-- colloc-cli -->"


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Fill the generated sections of a page."""
    if CLI in markdown:
        markdown = markdown.replace(CLI, cli_reference())
    return API.sub(lambda match: api_reference(match.group(1)), markdown)


def on_page_content(html: str, page: Any, config: Any, files: Any) -> str:
    """Drop the Sphinx role names left in front of code spans."""
    return ROLE.sub("", html)


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, argparse.ArgumentParser]]:
    found = []
    for action in parser._actions:  # argparse has no public walk of its subparsers
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.append((name, sub))
    return found


def cli_reference() -> str:
    """The help of ``colloc`` and of every subcommand, nested."""
    from colloc.cli import build_parser

    parser = build_parser()
    parser.prog = "colloc"
    parts = ["```text", parser.format_help().rstrip(), "```", ""]

    def walk(prefix: str, node: argparse.ArgumentParser, level: int) -> None:
        for name, sub in _subcommands(node):
            title = f"{prefix} {name}"
            parts.extend(
                [f"{'#' * level} `{title}`", "", "```text", sub.format_help().rstrip(), "```", ""]
            )
            walk(title, sub, min(level + 1, 4))

    walk("colloc", parser, 2)
    return "\n".join(parts)


def _defining_module(package: types.ModuleType, name: str, obj: object) -> str:
    """The module that defines a public name (lazy tables first, then where it lives)."""
    lazy = getattr(package, "_EXPORTS", {})
    if name in lazy:
        return lazy[name]
    owner = getattr(obj, "__module__", None)
    if (
        isinstance(owner, str)
        and owner.startswith("colloc")
        and name in vars(sys.modules.get(owner, package))
    ):
        return owner
    for module_name, module in sorted(sys.modules.items()):
        if (
            module_name.startswith(package.__name__ + ".")
            and isinstance(module, types.ModuleType)
            and vars(module).get(name) is obj
        ):
            return module_name
    return package.__name__


#: The subpackages with a reference page of their own.
PAGES = (
    "colloc.batch",
    "colloc.control",
    "colloc.data",
    "colloc.gait",
    "colloc.identify",
    "colloc.model",
    "colloc.nlp",
    "colloc.numeric",
    "colloc.plot",
    "colloc.simulate",
    "colloc.solve",
    "colloc.store",
    "colloc.transcription",
)


def _documented_elsewhere(package_name: str, name: str, obj: object) -> str | None:
    """The subpackage page that documents ``obj`` when this (higher) package re-exports it."""
    for other in PAGES:
        if other.startswith(package_name + ".") and name in importlib.import_module(other).__all__:
            if getattr(importlib.import_module(other), name) is obj:
                return other
    return None


def api_reference(package_name: str) -> str:
    """The package's docstring, then one entry per public name."""
    package = importlib.import_module(package_name)
    names = [n for n in package.__all__ if not n.startswith("__")]
    parts = [
        f"::: {package_name}",
        "    options:",
        "      members: false",
        "      show_root_heading: false",
        "",
    ]
    for name in names:
        obj = getattr(package, name)
        if inspect.ismodule(obj):
            parts.append(f"- `{name}`: the subpackage `{obj.__name__}` (its own page).\n")
            continue
        home = _documented_elsewhere(package_name, name, obj)
        if home is not None:  # one entry per object: the subpackage's page has it
            parts.append(f"- `{package_name}.{name}`: documented under `{home}`.\n")
            continue
        parts.append(f"::: {_defining_module(package, name, obj)}.{name}")
        parts.append("")
    return "\n".join(parts)
