"""Issue 14's flow measure: count module transitions during mocomp.flips.prepare (flips pre-processing) with sys.setprofile.

Tracks the mocomp module execution is in (Python frames only; C calls ignored). Every time execution
moves from one mocomp module to another (a call into it, or a return back to it), that is a transition;
a transition into a module that had already been visited (entered before and left) is a 'return'.

Usage::

    python scripts/flow_modules.py [prepare|cli] [--param NAME[,NAME...]] [--top N]

``prepare``: flips pre-processing of the embedded back flip, warm; ``cli``: the whole
``mocomp flips backflip --flips 2``. Prints the modules and the most frequent returns. ``--param`` follows
parameters by name: every mocomp function that receives an argument of one of those names, in the
order first called, with the value it got and how many times it was called (e.g. ``cli --param
flips,extra_rotation``: where ``--flips`` goes; ``prepare --param smooth_sigma,velocity_weight``).
"""
import argparse
import collections
import os
import sys

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "benchmarks"))
from mocomp import datasets  # noqa: E402
from mocomp.flips import prepare  # noqa: E402
import mocomp.cli  # noqa: E402,F401


def modname(frame):
    return frame.f_globals.get("__name__", "")


def _short(v) -> str:
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


def trace(fn, params=()):
    seen = set()
    cur = [None]
    returns = [0]
    pairs = collections.Counter()
    trans = [0]
    receivers: dict = {}                  # (module.function, param) -> [first value, calls], in first-call order

    def move(m):
        if not m.startswith("mocomp"):
            return
        if m != cur[0]:
            if cur[0] is not None:
                trans[0] += 1
                if m in seen:
                    returns[0] += 1
                    pairs[(cur[0], m)] += 1
            cur[0] = m
            seen.add(m)

    def prof(frame, event, arg):
        if event == "call":
            m = modname(frame)
            move(m)
            if params and m.startswith("mocomp"):
                code = frame.f_code
                names = code.co_varnames[:code.co_argcount + code.co_kwonlyargcount]
                for p in params:
                    if p in names and p in frame.f_locals:
                        key = (f"{m.replace('mocomp.', '')}.{code.co_qualname}", p)
                        hit = receivers.setdefault(key, [_short(frame.f_locals[p]), 0])
                        hit[1] += 1
        elif event == "return":
            b = frame.f_back
            if b is not None:
                move(modname(b))

    sys.setprofile(prof)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return seen, returns[0], pairs, trans[0], receivers


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("which", nargs="?", default="prepare", choices=("prepare", "cli"))
    ap.add_argument("--param", default="", help="comma-separated argument names to follow")
    ap.add_argument("--top", type=int, default=int(os.environ.get("TOP", 12)), help="how many pairs to list")
    args = ap.parse_args(argv)
    motion = datasets.load("backflip")
    if args.which == "cli":
        import tempfile

        from mocomp.cli import main as cli_main

        out = tempfile.mkdtemp()
        f = lambda: cli_main(["flips", "backflip", "--flips", "2", "-o", os.path.join(out, "x.bvh")])  # noqa: E731
    else:
        f = lambda: prepare(motion)  # noqa: E731
    f()  # warm: imports, numba cache, the clip's body model
    params = tuple(p for p in args.param.split(",") if p)
    seen, ret, pairs, trans, receivers = trace(f, params)
    print(f"{args.which}: {len(seen)} modules, {trans} transitions, {ret} returns to an already-visited module")
    print(" ".join(sorted(s.replace("mocomp.", "") for s in seen)))
    for (a, b), n in pairs.most_common(args.top):
        print(f"  {n:5d}  {a} -> {b}")
    if params:
        print(f"how {', '.join(params)} flow{'s' if len(params) == 1 else ''} (functions receiving them, "
              "in first-call order):")
        for (fn_name, p), (value, calls) in receivers.items():
            print(f"  {fn_name}({p}={value})" + (f"  x{calls}" if calls > 1 else ""))


if __name__ == "__main__":
    main()
