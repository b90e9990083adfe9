"""Issue 14's flow measure: count module transitions during mocomp.flips.prepare (flips pre-processing) with sys.setprofile.

Tracks the mocomp module execution is in (Python frames only; C calls ignored). Every time execution
moves from one mocomp module to another (a call into it, or a return back to it), that is a transition;
a transition into a module that had already been visited (entered before and left) is a 'return'.

Usage: python scripts/flow_modules.py [prepare|cli]  (prepare: flips pre-processing of the embedded back
flip, warm; cli: the whole `mocomp flips backflip -n 2`). Prints the modules and the most frequent returns.
"""
import collections, sys, os
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "benchmarks"))
from mocomp import datasets
from mocomp.flips import prepare
import mocomp.cli  # noqa

def modname(frame):
    return frame.f_globals.get("__name__", "")

def trace(fn):
    seen = set(); cur = [None]; returns = [0]; pairs = collections.Counter(); trans = [0]
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
            move(modname(frame))
        elif event == "return":
            b = frame.f_back
            if b is not None:
                move(modname(b))
    sys.setprofile(prof)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return seen, returns[0], pairs, trans[0]

which = sys.argv[1] if len(sys.argv) > 1 else "prepare"
motion = datasets.load("backflip")
if which == "cli":
    import tempfile
    from mocomp.cli import main
    out = tempfile.mkdtemp()
    f = lambda: main(["flips", "backflip", "-n", "2", "-o", os.path.join(out, "x.bvh")])
else:
    f = lambda: prepare(motion)
f()  # warm: imports, numba cache
seen, ret, pairs, trans = trace(f)
print(f"{which}: {len(seen)} modules, {trans} transitions, {ret} returns to an already-visited module")
print(" ".join(sorted(s.replace("mocomp.", "") for s in seen)))
for (a, b), n in pairs.most_common(int(os.environ.get("TOP", 12))):
    print(f"  {n:5d}  {a} -> {b}")
