"""Registry of the project's embedded examples (generated, never committed as blobs).

Each :class:`Example` names a deterministic generator from :mod:`mocomp.synth`
returning a result with ``.motion`` and its ground truth. ``mocomp.datasets.load``
looks names up here first.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

__all__ = ["Example", "EXAMPLES", "register"]


@dataclass(frozen=True)
class Example:
    """A named example: ``make()`` returns an object with a ``.motion`` attribute
    (a :class:`~mocomp.core.Motion`) plus ground truth fields."""

    name: str
    description: str
    make: Callable[[], Any]


#: name -> Example; filled by :mod:`mocomp.synth` registrations.
EXAMPLES: dict[str, Example] = {}


def register(example: Example) -> Example:
    if example.name in EXAMPLES:
        raise ValueError(f"example {example.name!r} registered twice")
    EXAMPLES[example.name] = example
    return example


def _register_builtin_examples() -> None:
    """Register the embedded synthetic examples of :mod:`mocomp.synth` (generation stays lazy)."""
    import importlib

    importlib.import_module("mocomp.synth.registry")


_register_builtin_examples()
