"""YAML that refuses what ``yaml.safe_load`` lets through silently: a key given twice.

``safe_load`` keeps the last of two equal keys (``seed: 4`` then ``seed: 5`` is ``seed: 5``
without a word); a metadata or batch file with a repeated key is more likely a mistake than
an intent, so it is an error here, naming the key and both lines.
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


def safe_load_unique(stream: Any) -> Any:
    """``yaml.safe_load`` that raises ``yaml.YAMLError`` on a key repeated in a mapping.

    Parameters
    ----------
    stream : str, bytes or file
        YAML text.

    Returns
    -------
    Any
        The document, as ``yaml.safe_load`` gives it.

    Raises
    ------
    yaml.YAMLError
        On invalid YAML, or a mapping that repeats a key (naming the key and its lines).
    """
    return yaml.load(stream, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
