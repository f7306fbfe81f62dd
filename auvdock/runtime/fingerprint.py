"""What defines a built thing, as a short digest; and a small per-thread memo of built things.

Building a controller's or a filter's CasADi functions (the model's expressions, their derivatives, the
compiled library's cache key) takes about a second a run; in a sweep or a comparison the same functions
are built again for every run.  :class:`Memo` keeps them, keyed by :func:`digest` of everything that
defines them (numbers, arrays, settings), so that a run whose functions were built before in the same
process takes them as they are.  Only immutable things go in (CasADi ``Function`` objects, QP solvers
with no state of their own between calls); whatever holds a run's state (warm starts, buffers, the
filter's estimate) is made per run around them.

Entries are per thread (a CasADi function's evaluation memory is not shared across threads here), and
the memo is bounded (least recently used out).
"""

from __future__ import annotations

import dataclasses
import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

__all__ = ["digest", "Memo"]

T = TypeVar("T")


def _feed(h: Any, x: Any) -> None:
    """Feed ``x`` into the hash ``h``, tagged by its kind (so that 1, 1.0, "1" and [1] differ)."""
    if x is None or isinstance(x, bool | int | float | str | bytes):
        h.update(f"{type(x).__name__}:{x!r};".encode())
    elif isinstance(x, np.ndarray | np.generic):
        a = np.ascontiguousarray(x)
        h.update(f"nd:{a.dtype.str}:{a.shape};".encode())
        h.update(a.tobytes())
    elif isinstance(x, list | tuple):
        h.update(f"seq:{len(x)}[".encode())
        for v in x:
            _feed(h, v)
        h.update(b"]")
    elif isinstance(x, dict):
        h.update(f"map:{len(x)}{{".encode())
        for k in sorted(x, key=repr):
            _feed(h, k)
            _feed(h, x[k])
        h.update(b"}")
    elif dataclasses.is_dataclass(x) and not isinstance(x, type):
        h.update(f"dc:{type(x).__module__}.{type(x).__qualname__}(".encode())
        for f in dataclasses.fields(x):
            _feed(h, f.name)
            _feed(h, getattr(x, f.name))
        h.update(b")")
    elif hasattr(x, "model_dump_json") and hasattr(type(x), "model_fields"):  # pydantic settings
        h.update(f"pd:{type(x).__module__}.{type(x).__qualname__}:".encode())
        h.update(x.model_dump_json().encode())
    else:
        raise TypeError(
            f"cannot fingerprint an object of type {type(x).__name__} (give what defines it instead)"
        )


def digest(*parts: Any) -> str:
    """A digest (24 hex digits) of ``parts``: numbers, strings, arrays, sequences, dicts, dataclasses and
    pydantic settings, by value.  Raises TypeError for anything else (a function, an object with state):
    what defines it must be given instead."""
    h = hashlib.sha256()
    _feed(h, parts)
    return h.hexdigest()[:24]


class Memo:
    """Built things by name and :func:`digest` of what defines them, per thread, at most ``size`` kept."""

    def __init__(self, size: int = 32) -> None:
        self.size = int(size)
        self._items: OrderedDict[tuple[int, str, str], Any] = OrderedDict()
        self._lock = threading.Lock()
        #: How many lookups found their thing built (hits) and how many built it (misses).
        self.hits = 0
        self.misses = 0

    def get(self, name: str, parts: Any, build: Callable[[], T], keep: Callable[[], bool] | None = None) -> T:
        """The thing ``name`` defined by ``parts``: the one built before in this thread, else ``build()``,
        kept unless ``keep()`` says not (asked after the build)."""
        key = (threading.get_ident(), name, digest(parts))
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                self.hits += 1
                return self._items[key]
        value = build()
        with self._lock:
            self.misses += 1
            if keep is not None and not keep():
                return value
            self._items[key] = value
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return value

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
