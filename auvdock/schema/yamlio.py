"""Reading YAML the strict way: every user-written YAML file (missions, sweeps, vehicle parameters,
camera files) is read with :func:`load_yaml_strict`."""

from __future__ import annotations

from typing import Any

import yaml

__all__ = ["load_yaml_strict"]


class _StrictLoader(yaml.SafeLoader):
    """PyYAML's safe loader, but a key given twice in one mapping is an error (YAML 1.2 says so;
    PyYAML silently keeps the last one, so a second ``controller:`` block would replace the first)."""


def _mapping_without_duplicates(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False) -> Any:
    seen: dict[Any, Any] = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        try:
            hash(key)
        except TypeError:
            continue  # left to PyYAML (it refuses unhashable keys itself)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"duplicate key {key!r} (first on line {seen[key].line + 1})",
                key_node.start_mark,
            )
        seen[key] = key_node.start_mark
    return loader.construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping_without_duplicates)


def load_yaml_strict(text: str) -> Any:
    """``yaml.safe_load``, refusing a key given twice in one mapping (``yaml.YAMLError`` naming it)."""
    return yaml.load(text, Loader=_StrictLoader)  # noqa: S506 -- a SafeLoader subclass
