"""The commands ``mocomp batch`` maps over clips, and what it keeps of each one's run.

A batch does not re-implement a command: the worker runs the command's own entry point
(:func:`mocomp.cli.main` with the argument list a user would type for one clip), with every file
the command writes redirected into the clip's output folder, and captures its printed summary.
A :class:`CommandSpec` says which arguments carry those per-clip paths, which of the command's
own options name further output files (their value becomes a file name inside the clip's folder),
and which key numbers of the command's report go into the results table.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

__all__ = ["CommandSpec", "COMMANDS", "command_argv"]


def _num(v):
    """A float for the table (``None``/non-numbers -> NaN)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def _checks_text(findings, severity: str = "violation") -> str:
    """``check:count;check:count`` of the findings of one severity (the study manifest's format)."""
    counts: dict[str, int] = {}
    for f in findings or ():
        if f.get("severity") == severity:
            counts[f["check"]] = counts.get(f["check"], 0) + 1
    return ";".join(f"{k}:{v}" for k, v in sorted(counts.items()))


def _audit_numbers(d: dict, prefix: str = "") -> dict:
    """Key numbers of an :class:`~mocomp.audit.AuditReport` as a dict (``AuditReport.to_dict``)."""
    m = d.get("measures") or {}
    return {
        f"{prefix}verdict": d.get("verdict"),
        f"{prefix}violations": _num(d.get("violations")),
        f"{prefix}advisories": _num(d.get("advisories")),
        f"{prefix}violation_checks": _checks_text(d.get("findings")),
        f"{prefix}n_frames": _num(d.get("n_frames")),
        f"{prefix}fps": _num(d.get("fps")),
        f"{prefix}n_flights": _num(len(d.get("flights") or ())),
        f"{prefix}max_penetration_m": _num(m.get("max_penetration_m")),
        f"{prefix}max_foot_slide_m": _num(m.get("max_foot_slide_m")),
        f"{prefix}max_com_jump_mps": _num(m.get("max_com_jump_mps")),
        f"{prefix}takeoff_jump_mps": _num(m.get("takeoff_jump_mps")),
        f"{prefix}landing_jump_mps": _num(m.get("landing_jump_mps")),
        f"{prefix}zmp_max_outside_m": _num(m.get("zmp_max_outside_m")),
    }


def _audit_columns(report: dict | None, stdout: str) -> dict:
    return _audit_numbers(report or {})


def _info_columns(report: dict | None, stdout: str) -> dict:
    d = report or {}
    return {"n_frames": _num(d.get("n_frames")), "fps": _num(d.get("fps")), "duration_s": _num(d.get("duration")),
            "n_joints": _num(d.get("n_joints")), "unit_scale": _num(d.get("unit_scale")),
            "standing_height_m": _num(d.get("standing_height")),
            "root_path_length_m": _num(d.get("root_path_length")),
            "peak_joint_speed_mps": _num(d.get("peak_joint_speed"))}


def _output_audit_columns(report: dict | None, stdout: str) -> dict:
    """The audit of the written motion against the input (``report['audit']``, mocomp.cli._common)."""
    a = (report or {}).get("audit") or {}
    out = {"out_" + k: v for k, v in _audit_numbers(a).items()}
    against = (a.get("comparison") or {})
    out["in_verdict"] = against.get("against_verdict")
    out["new_violations"] = _num(len(a["new_violations"])) if "new_violations" in a else float("nan")
    out["new_violation_checks"] = _checks_text(
        [dict(f, severity="violation") for f in a.get("new_violations") or ()])
    out["worse_measures"] = ";".join(k for k in against.get("worse") or () if k != "violations")
    return out


_RENDER_AUDIT = re.compile(r"^audit of (?P<name>.*?): (?P<verdict>[A-Z]+), (?P<n>\d+) violation", re.M)
_RENDER_WROTE = re.compile(r"^wrote \S+ \((?P<kind>[a-z0-9]+), (?P<w>\d+)x(?P<h>\d+), (?:(?P<frames>\d+) frames)?", re.M)


def _render_columns(report: dict | None, stdout: str) -> dict:
    """``mocomp render`` has no JSON report: its printed lines (the audit of the drawn motion)."""
    a = _RENDER_AUDIT.search(stdout)
    w = _RENDER_WROTE.search(stdout)
    return {"verdict": a["verdict"].lower() if a else None, "violations": _num(a["n"]) if a else float("nan"),
            "kind": w["kind"] if w else None, "width": _num(w["w"]) if w else float("nan"),
            "height": _num(w["h"]) if w else float("nan"),
            "video_frames": _num(w["frames"]) if w and w["frames"] else float("nan")}


@dataclass(frozen=True)
class CommandSpec:
    """How ``mocomp batch`` runs one command on one clip.

    name: the ``mocomp`` command.
    output: file name of the motion/image the command writes with ``output_option`` (``None``:
        the command writes no main output); its extension is the default of ``output_types``.
    output_option: the option that takes the output path (``-o``).
    report_option: the option that writes the JSON report (``None``: ``report_from_stdout`` or none).
    report_from_stdout: extra arguments that make the command print its report as JSON on stdout
        (``mocomp info --json``), saved as ``report.json``.
    file_options: the command's options whose value is an output file: in a batch their value is a
        file name, written inside each clip's folder.
    reserved: options the batch sets itself (a user may not pass them).
    columns: the key numbers of the report kept in the results table: ``columns(report, stdout)``.
    output_types: extensions the main output may have (``--output-type``).
    """

    name: str
    columns: Callable[[dict | None, str], dict]
    output: str | None = None
    output_option: str = "-o"
    report_option: str | None = "--report"
    report_from_stdout: tuple[str, ...] = ()
    file_options: tuple[str, ...] = ()
    reserved: tuple[str, ...] = ()
    output_types: tuple[str, ...] = ()
    help: str = ""
    column_names: tuple[str, ...] = field(default=(), repr=False)

    def __post_init__(self):
        if not self.column_names:
            object.__setattr__(self, "column_names", tuple(self.columns(None, "")))


_OUT_RESERVED = ("-o", "--output", "--out", "--report")

COMMANDS: dict[str, CommandSpec] = {s.name: s for s in (
    CommandSpec("audit", _audit_columns, file_options=("--plot",), reserved=("--report", "--against"),
                help="audit report.json; verdict, violations by check, key measures"),
    CommandSpec("info", _info_columns, report_option=None, report_from_stdout=("--json",),
                reserved=("--json",), help="summary as report.json; frames, fps, duration, height"),
    CommandSpec("flips", _output_audit_columns, output="output.bvh", file_options=("--filmstrip", "--render"),
                reserved=_OUT_RESERVED, help="output.bvh + report.json; the audit of the written motion"),
    CommandSpec("edit", _output_audit_columns, output="output.bvh", file_options=("--edited", "--plot", "--render"),
                reserved=_OUT_RESERVED, help="output.bvh + report.json; the audit of the written motion"),
    CommandSpec("touchup", _output_audit_columns, output="output.bvh", file_options=("--plot", "--render"),
                reserved=_OUT_RESERVED, help="output.bvh + report.json; the audit of the written motion"),
    CommandSpec("render", _render_columns, output="render.png", report_option=None, reserved=("-o", "--output",
                "--against"), output_types=("png", "mp4", "gif"),
                help="render.png (filmstrip; --output-type mp4|gif for a video); the drawn audit's verdict"),
)}


def _option_of(token: str, names) -> str | None:
    """The option of ``names`` that ``token`` (``--plot`` or ``--plot=x``) gives, else ``None``."""
    head = token.split("=", 1)[0]
    return head if head in names else None


def command_argv(spec: CommandSpec, clip_path: Path, out_dir: Path, options: list[str],
                 output_type: str | None = None) -> tuple[list[str], dict[str, str]]:
    """The argument list (after the command name) that runs ``spec`` on one clip, writing into
    ``out_dir``, and ``{role: file name}`` of what it writes (``output``, ``report``, each file option).

    ``options`` are the user's command options; the value of each of ``spec.file_options`` is taken
    as a file name inside ``out_dir``. Raises ``ValueError`` for a reserved option or a file option
    whose value is a path rather than a file name.
    """
    out_dir = Path(out_dir)
    argv: list[str] = [str(clip_path)]
    files: dict[str, str] = {}
    if spec.output is not None:
        name = spec.output if output_type is None else f"{Path(spec.output).stem}.{output_type}"
        argv += [spec.output_option, str(out_dir / name)]
        files["output"] = name
    if spec.report_option is not None:
        argv += [spec.report_option, str(out_dir / "report.json")]
        files["report"] = "report.json"
    elif spec.report_from_stdout:
        argv += list(spec.report_from_stdout)
        files["report"] = "report.json"
    i = 0
    while i < len(options):
        tok = options[i]
        bad = _option_of(tok, spec.reserved)
        if bad is not None:
            raise ValueError(f"{bad} is set by mocomp batch for every clip (outputs go to OUT_DIR/clips/<clip>/); "
                             f"leave it out")
        opt = _option_of(tok, spec.file_options)
        if opt is not None:
            if "=" in tok:
                value, step = tok.split("=", 1)[1], 1
            elif i + 1 < len(options):
                value, step = options[i + 1], 2
            else:
                argv.append(tok)  # the command's parser reports the missing value
                break
            if not value or Path(value).name != value or value in (".", ".."):
                raise ValueError(f"{opt} {value!r}: in a batch give a file name (written into each clip's "
                                 f"folder), not a path")
            argv += [opt, str(out_dir / value)]
            files[opt.lstrip("-")] = value
            i += step
            continue
        argv.append(tok)
        i += 1
    return argv, files


def read_report(path: Path) -> dict | None:
    """The JSON report a command wrote, or ``None`` when it is missing or not a JSON object."""
    try:
        d = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return d if isinstance(d, dict) else None
