"""Exception types of the project.

Every error a researcher can trigger with bad input is one of these, with a
message that says where (file, line, field) and what is wrong.
"""
from __future__ import annotations

from pathlib import Path


class MocompError(Exception):
    """Base class of every error raised on purpose by :mod:`mocomp`."""


class MotionFormatError(MocompError, ValueError):
    """A motion/skeleton/marker file (or an in-memory array) is malformed.

    Parameters
    ----------
    message:
        What is wrong, in words a researcher can act on.
    path:
        The file, if any.
    line:
        1-based line number in that file, if known.
    """

    def __init__(self, message: str, path: str | Path | None = None, line: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = message
        where = ""
        if self.path is not None:
            where = self.path + (f":{line}" if line is not None else "") + ": "
        elif line is not None:
            where = f"line {line}: "
        super().__init__(where + message)


class DataNotFoundError(MocompError, FileNotFoundError):
    """A named clip or data directory could not be found."""


class NoFlightPhaseError(MocompError):
    """A motion has no ballistic (flight) phase where the method needs one."""


class PhysicsError(MocompError, ValueError):
    """A requested edit is physically impossible (e.g. negative radicand in k*)."""


class StudyDataError(MocompError, ValueError):
    """Perception-study data (manifest, plan, session or response CSV) is malformed.

    The message names the file, the 1-based line (where known) and the column.
    """

    def __init__(self, message: str, path: str | Path | None = None, line: int | None = None,
                 column: str | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        self.reason = message
        where = ""
        if self.path is not None:
            where = self.path + (f":{line}" if line is not None else "")
            where += (f" [{column}]" if column else "") + ": "
        elif column:
            where = f"[{column}]: "
        super().__init__(where + message)


class SessionLockedError(MocompError):
    """A study session is already open (another window/process holds its lock)."""


class AlignmentError(MocompError, ValueError):
    """A time-alignment (DTW) problem is ill-posed: a band that admits no
    monotone path, matching points out of order or outside the matrix,
    sequences too short for the band or the derivative windows, non-finite costs."""


class ChecksumError(MocompError):
    """A downloaded or cached data file does not match its known size or SHA-256."""


class JoinError(PhysicsError):
    """Two flights cannot be joined: angular-momentum directions that cannot be aligned,
    different skeletons, magnitudes too far apart to match by retiming, no transition."""


class TwistRangeError(PhysicsError):
    """A twist-jump target rotation lies outside the range reachable from the clip."""


class ImplausibleFlightError(NoFlightPhaseError):
    """A detected flight phase is not plausible free flight: shorter than the minimum duration,
    or its centre-of-mass parabola implies a gravity far from 9.81 m/s^2 (a walk's double-support
    gap, a roll, a wrong frame rate). ``check`` holds the measurements
    (:class:`mocomp.flips.plausibility.FlightCheck`), ``source`` which input it concerns (when a
    command takes several)."""

    def __init__(self, message: str, check=None, source: str | None = None):
        self.check = check
        self.source = source
        super().__init__(message)
