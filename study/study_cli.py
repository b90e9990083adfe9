"""``mocomp study run`` (serve the participant app with Voila) and ``mocomp study analyze``.

:func:`register_run` and :func:`register_analyze` add the sub-commands to the
``study`` command's sub-parsers (``lib/mocomp/cli/study.py`` lists them).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

__all__ = ["register_run", "register_analyze", "voila_command", "app_notebook", "cull_interval", "KERNEL_CULL_S"]


def app_notebook() -> Path:
    """The packaged participant app notebook (``study/app.ipynb``)."""
    return Path(__file__).with_name("app.ipynb")


#: Default seconds after which the kernel of a closed or reloaded page is shut down (see voila_command).
KERNEL_CULL_S = 30


def cull_interval(cull_idle_s: int) -> int:
    """How often (s) the server looks for kernels to cull: a quarter of the idle timeout, 1-10 s."""
    return int(min(10, max(1, int(cull_idle_s) // 4)))


def voila_command(port: int, notebook: str | Path | None = None, *, python: str | None = None,
                  cull_idle_s: int = KERNEL_CULL_S) -> list[str]:
    """The Voila command line serving the app on 127.0.0.1:``port`` (no browser, no tracebacks shown).

    Each page has its own kernel, which holds the session lock while it lives.
    Voila's page asks the server to shut its kernel down on ``beforeunload``
    (a ``sendBeacon``), but browsers and extensions can drop that request; the
    kernel of a closed or reloaded page would then live on and keep the session
    locked. So the server also culls kernels that have *no page connected* and
    have been idle for ``cull_idle_s`` seconds (jupyter_server's
    ``MappingKernelManager.cull_idle_timeout``, checked every
    :func:`cull_interval` s; ``cull_connected=False``: the kernel of an open
    page is never culled, however long the participant takes). After at most
    ``cull_idle_s + cull_interval`` seconds the lock is free and the new
    page's "Try again" opens the session where it stopped; two windows never
    write at once (the lock is an exclusive ``flock``, held until the old
    kernel's process has exited).
    """
    nb = Path(notebook) if notebook is not None else app_notebook()
    cull = int(cull_idle_s)
    if cull < 1:
        raise ValueError(f"cull_idle_s must be >= 1 s, got {cull_idle_s}")
    return [python or sys.executable, "-m", "voila", "--no-browser", f"--port={int(port)}", "--Voila.ip=127.0.0.1",
            "--show_tracebacks=False", "--theme=light",
            f"--MappingKernelManager.cull_idle_timeout={cull}",
            f"--MappingKernelManager.cull_interval={cull_interval(cull)}",
            "--MappingKernelManager.cull_connected=False", "--MappingKernelManager.cull_busy=False", str(nb)]


def register_run(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "run", help="serve the participant app (Voila on 127.0.0.1) for one participant session",
        description="Serve the perception-study app for one participant and session with Voila on "
                    "127.0.0.1 (open the printed address in a browser). The plan is written to "
                    "DATA/<participant>/<session>/ before the first trial; re-running the same command "
                    "resumes the session where it stopped. Stop with Ctrl-C.")
    p.add_argument("--participant", required=True, help="participant id (letters, digits, _ . -)")
    p.add_argument("--session", required=True, help="session id, e.g. S1")
    p.add_argument("--manifest", required=True, help="stimulus manifest CSV (from `mocomp study render`)")
    p.add_argument("--data", required=True, metavar="DIR", help="folder for session data")
    p.add_argument("--port", type=int, default=8866, help="port on 127.0.0.1 (default 8866)")
    p.add_argument("--design", metavar="JSON", help="trial-design settings (JSON file, fields of study.design.DesignConfig)")
    p.add_argument("--study-seed", type=int, default=0, help="study seed; the participant seed derives from it and the id")
    p.add_argument("--seed", type=int, default=None, help="explicit participant seed (overrides --study-seed)")
    p.add_argument("--counterbalance-index", type=int, default=None,
                   help="participant number for counterbalance='latin'")
    p.add_argument("--break-every", type=int, default=None, help="break screen every N test trials")
    p.add_argument("--practice", type=int, default=None, help="number of practice trials")
    p.add_argument("--attention-checks", type=int, default=None, help="number of attention-check trials")
    p.add_argument("--no-must-watch", action="store_true",
                   help="allow answers before the video has played to its end (default: buttons and keys "
                        "stay disabled until it has, once per presentation)")
    p.add_argument("--texts", metavar="JSON", help="participant-facing texts (JSON file, fields of HarnessTexts)")
    p.add_argument("--lock-timeout", type=float, default=None, metavar="S",
                   help="seconds a new window waits for a session held by another window (default 15)")
    p.add_argument("--kernel-cull-s", type=int, default=KERNEL_CULL_S, metavar="S",
                   help="shut down the kernel of a closed or reloaded page after S idle seconds without a "
                        f"page (frees the session for a new window; default {KERNEL_CULL_S})")
    p.add_argument("--print-config", action="store_true", help="print the app configuration and exit")
    p.set_defaults(func=run_run)
    return p


def _design_dict(args) -> dict | None:
    d = {}
    if args.design:
        d = json.loads(Path(args.design).read_text())
    for key, val in (("break_every", args.break_every), ("n_practice", args.practice),
                     ("n_attention", args.attention_checks), ("must_watch", False if args.no_must_watch else None)):
        if val is not None:
            d[key] = val
    if not d:
        return None
    from .design import DesignConfig

    DesignConfig.from_dict(d)  # validate now, not in the participant's browser
    return d


def _check_run_args(args, design: dict | None) -> None:
    """Refuse, before any server starts, what the app would only find in the participant's browser."""
    if (design or {}).get("counterbalance") == "latin" and args.counterbalance_index is None:
        raise ValueError(f"the design{' ' + repr(args.design) if args.design else ''} uses counterbalance='latin', "
                         "which needs --counterbalance-index N (the participant's number: row N of the "
                         "balanced Latin square of group orders)")
    import importlib.util

    if importlib.util.find_spec("voila") is None:
        from mocomp.errors import MocompError

        raise MocompError(f"`mocomp study run` serves the app with Voila, which is not importable from "
                          f"{sys.executable}: pip install 'mocomp[study]' (voila, ipykernel, jupyterlab-widgets)")


def run_run(args) -> int:
    from .session import check_id
    from .stimulus_set import load_manifest

    check_id(args.participant, "participant id")
    check_id(args.session, "session id")
    manifest = Path(args.manifest).resolve()
    # fail here with a clear message, before starting a server (the app checks again at session start)
    load_manifest(manifest, verify_hashes=True)
    design = _design_dict(args)
    _check_run_args(args, design)
    data = Path(args.data).resolve()
    data.mkdir(parents=True, exist_ok=True)
    cfg = {"manifest": str(manifest), "data_dir": str(data), "participant_id": args.participant,
           "session_id": args.session, "study_seed": args.study_seed, "seed": args.seed,
           "counterbalance_index": args.counterbalance_index}
    if design:
        cfg["design"] = design
    if args.lock_timeout is not None:
        cfg["lock_timeout_s"] = args.lock_timeout
    if args.kernel_cull_s < 1:
        raise ValueError(f"--kernel-cull-s must be >= 1, got {args.kernel_cull_s}")
    cfg["release_after_s"] = args.kernel_cull_s + cull_interval(args.kernel_cull_s)
    if args.texts:
        cfg["texts"] = json.loads(Path(args.texts).read_text())
    if args.print_config:
        print(json.dumps(cfg, indent=2))
        return 0
    env = dict(os.environ)
    env["MOCOMP_STUDY_CONFIG"] = json.dumps(cfg)
    cmd = voila_command(args.port, cull_idle_s=args.kernel_cull_s)
    print(f"participant {args.participant}, session {args.session}: open http://127.0.0.1:{args.port}/ "
          f"(data -> {data / args.participant / args.session}); Ctrl-C stops the server", flush=True)
    proc = subprocess.Popen(cmd, env=env)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        proc.send_signal(signal.SIGINT)
        try:
            return proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            return proc.wait()


def register_analyze(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "analyze", help="analyse every session CSV under a folder (ratings, d', psychometric, mixed model)",
        description="Read every responses.csv below RESPONSES_DIR (schema checked), and write tidy CSVs "
                    "(conditions.csv, trials.csv, participants_*.csv, psychometric.csv, observer_model.csv, "
                    "mixed_model.csv), "
                    "figures and report.md to REPORT_DIR.")
    p.add_argument("responses", metavar="RESPONSES_DIR")
    p.add_argument("-o", "--out", required=True, metavar="REPORT_DIR")
    p.add_argument("--correction", choices=("loglinear", "1/(2N)", "none"), default="loglinear",
                   help="d' correction for rates of 0 or 1 (default loglinear)")
    p.add_argument("--control", choices=("group", "pooled"), default="group",
                   help="false-alarm baseline: unperturbed motions of the same error group, or all of them")
    p.add_argument("--level", choices=("nominal_level", "achieved_error"), default="nominal_level",
                   help="regressor of the psychometric fits")
    p.add_argument("--link", choices=("probit", "logit"), default="probit")
    p.add_argument("--n-boot", type=int, default=2000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--min-attention", type=float, default=None,
                   help="exclude participants whose attention-check pass rate is below this")
    p.add_argument("--allow-mixed-sets", action="store_true", help="accept sessions from different stimulus sets")
    p.add_argument("--observer-ci", choices=("profile", "bootstrap", "wald"), default="profile",
                   help="CIs of the observer-model fit (observer_model.csv; default profile likelihood)")
    p.add_argument("--no-observer-model", action="store_true",
                   help="skip the observer-model fit (threshold, slope, bias, lapse)")
    p.add_argument("--no-figures", action="store_true")
    p.set_defaults(func=run_analyze)
    return p


def run_analyze(args) -> int:
    from .analysis import analyze

    res = analyze(args.responses, args.out, level=args.level, control=args.control, correction=args.correction,
                  link=args.link, n_boot=args.n_boot, seed=args.seed, min_attention=args.min_attention,
                  allow_mixed_sets=args.allow_mixed_sets, figures=not args.no_figures,
                  observer_model=not args.no_observer_model, observer_ci=args.observer_ci)
    s = res.settings
    print(f"{s['n_participants']} participants, {s['n_test_trials']} test trials, "
          f"{len(res.conditions)} condition rows -> {Path(args.out) / 'report.md'}")
    return 0
