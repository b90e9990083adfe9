"""Is a detected flight plausible free flight? The check a command makes before it edits one.

:func:`~mocomp.flips.phases.detect_flights` accepts any interval whose vertical COM velocity
falls on a line with a gravity scale of 0.35-40 -- wide on purpose, so that clips with a
mislabelled frame rate are still found and diagnosed. A command that *edits* the flight needs
more: on the CMU walk 131_01 the detector returns frames 321-345 (a double-support gap,
0.200 s, fitted gravity 4.50 m/s^2) and ``mocomp edit`` used to turn it into a motion with a
34 m/s knee and a 0.63 m foot slide, with exit status 0. :func:`check_flight` measures:

1. **duration**, take-off frame to last airborne frame, ``(stop - 1 - start) / fps``: at least
   :data:`MIN_FLIGHT_S` (0.25 s, a COM rise of ``g t^2 / 8`` = 7.7 cm);
2. **the flight's own gravity**, fitted to the COM parabola (eq. 5.1's ballistic model with the
   masses in use), with the systematic per-flight uncertainty of
   :data:`~mocomp.flips.mass.FLIGHT_LOG_SCALE_SD` / :data:`~mocomp.flips.mass.ROTATION_LOG_SCALE_SD`
   (fitted on 68 real flights; flips' fast rotation makes it large): its 95 % interval must
   reach into :data:`GRAVITY_BAND`;
3. **the clip's gravity**, all its flights combined (:func:`~mocomp.flips.mass.diagnose_timing`,
   the frame-rate check the pre-processing prints): inside :data:`GRAVITY_BAND`.

The band is 9.81 m/s^2 within a factor 1.4, 7.00-13.73 m/s^2 (a frame rate off by up to 18 %;
50 Hz labelled 60 Hz, or 25 labelled 30, already falls outside). Measured with the prior masses
(as ``mocomp edit`` uses them), after the loaders' known frame-rate corrections (CMU subjects 88
and 90 at 60 Hz; key-framed DeepMimic clips spline-resampled to 120 Hz):

==========================  ==========  ==============  ==========  ==========================
clip                        flight (s)  own g (m/s^2)   clip g      verdict
==========================  ==========  ==============  ==========  ==========================
CMU 88_01 back flip         0.517       12.07 (7.1-21)  10.44       passes
CMU 88_05 cartwheel+flip    0.600       11.73           11.07       passes
CMU 90_08 side flip         0.450       11.00           9.28        passes
DeepMimic back flip         0.425       7.77 (4.8-13)   7.85        passes (lowest clip g)
DeepMimic side flip         0.375       14.83 (9.0-24)  10.89       passes (own g above the
                                                                    band, interval inside)
DeepMimic spin kick, jump   0.37, 0.42  9.49, 9.65      same        passes
CMU 83_58 hop turn, 01_01   0.417       9.55, 9.77      9.55, 9.69  passes
CMU 131_03 hop              0.258       9.10            9.10        passes (shortest accepted)
synthetic examples          0.58-0.66   9.81            9.81        pass
CMU 131_01 walk             0.200       4.50 (3.8-5.4)  4.50        refused (all three)
CMU 131_02 walk             0.133       7.61            7.73        refused (duration)
SFU jogging, DeepMimic run  0.142       9.87, 13.74     --          refused (duration)
MASS back flip at 120 Hz    0.250       60.5            55.5        refused (gravity): its
                                                                    header rate is wrong
==========================  ==========  ==============  ==========  ==========================

With estimated masses (``mocomp flips``) the flips' own fits move by up to 15 % (88_05: 9.92,
DeepMimic side flip 13.02) and stay accepted. The root's parabola is no substitute for the COM:
on the real flips it gives 1.8-19.2 m/s^2.

A flight the user gave explicitly (``flight=(start, stop)``, ``--flight START STOP``) is
measured the same way, but :func:`enforce_flight` only returns the findings as a warning: the
user has looked at the frames (a short hop, a clip whose timing is known to be off).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ImplausibleFlightError
from .mass import FLIGHT_LOG_SCALE_SD, G, FlightFit, TimingDiagnosis

__all__ = ["GRAVITY_BAND", "GRAVITY_FACTOR", "MIN_FLIGHT_S", "FlightCheck", "check_flight", "check_prepared",
           "check_detected", "enforce_flight"]

#: accepted factor between a fitted gravity and standard gravity
GRAVITY_FACTOR = 1.4
#: m/s^2, the accepted gravity of a flight (and of its clip): ``G / 1.4 .. G * 1.4``
GRAVITY_BAND = (G / GRAVITY_FACTOR, G * GRAVITY_FACTOR)
#: s, the shortest flight accepted (take-off frame to last airborne frame)
MIN_FLIGHT_S = 0.25
#: two-sided coverage of the flight's own gravity interval
LEVEL = 0.95


@dataclass(frozen=True)
class FlightCheck:
    """Measurements of one flight against the plausibility rules (module docstring).

    Attributes
    ----------
    flight: ``(start, stop)`` half-open frames; fps: Hz the clip is used at.
    duration: s, ``(stop - 1 - start) / fps``.
    gravity: m/s^2, the flight's own COM-parabola fit; gravity_interval: its 95 % interval.
    clip_gravity: m/s^2, all the clip's flights combined (``nan`` if unknown); n_flights: how many.
    band: m/s^2, the accepted gravity; min_duration: s.
    problems: the rules it breaks, in words (empty: plausible).
    timing_text: the clip's frame-rate diagnosis; suggested_fps: the rate it suggests when the
        gravity is refused (``None`` otherwise).
    """

    flight: tuple[int, int]
    fps: float
    duration: float
    gravity: float
    gravity_interval: tuple[float, float]
    clip_gravity: float
    n_flights: int
    band: tuple[float, float]
    min_duration: float
    problems: tuple[str, ...]
    timing_text: str = ""
    suggested_fps: float | None = None

    @property
    def ok(self) -> bool:
        return not self.problems

    def describe(self, name: str = "the clip", *, explicit: bool = False, override: str = "flight=(start, stop)",
                 fps_hint: str = "fps=F") -> str:
        """The findings in one paragraph: what was measured, why it is refused (or, for an
        ``explicit`` flight, why it is suspicious) and how to override."""
        a, b = self.flight
        what = "the given flight" if explicit else "the detected flight"
        head = (f"{name}: {what}, frames {a}-{b - 1} ({self.duration:.3f} s at {self.fps:g} Hz), is not plausible "
                f"free flight: " + "; ".join(self.problems))
        if explicit:
            return head + " (used anyway, as given)"
        text = (head + ". Refused: editing it would write a physically meaningless motion (a walk's "
                "double-support gaps give such 'flights')")
        if self.suggested_fps is not None:
            text += (f". The clip's gravity points at a wrong frame rate: reload it at {self.suggested_fps:g} Hz "
                     f"({fps_hint.replace('F', f'{self.suggested_fps:g}')})")
        return text + (f". If the clip has a real flight, give its frames explicitly ({override}); they are then "
                       "measured the same way, with a warning instead of this refusal")


def _band_text(band) -> str:
    return f"{band[0]:.2f}-{band[1]:.2f} m/s^2 (9.81 m/s^2 within a factor {np.sqrt(band[1] / band[0]):.2g})"


def check_flight(fit: FlightFit, fps: float, timing: TimingDiagnosis | None = None, *,
                 band: tuple[float, float] = GRAVITY_BAND, min_duration: float = MIN_FLIGHT_S) -> FlightCheck:
    """Measure the flight of ``fit`` (its COM-parabola fit at ``fps``) against the rules of the
    module docstring; ``timing`` is the clip's frame-rate diagnosis over all its flights (rule 3
    and the per-flight uncertainty; without it the uncertainty floor
    :data:`~mocomp.flips.mass.FLIGHT_LOG_SCALE_SD` is used and rule 3 is skipped)."""
    from scipy.stats import norm

    a, b = int(fit.start), int(fit.stop)
    fps = float(fps)
    lo_b, hi_b = float(band[0]), float(band[1])
    duration = (b - 1 - a) / fps
    g = float(fit.gravity)
    sd = None
    if timing is not None:
        sd = next((float(v) for s0, s1, _, v in timing.per_flight if (s0, s1) == (a, b)), None)
    if sd is None or not np.isfinite(sd):
        rel = fit.scale_se / fit.scale if fit.scale > 0 and np.isfinite(fit.scale_se) else 0.0
        sd = float(np.hypot(FLIGHT_LOG_SCALE_SD, rel))
    z = float(norm.ppf(0.5 + LEVEL / 2))
    g_lo, g_hi = (g * np.exp(-z * sd), g * np.exp(z * sd)) if g > 0 else (g, g)
    problems = []
    if not duration >= min_duration:
        problems.append(f"it lasts {duration:.3f} s, shorter than the {min_duration:g} s minimum")
    if not (g_hi >= lo_b and g_lo <= hi_b):
        problems.append(f"its centre-of-mass parabola gives gravity {g:.2f} m/s^2 ({100 * LEVEL:.0f}% interval "
                        f"{g_lo:.2f}-{g_hi:.2f}), outside the accepted {_band_text(band)}")
        gravity_bad = True
    else:
        gravity_bad = False
    clip_g, n, text, sugg = float("nan"), 1, "", None
    if timing is not None:
        clip_g, n, text, sugg = float(timing.scale) * G, len(timing.per_flight), timing.text, timing.suggested
        if np.isfinite(clip_g) and not lo_b <= clip_g <= hi_b:
            problems.append(f"the clip's {n} flight{'s' if n != 1 else ''} combined give{'s' if n == 1 else ''} "
                            f"gravity {clip_g:.2f} m/s^2, " + ("also outside that band" if gravity_bad else
                                                              f"outside the accepted {_band_text(band)}"))
            gravity_bad = True
        elif not np.isfinite(clip_g):
            problems.append("no flight of the clip has a downward parabola")
            gravity_bad = True
    if not gravity_bad:
        sugg = None        # the frame-rate hint only where the gravity itself is refused
    return FlightCheck(flight=(a, b), fps=fps, duration=float(duration), gravity=g,
                       gravity_interval=(float(g_lo), float(g_hi)), clip_gravity=clip_g, n_flights=n,
                       band=(lo_b, hi_b), min_duration=float(min_duration), problems=tuple(problems),
                       timing_text=text, suggested_fps=None if sugg is None else float(sugg))


def check_prepared(prep, **options) -> FlightCheck:
    """:func:`check_flight` of a :class:`~mocomp.flips.preprocess.PreparedFlip` (its flight, fit
    and clip timing, with the masses it uses)."""
    return check_flight(prep.fit, prep.fps, prep.timing, **options)


def check_detected(motion, body, flight, detection=None, **options) -> FlightCheck:
    """:func:`check_flight` of ``flight`` in ``motion`` with the COM of ``body``; the clip's
    timing is combined over ``detection``'s flights (detected here if ``None``)."""
    from ..dynamics import center_of_mass
    from .mass import fit_ballistic
    from .phases import detect_flights
    from .preprocess import clip_timing

    a, b = int(flight[0]), int(flight[1])
    if detection is None:
        detection = detect_flights(motion, body)
    com = detection.com if detection.com is not None else center_of_mass(body, motion)
    fit = fit_ballistic(np.asarray(com)[a:b], motion.fps, a)
    timing = clip_timing(body, motion, detection.intervals, (a, b))
    return check_flight(fit, motion.fps, timing, **options)


def enforce_flight(check: FlightCheck, name: str = "the clip", *, explicit: bool = False,
                   override: str = "flight=(start, stop)", fps_hint: str = "fps=F",
                   source: str | None = None) -> str | None:
    """Refuse an implausible detected flight (:class:`~mocomp.errors.ImplausibleFlightError`, the
    message from :meth:`FlightCheck.describe`); for an ``explicit`` flight return the findings as
    a warning text instead (``None`` when the flight is plausible)."""
    if check.ok:
        return None
    msg = check.describe(name, explicit=explicit, override=override, fps_hint=fps_hint)
    if explicit:
        return msg
    raise ImplausibleFlightError(msg, check=check, source=source)
