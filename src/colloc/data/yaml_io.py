"""YAML that refuses what ``yaml.safe_load`` lets through: a key given twice, a bomb.

``safe_load`` keeps the last of two equal keys (``seed: 4`` then ``seed: 5`` is ``seed: 5``
without a word); a metadata or batch file with a repeated key is more likely a mistake than
an intent, so it is an error here, naming the key and both lines.

Aliases make a small text stand for a huge document (nine levels of ten aliases each are a
billion values: "billion laughs"): ``safe_load`` builds it quickly, sharing objects, but
anything that walks it (a sweep, an error message) never ends. The document's size with
every alias expanded, and its depth, are counted on the shared objects (each once) and
bounded before anyone walks it; a document nested deeper than the parser can recurse is an
error too, not a ``RecursionError``.
"""

from __future__ import annotations

from typing import Any

import yaml


class _UniqueKeyLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` whose mappings refuse a repeated key."""


def _construct_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode, deep: bool = False) -> Any:
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)  # type: ignore[no-untyped-call]
        line = key_node.start_mark.line + 1
        try:
            first = seen.get(key)
            seen.setdefault(key, line)
        except TypeError:  # an unhashable key: the base constructor names it
            continue
        if first is not None:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"found the key {key!r} twice (lines {first} and {line})",
                key_node.start_mark,
            )
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


#: Most values a document may hold with its aliases expanded.
MAX_NODES = 2_000_000

#: Deepest nesting of lists and mappings a document may have.
MAX_DEPTH = 64


def safe_load_unique(stream: Any, max_nodes: int = MAX_NODES, max_depth: int = MAX_DEPTH) -> Any:
    """``yaml.safe_load`` that refuses a repeated key, an alias bomb and deep nesting.

    Parameters
    ----------
    stream : str, bytes or file
        YAML text.
    max_nodes : int, optional
        Most values the document may hold, counted with every alias expanded.
    max_depth : int, optional
        Deepest nesting of lists and mappings.

    Returns
    -------
    Any
        The document, as ``yaml.safe_load`` gives it.

    Raises
    ------
    yaml.YAMLError
        On invalid YAML, a mapping that repeats a key (naming the key and its lines), a
        document over ``max_nodes`` values or ``max_depth`` levels.
    """
    try:
        document = yaml.load(stream, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader
    except RecursionError:
        raise yaml.YAMLError(
            f"nested too deeply to read (at most {max_depth} levels of lists and mappings)"
        ) from None
    try:
        nodes, depth = document_size(document)
    except ValueError as error:
        raise yaml.YAMLError(str(error)) from None
    if depth > max_depth:
        raise yaml.YAMLError(
            f"nested {depth} levels deep; at most {max_depth} levels of lists and mappings"
        )
    if nodes > max_nodes:
        raise yaml.YAMLError(
            f"stands for {nodes:.3g} values once its aliases are expanded; at most "
            f"{max_nodes} (an alias bomb?)"
        )
    return document


def document_size(document: Any) -> tuple[int, int]:
    """Values and depth of a loaded document, with shared (aliased) parts counted at every use.

    Each distinct list or mapping is visited once and its size remembered, so a document of
    a billion values by aliases is measured in a few steps.

    Parameters
    ----------
    document : Any

    Returns
    -------
    values : int
    depth : int
        Levels of lists and mappings (0 for a scalar).

    Raises
    ------
    ValueError
        When the document contains itself (a recursive alias: it has no finite size).
    """
    sizes: dict[int, tuple[int, int]] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[Any, bool]] = [(document, False)]
    while stack:
        node, ready = stack.pop()
        if not isinstance(node, list | dict) or id(node) in sizes:
            continue
        children = [*node.keys(), *node.values()] if isinstance(node, dict) else node
        if not ready:
            if id(node) in open_nodes:
                raise ValueError("the document contains itself (a recursive alias)")
            open_nodes.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in children if isinstance(c, list | dict))
            continue
        count, deepest = 1, 0
        for child in children:
            n, d = sizes.get(id(child), (1, 0))
            count += n
            deepest = max(deepest, d)
        sizes[id(node)] = (count, deepest + 1)
        open_nodes.discard(id(node))
    return sizes.get(id(document), (1, 0))
