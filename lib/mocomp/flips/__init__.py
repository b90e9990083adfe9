"""Multi-flip jumps from a single flip (Majkowska & Faloutsos, "Flipping with physics: motion
editing for acrobatics", SCA 2007; Majkowska, PhD dissertation, UCLA 2007, sections 5.2-5.4
and appendices B-C).

>>> from mocomp import flips
>>> prep = flips.prepare("backflip")            # pre-processing, once per clip (~0.1 s)
>>> res = flips.multiflip(prep, flips=2)        # run time (about half a millisecond); k = k*, g = 9.81
>>> print(res.report)                           # the physics report
>>> res.motion                                  # the new Motion

Pre-processing (:func:`prepare`, :class:`PreparedFlip`): ballistic phase detection
(:mod:`.phases`, section 4.1), mass distribution (:mod:`.mass`, eq. 5.1-5.2), inertias and
momentum (eq. 5.4-5.5), the angular-momentum direction and the self-looping search
(:mod:`.looping`, eq. 5.9). Run time (:func:`multiflip`, :class:`MultiFlipResult`):
sequencing (:mod:`.sequence`, eq. 5.10-5.11), seam smoothing (:mod:`.smoothing`, eq. 5.14) and
non-uniform retiming across the seams (:mod:`.smoothing`, eq. 5.22 as section 5.4.2.2 prescribes),
retiming (:mod:`.retime`, App. B; ``k = k*`` by default, continuous at take-off), repositioning
(:mod:`.reposition`, eq. 5.15-5.17, the new flight falling with g = 9.81 m/s^2 from the input's
measured take-off velocity) and, beyond the paper, the take-off/landing repair that makes ``k < k*``
physical (:mod:`.takeoff`, ``takeoff="repair"``). The frame rate is checked from the fitted
gravity of every flight of the clip (:func:`diagnose_timing`); the fitted gravity is a diagnostic.
"""
from .looping import SelfLoop, find_self_loop
from .mass import (FlightFit, FlightTooShortError, MassEstimate, TimingDiagnosis, diagnose_gravity, diagnose_timing,
                   estimate_masses, fit_ballistic)
from .multiflip import MultiFlipResult, PhysicsReport, landing_change_for_k, multiflip
from .phases import FlightDetection, detect_flights
from .preprocess import PreparedFlip, clip_prior, clip_timing, prepare, prepare_cached, spline_resample
from .retime import RetimePlan, k_star, plan_retime, resolve_gravity
from .takeoff import StanceRepair, StanceRepairError, repair_stance
from .sequence import Sequence, build_sequence, loop_count
from .similarity import SimilarityWeights, frame_distance, similarity_weights

__all__ = [
    "prepare", "prepare_cached", "PreparedFlip", "multiflip", "MultiFlipResult", "PhysicsReport", "demo",
    "landing_change_for_k",
    "detect_flights", "FlightDetection", "estimate_masses", "MassEstimate", "FlightFit", "fit_ballistic",
    "diagnose_gravity", "FlightTooShortError", "find_self_loop", "SelfLoop", "build_sequence", "Sequence",
    "loop_count", "k_star", "plan_retime", "RetimePlan", "resolve_gravity", "StanceRepair", "StanceRepairError",
    "repair_stance", "similarity_weights", "SimilarityWeights",
    "frame_distance", "clip_prior", "spline_resample", "diagnose_timing", "TimingDiagnosis", "clip_timing",
]


def demo(out_dir="mocomp-demo", flips: int = 2, source: str = "backflip", renderer: str = "auto",
         verbose: bool = True, k_ratio: float | None = None, takeoff: str | None = None) -> dict:
    """The project's demo: the embedded synthetic back flip turned into a double flip at the paper's
    take-off speed (``k = 0.7 k*``, section 5.3; Fig. 4a) made physical: the take-off and landing
    stances are reshaped (``takeoff="repair"``, :mod:`mocomp.flips.takeoff`) so the centre of mass
    reaches the faster flight's velocity without a jump; the flight falls at g = 9.81 m/s^2.
    ``k_ratio=1, takeoff="as-is"`` gives :func:`multiflip`'s own defaults (continuous at ``k = k*``
    without reshaping, the whole clip played k* times faster). When neither is given and the stance
    cannot take the repair (a triple flip at 0.7 k* would need about 9.6 body weights of push), the
    demo says so and uses those defaults instead; a ``k_ratio``/``takeoff`` given explicitly is
    never replaced (:class:`~mocomp.flips.takeoff.StanceRepairError` is raised).

    Writes to ``out_dir``: ``<source>_x<flips>.bvh`` (the new motion), ``<source>_original.bvh``,
    ``filmstrip.png`` (original in yellow, multi-flip in turquoise; 3-D when offscreen
    rendering works here, else stick figures), ``momentum.png`` and ``report.json``; prints the
    physics report (its stage times are those of a second, warm call: the first call in a process
    also pays for memory allocation and cache misses). Returns the paths and the
    :class:`MultiFlipResult`.
    """
    from pathlib import Path

    import matplotlib
    import numpy as np

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..io.bvh import write_bvh
    from ..plots.flips import filmstrip, plot_momentum_comparison

    if isinstance(flips, bool) or not isinstance(flips, (int, np.integer)) or flips < 2:
        raise ValueError(f"flips must be an integer >= 2 (total somersaults; the input is one flip), got {flips!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    prep = prepare(source)
    from .takeoff import StanceRepairError

    opts = dict(flips=flips, k_ratio=0.7 if k_ratio is None else k_ratio,
                takeoff="repair" if takeoff is None else takeoff)
    try:
        multiflip(prep, evaluate=False, **opts)        # warm-up: the reported times are a warm call's
    except StanceRepairError as exc:
        if k_ratio is not None or takeoff is not None:
            raise
        if verbose:
            print(f"note: {exc}; the demo uses k = k* with the take-off as is instead")
        opts.update(k_ratio=1.0, takeoff="as-is")
        multiflip(prep, evaluate=False, **opts)
    res = multiflip(prep, **opts)
    paths = {
        "bvh": write_bvh(res.motion, out / f"{source}_x{flips}.bvh"),
        "original_bvh": write_bvh(prep.motion, out / f"{source}_original.bvh"),
    }
    kind, fig = filmstrip(res, path=out / "filmstrip.png", renderer=renderer)
    if kind == "matplotlib":
        plt.close(fig)
    paths["filmstrip"] = out / "filmstrip.png"
    f2 = plot_momentum_comparison(res)
    f2.savefig(out / "momentum.png", dpi=110)
    plt.close(f2)
    paths["momentum"] = out / "momentum.png"
    res.report.to_json(out / "report.json")
    paths["report"] = out / "report.json"
    if verbose:
        print(prep.summary())
        print(res.report)
        print("wrote: " + ", ".join(str(p) for p in paths.values()) + f" (filmstrip: {kind})")
    return {"paths": paths, "result": res, "filmstrip_renderer": kind}
