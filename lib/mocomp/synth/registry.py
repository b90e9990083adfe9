"""The project's embedded examples: named, deterministic synthetic motions.

Registered in :data:`mocomp.datasets.examples.EXAMPLES` when :mod:`mocomp.synth`
(or :mod:`mocomp.datasets`) is imported; each is generated on first use and
cached for the process (``functools.lru_cache``; results are immutable). Nothing
is stored on disk. All use the default performer: 1.75 m, 70 kg, de Leva (1996)
male table, constant-density ellipsoids, 120 fps, seed 0, no variation.
"""
from __future__ import annotations

from functools import lru_cache

from ..datasets.examples import EXAMPLES, Example, register
from .flights import backflip, frontflip, sideflip, straight_jump, twist_jump
from .result import SynthResult

__all__ = ["EXAMPLE_NAMES", "make_example"]


@lru_cache(maxsize=None)
def _backflip() -> SynthResult:
    return backflip()


@lru_cache(maxsize=None)
def _frontflip() -> SynthResult:
    return frontflip()


@lru_cache(maxsize=None)
def _sideflip() -> SynthResult:
    return sideflip()


@lru_cache(maxsize=None)
def _twist180() -> SynthResult:
    return twist_jump(twist=180.0)


@lru_cache(maxsize=None)
def _twist360() -> SynthResult:
    return twist_jump(twist=360.0)


@lru_cache(maxsize=None)
def _jump() -> SynthResult:
    return straight_jump()


_TRUTH = "ground truth: true masses, L0, flight frames, contacts, COM parabola (g = 9.81)"

_SPECS = {
    "backflip": ("Standing tucked back somersault, 1 turn, COM rise 0.5 m, 0.4 m backwards; " + _TRUTH, _backflip),
    "frontflip": ("Standing tucked front somersault, 1 turn, COM rise 0.5 m, 0.6 m forwards; " + _TRUTH, _frontflip),
    "sideflip": ("Tucked side somersault to the left, 1 turn, COM rise 0.5 m, 0.5 m sideways; " + _TRUTH, _sideflip),
    "twist180": ("Straight jump with a 180 deg twist about the vertical, COM rise 0.45 m; " + _TRUTH, _twist180),
    "twist360": ("Straight jump with a 360 deg twist about the vertical, COM rise 0.45 m; " + _TRUTH, _twist360),
    "jump": ("Countermovement jump straight up with an arm swing, COM rise 0.4 m; " + _TRUTH, _jump),
}

#: names of the embedded examples, in a stable order
EXAMPLE_NAMES: tuple[str, ...] = tuple(_SPECS)


def make_example(name: str) -> SynthResult:
    """The cached result of embedded example ``name``."""
    try:
        return _SPECS[name][1]()
    except KeyError:
        raise KeyError(f"no synthetic example {name!r}; examples: {EXAMPLE_NAMES}") from None


for _name, (_desc, _make) in _SPECS.items():
    if _name not in EXAMPLES:
        register(Example(_name, _desc, _make))
