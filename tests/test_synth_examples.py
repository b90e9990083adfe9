"""The embedded examples: registered by importing mocomp.datasets, deterministic, cached."""
from __future__ import annotations

import subprocess
import sys

import numpy as np

from mocomp import datasets
from mocomp.core import Motion
from mocomp.synth import EXAMPLE_NAMES, SynthResult, make_example

NAMES = {"backflip", "frontflip", "sideflip", "twist180", "twist360", "jump"}


def test_importing_datasets_registers_the_examples():
    code = ("import sys, mocomp.datasets; from mocomp.datasets.examples import EXAMPLES; "
            "print(sorted(EXAMPLES))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert eval(out[0]) == sorted(NAMES)
    assert set(EXAMPLE_NAMES) == NAMES


def test_examples_load_as_motions_and_are_cached():
    for name in EXAMPLE_NAMES:
        r = make_example(name)
        assert isinstance(r, SynthResult) and isinstance(r.motion, Motion)
        assert r.motion.fps == 120.0 and r.motion.skeleton.n_joints == 31
        assert r.motion.source.format == "synthetic"
        assert make_example(name) is r                      # lru_cache
        ex = datasets.EXAMPLES[name]
        assert ex.description and ex.make() is r
    m = datasets.load("backflip")
    assert isinstance(m, Motion) and np.array_equal(m.rotations, make_example("backflip").motion.rotations)


def test_examples_are_deterministic_across_processes():
    import hashlib

    code = ("from mocomp.synth import make_example; import hashlib; r = make_example('twist180'); "
            "print(hashlib.sha256(r.motion.rotations.tobytes() + r.motion.root_positions.tobytes()).hexdigest())")
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    r = make_example("twist180")
    assert other == hashlib.sha256(r.motion.rotations.tobytes() + r.motion.root_positions.tobytes()).hexdigest()
