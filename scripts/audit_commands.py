"""Audit every motion-writing command of issue 13 section 2 against its input and write the table
"command, input, measure, input value, output value, worse?" (Markdown, or JSON with ``--json``).

Each command is run through the CLI itself (``mocomp.cli.main``, in this process) with
``--report``; the audit the command ran on the frames it wrote (read back), against the input as
the command used it, is taken from the report's ``audit`` key: these are the numbers the user sees.
The acceptance of issue 13 ("no output is worse than its input on floor penetration, foot slide or
velocity jumps unless the user asked for it") is judged on the measures in :data:`MEASURES`; a
measure is *worse* as :class:`mocomp.audit.AuditComparison` decides it (worse by more than a
quarter of its threshold).

    MOCOMP_DATA_DIR=/path/to/mocap python scripts/audit_commands.py [-o table.md] [--json out.json]
        [--only SUBSTRING] [--section docs/audit_baseline.md]

``--section FILE`` replaces the part of FILE between the ``<!-- audit_commands -->`` markers
(appending it when absent) with the table.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

#: the acceptance measures (issue 13), then the flight measures reported beside them
MEASURES = ("max_penetration_m", "max_foot_slide_m", "max_com_jump_mps", "takeoff_jump_mps", "landing_jump_mps",
            "max_point_speed")
ACCEPTANCE = MEASURES[:5]
#: per-flight measures listed for every flight (``flight{i}_...``)
FLIGHT_MEASURES = ("_g", "_L_magnitude")
MARK_BEGIN, MARK_END = "<!-- audit_commands -->", "<!-- /audit_commands -->"


def cases(data: Path | None):
    """``(label, argv-without-output, asked)``: ``asked`` names what the user asked for that makes a
    worse measure expected (e.g. the paper's 0.7 k* take-off jump), else ``""``."""
    out = []
    ex = ["backflip", "frontflip", "sideflip"]
    real = []
    if data is not None:
        real = [str(data / "flips" / f) for f in ("cmu_88_01_backflip.bvh", "cmu_90_08_sideflip.bvh",
                                                  "deepmimic_backflip.txt", "deepmimic_sideflip.txt")]
    for x in ex + real:
        out.append(("flips --flips 2", [ "flips", x, "--flips", "2"], ""))
    for x in ex + real[:1]:
        out.append(("flips --flips 2 --k-ratio 0.7 --takeoff repair",
                    ["flips", x, "--flips", "2", "--k-ratio", "0.7", "--takeoff", "repair"], ""))
    out.append(("flips --flips 2 --k-ratio 0.7 --takeoff as-is",
                ["flips", "backflip", "--flips", "2", "--k-ratio", "0.7", "--takeoff", "as-is"],
                "the paper's 0.7 k* take-off jump (--k-ratio 0.7 --takeoff as-is)"))
    out.append(("flips --flips 2 --k-ratio 0.7", ["flips", "backflip", "--flips", "2", "--k-ratio", "0.7"], ""))
    for preset in ("straight-legs", "arms-twist", "arms-out"):
        for x in ex + real + (["88_01"] if data is not None else []):
            if x.endswith("cmu_88_01_backflip.bvh"):
                continue
            out.append((f"edit --preset {preset}", ["edit", x, "--preset", preset], ""))
    out.append(("twist --degrees 270", ["twist", "twist180", "--degrees", "270"], ""))
    out.append(("twist --degrees 450", ["twist", "twist360", "--degrees", "450"], ""))
    if data is not None:
        out.append(("twist --degrees 360", ["twist", str(data / "twists" / "cmu_83_58_hopturn270.bvh"),
                                            "--degrees", "360"], ""))
    out.append(("join", ["join", "backflip", "sideflip"], ""))
    out.append(("join --force", ["join", "backflip", "sideflip", "--force"],
                "a join the audit refused, written anyway (--force)"))
    if data is not None:
        out.append(("join", ["join", "88_01", "88_05"], ""))
    return out


def run_case(argv, workdir: Path):
    from mocomp.cli import main

    out = workdir / "out.bvh"
    rep = workdir / "r.json"
    for p in (out, rep):
        if p.exists():
            p.unlink()
    buf_o, buf_e = io.StringIO(), io.StringIO()
    t = time.perf_counter()
    with contextlib.redirect_stdout(buf_o), contextlib.redirect_stderr(buf_e):
        code = main(list(argv) + ["-o", str(out), "--report", str(rep)])
    secs = time.perf_counter() - t
    if code != 0 or not rep.exists():
        err = (buf_e.getvalue().strip().splitlines() or ["?"])[-1].replace(str(out), "OUT.bvh")
        err = err.split(": the output OUT.bvh has")[0].split("; the output OUT.bvh has")[0]
        return None, f"exit {code}: {err.replace('|', '/')}", secs
    d = json.loads(rep.read_text())
    a = d.get("audit")
    if not a or not a.get("comparison"):
        return None, "no audit in the report", secs
    rows = {r["key"]: r for r in a["comparison"]["rows"]}
    return rows, "", secs


def _fmt(key, v):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if key.endswith("_m"):
        return f"{100 * v:.1f} cm"
    if key.endswith("_mps") or key == "max_point_speed":
        return f"{v:.2f} m/s"
    if key.endswith("L_magnitude"):
        return f"{100 * v:.0f} %"
    if key.endswith("_g"):
        return f"{v:.2f} m/s^2"
    return f"{v:.3g}"


def _short(x: str) -> str:
    return Path(x).name if os.sep in x else x


def table(results, before=None) -> str:
    """The Markdown table; ``before``: ``{(command, argv...): rows}`` of an earlier run (``--compare``),
    shown as the output value then."""
    cols = ["command", "input", "measure", "input value", "output value", "worse?"]
    if before is not None:
        cols[4:4] = ["output before"]
    lines = ["| " + " | ".join(cols) + " |", "|" + " --- |" * len(cols)]
    n_bad = 0
    for label, argv, asked, rows, err, secs in results:
        inp = _short(argv[1]) + (f" + {_short(argv[2])}" if argv[0] == "join" else "")
        old_rows = None if before is None else before.get(tuple(argv))
        if rows is None:
            extra = "" if before is None else (" - |" if old_rows is None else " (written) |")
            lines.append(f"| `{label}` | `{inp}` | - | - |{extra} - | not written ({err}) |")
            continue
        flight_keys = [k for k in rows if k.startswith("flight") and k.endswith(FLIGHT_MEASURES)]
        for key in list(MEASURES) + flight_keys:
            r = rows.get(key)
            if r is None:
                continue
            worse = bool(r["worse"])
            acc = key in ACCEPTANCE
            if worse and acc and not asked:
                n_bad += 1
            mark = ("**worse**" + (f" (asked: {asked})" if asked else "") if worse and acc else
                    ("worse (not an acceptance measure)" if worse else "no"))
            was = ""
            if before is not None:
                o = (old_rows or {}).get(key)
                was = f" {_fmt(key, o['this']) if o else ('not written' if old_rows is None else '-')} |"
            lines.append(f"| `{label}` | `{inp}` | {r['label']} | {_fmt(key, r['against'])} |{was} "
                         f"{_fmt(key, r['this'])} | {mark} |")
    return "\n".join(lines), n_bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", help="write the Markdown table here (default: stdout)")
    ap.add_argument("--json", help="also write the raw rows as JSON")
    ap.add_argument("--only", default=None, help="run only cases whose command line contains this")
    ap.add_argument("--section", help="replace the marked section of this Markdown file with the table")
    ap.add_argument("--compare", help="a --json file of an earlier run: its output values in a column")
    a = ap.parse_args(argv)
    env = os.environ.get("MOCOMP_DATA_DIR")
    data = Path(env) if env else None
    results = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for label, args, asked in cases(data):
            if a.only and a.only not in " ".join(args):
                continue
            rows, err, secs = run_case(args, Path(tmp))
            print(f"{' '.join(_short(x) for x in args)}: {'ok' if rows else err} ({secs:.1f} s)", file=sys.stderr)
            results.append((label, args, asked, rows, err, secs))
    before = None
    if a.compare:
        before = {tuple(d["argv"]): d["rows"] for d in json.loads(Path(a.compare).read_text())}
    text, n_bad = table(results, before)
    head = (f"Commands run: {len(results)} ({time.perf_counter() - t0:.0f} s). Acceptance measures worse than the "
            f"input without the user asking for it: {n_bad}.\n\n")
    body = head + text + "\n"
    if a.output:
        Path(a.output).write_text(body)
    if a.json:
        Path(a.json).write_text(json.dumps([{"command": lab, "argv": args, "asked": asked, "rows": rows,
                                              "error": err} for lab, args, asked, rows, err, _ in results],
                                            indent=1) + "\n")
    if a.section:
        p = Path(a.section)
        old = p.read_text() if p.exists() else ""
        block = f"{MARK_BEGIN}\n{body}{MARK_END}"
        if MARK_BEGIN in old and MARK_END in old:
            pre, rest = old.split(MARK_BEGIN, 1)
            post = rest.split(MARK_END, 1)[1]
            p.write_text(pre + block + post)
        else:
            p.write_text(old.rstrip("\n") + "\n\n" + block + "\n")
    if not a.output and not a.section:
        print(body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
