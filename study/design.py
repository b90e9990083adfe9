"""Trial design: the per-participant plan of a session.

The flips paper (section 7, "Procedure"; dissertation section 5.7) says:
participants were first *shown examples of correct motions* as a reference;
they then marked each test motion correct or incorrect; *the test motions were
arranged randomly within each error group and then interleaved to reduce the
learning effect*; *each motion was shown twice*. :func:`make_plan` builds
exactly that, with choices the paper leaves open made explicit in
:class:`DesignConfig`:

* error groups: by default the two groups of Table 2, angular momentum
  (abrupt and smooth) and take-off angle. The unperturbed motions are each
  group's 0 % level (Table 2 lists a separate 0 % rating per group: 72 % for
  angular momentum, 63 % for take-off), so by default they are shown inside
  every group (``controls="each_group"``) and the analysis compares each
  perturbed condition with the controls of its own group;
* "shown twice": by default two passes over all test motions, each pass
  freshly shuffled within groups and interleaved (``repeat_mode="passes"``);
  ``"mixed"`` shuffles both copies together. No stimulus is ever shown twice
  in a row;
* interleaving: ``"proportional"`` spreads every group evenly over the
  sequence (round-robin when groups are equal in size), the first group of
  the (counterbalanced) order leading and each later group phase-shifted by
  rank / number of groups of its own spacing, ``"round_robin"``
  alternates strictly until a group runs out, ``"blocked"`` shows the groups
  one after the other;
* optional counterbalancing of the group order (balanced Latin square by
  participant number, or random), practice trials, instructed-response
  attention checks, and breaks: on by default, a break screen before every
  :data:`BREAK_EVERY_DEFAULT`-th trial of the test phase (about every 4-5
  minutes at the paper's pace), stating its suggested length ``break_s``;
* "must watch first" (default on): no answer before the video has played to its
  end once per presentation (enforced by the app, recorded per response).

All randomness comes from one per-participant seed, recorded in the plan.
"""
from __future__ import annotations

import hashlib
import io
import json
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone

import numpy as np
import pandas as pd

from .stimulus_set import StimulusSet

PLAN_FORMAT = 1
KINDS = ("example", "practice", "test", "attention")
#: Plan columns, in order (see DATA_DICTIONARY.md).
PLAN_COLUMNS = ("trial_index", "kind", "stimulus_id", "group", "repetition", "expected_response",
                "break_before", "condition", "perturbation", "direction", "nominal_level", "base_clip")

#: Default break interval: a break screen before every 30th trial of the test phase (the paper's 88
#: trials of about 3 s of video plus the answer take ~12-15 min: two breaks, ~4-5 min apart).
BREAK_EVERY_DEFAULT = 30
#: Default suggested break length (s), said on the break screen.
BREAK_S_DEFAULT = 60.0


@dataclass(frozen=True)
class DesignConfig:
    """Choices of the trial design (all recorded in the plan).

    Attributes
    ----------
    n_repeats: how often each test motion is shown (paper: 2).
    repeat_mode: ``"passes"`` (repeat the whole interleaved sequence, reshuffled) or
        ``"mixed"`` (both copies shuffled together within the group).
    groups: error groups, name -> perturbation types it holds.
    controls: ``"each_group"`` (unperturbed motions shown in every group, as its 0 %
        level) or ``"own_group"`` (one extra group ``"control"``).
    interleave: ``"proportional"``, ``"round_robin"`` or ``"blocked"``.
    counterbalance: group order ``"none"`` (as listed), ``"latin"`` (balanced Latin
        square row ``counterbalance_index``) or ``"random"`` (from the seed).
    examples: ``"unperturbed"`` (every unperturbed motion once, in random order),
        ``"none"``, or a tuple of stimulus ids, shown first without a response.
    n_practice: practice trials after the examples (responses recorded, kind
        ``practice``, excluded from the analysis).
    n_attention: instructed-response attention checks spread over the test trials
        (the screen tells the participant which button to press).
    break_every: a break screen before every ``break_every``-th trial of the test
        phase (default :data:`BREAK_EVERY_DEFAULT`; None or 0: no breaks). The
        break screen states its suggested length and how far the participant has
        come, and the study resumes when the participant clicks "Continue".
    break_s: suggested length of each break in seconds, said on the break screen
        (default :data:`BREAK_S_DEFAULT`; a countdown shows it when the page's
        script runs; the participant may continue earlier or later).
    must_watch: the response buttons and keys (and an example's "Next") stay
        disabled until the video of the current presentation has played to its
        end at least once (default, as labs expect). The app enforces it when its
        browser script reports the video's ``ended`` event; each response row
        records whether it was enforced (``must_watch``) and whether the video had
        ended (``watched_to_end``).
    """

    n_repeats: int = 2
    repeat_mode: str = "passes"
    groups: dict = field(default_factory=lambda: {"angular_momentum": ("am_abrupt", "am_smooth"),
                                                   "takeoff": ("takeoff",)})
    controls: str = "each_group"
    interleave: str = "proportional"
    counterbalance: str = "none"
    examples: object = "unperturbed"
    n_practice: int = 0
    n_attention: int = 0
    break_every: int | None = BREAK_EVERY_DEFAULT
    break_s: float = BREAK_S_DEFAULT
    must_watch: bool = True

    def __post_init__(self):
        def bad(msg):
            raise ValueError(f"DesignConfig: {msg}")
        if int(self.n_repeats) < 1:
            bad(f"n_repeats must be >= 1, got {self.n_repeats}")
        for name, val, allowed in (("repeat_mode", self.repeat_mode, ("passes", "mixed")),
                                   ("controls", self.controls, ("each_group", "own_group")),
                                   ("interleave", self.interleave, ("proportional", "round_robin", "blocked")),
                                   ("counterbalance", self.counterbalance, ("none", "latin", "random"))):
            if val not in allowed:
                bad(f"{name} must be one of {allowed}, got {val!r}")
        if not self.groups:
            bad("groups is empty")
        seen = {}
        for g, perts in self.groups.items():
            if g == "control" and self.controls == "own_group":
                bad("group name 'control' is reserved when controls='own_group'")
            for p in perts:
                if p == "none":
                    bad("groups list perturbation types; unperturbed motions are placed by `controls`")
                if p in seen:
                    bad(f"perturbation {p!r} is in groups {seen[p]!r} and {g!r}")
                seen[p] = g
        if isinstance(self.examples, str) and self.examples not in ("unperturbed", "none"):
            bad(f"examples must be 'unperturbed', 'none' or a list of stimulus ids, got {self.examples!r}")
        if int(self.n_practice) < 0 or int(self.n_attention) < 0:
            bad("n_practice and n_attention must be >= 0")
        if not isinstance(self.must_watch, bool):
            bad(f"must_watch must be true or false, got {self.must_watch!r}")
        if self.break_every is not None:
            if isinstance(self.break_every, bool) or int(self.break_every) != self.break_every \
                    or int(self.break_every) < 0:
                bad(f"break_every must be a whole number >= 1 (0 or None: no breaks), got {self.break_every!r}")
            if int(self.break_every) == 0:
                object.__setattr__(self, "break_every", None)
        if isinstance(self.break_s, bool) or not 0 < float(self.break_s) <= 3600:
            bad(f"break_s must be a number of seconds in (0, 3600], got {self.break_s!r}")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["groups"] = {k: list(v) for k, v in self.groups.items()}
        if not isinstance(self.examples, str):
            d["examples"] = list(self.examples)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "DesignConfig":
        d = dict(d)
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"DesignConfig: unknown field(s) {sorted(unknown)}")
        if "groups" in d:
            d["groups"] = {k: tuple(v) for k, v in d["groups"].items()}
        if "examples" in d and not isinstance(d["examples"], str):
            d["examples"] = tuple(d["examples"])
        return cls(**d)


def participant_seed(study_seed: int, participant_id: str) -> int:
    """Deterministic per-participant seed from a study seed and the participant id."""
    h = hashlib.sha256(f"mocomp-study/{int(study_seed)}/{participant_id}".encode()).digest()
    return int.from_bytes(h[:8], "big") >> 1


def balanced_latin_square(n: int) -> np.ndarray:
    """Williams' balanced Latin square (n x n; for odd n, 2n rows: the square and its mirror).

    Every item appears once in every position, and (for even n) every item
    follows every other exactly once.
    """
    if n < 1:
        raise ValueError("n must be >= 1")
    first = [0]
    lo, hi = 1, n - 1
    take_lo = True
    while len(first) < n:
        first.append(lo if take_lo else hi)
        lo, hi = (lo + 1, hi) if take_lo else (lo, hi - 1)
        take_lo = not take_lo
    rows = np.array([[(c + r) % n for c in first] for r in range(n)])
    if n % 2 == 1:
        rows = np.vstack([rows, rows[:, ::-1]])
    return rows


@dataclass(frozen=True)
class Plan:
    """One participant's session plan: the trial table and how it was made.

    ``trials`` has the columns :data:`PLAN_COLUMNS`, one row per screen that
    shows a stimulus, in presentation order (``trial_index`` 0..n-1).
    ``meta`` holds participant id, seed, design config, stimulus-set id,
    manifest hash, group order and creation time (UTC).
    """

    trials: pd.DataFrame
    meta: dict

    @property
    def response_trials(self) -> pd.DataFrame:
        """Trials that take a response (practice, test, attention), in order."""
        return self.trials[self.trials["kind"] != "example"]

    def to_csv_bytes(self) -> bytes:
        buf = io.StringIO()
        self.trials.to_csv(buf, index=False, lineterminator="\n")
        return buf.getvalue().encode()

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.to_csv_bytes()).hexdigest()

    def meta_json(self) -> str:
        return json.dumps({**self.meta, "plan_sha256": self.sha256, "n_trials": int(len(self.trials))},
                          indent=2, sort_keys=True)

    @staticmethod
    def from_files(csv_bytes: bytes, meta: dict) -> "Plan":
        trials = pd.read_csv(io.BytesIO(csv_bytes), dtype={"stimulus_id": str, "group": str, "kind": str,
                                                           "expected_response": str, "condition": str,
                                                           "perturbation": str, "direction": str,
                                                           "base_clip": str},
                             keep_default_na=False)
        trials["break_before"] = trials["break_before"].astype(str).str.lower().isin(("true", "1"))
        return Plan(trials=trials, meta={k: v for k, v in meta.items() if k not in ("plan_sha256", "n_trials")})


def _interleave(lists: list[list], mode: str) -> list:
    """Merge per-group sequences (in group order) into one sequence.

    ``"proportional"``: item i of the group at rank r (of G) in the group order
    sits at (i + r / G) / n_r of the sequence: every group evenly spread, and
    the order sets the phase, so the first group leads and a counterbalanced
    order changes the group at up to 2 min(n_r) positions (not only ties).
    """
    if mode == "blocked":
        return [x for lst in lists for x in lst]
    keyed = []
    G = len(lists)
    for rank, lst in enumerate(lists):
        n = len(lst)
        for i, x in enumerate(lst):
            key = (i + rank / G) / n if mode == "proportional" else float(i)
            keyed.append((key, rank, i, x))
    keyed.sort(key=lambda t: (t[0], t[1], t[2]))
    return [t[3] for t in keyed]


def _no_adjacent_repeats(seq: list[tuple[str, str]], rng: np.random.Generator) -> list[tuple[str, str]]:
    """Swap items so that no stimulus follows itself; swaps stay within a group."""
    seq = list(seq)
    for _ in range(4):
        clash = False
        for i in range(1, len(seq)):
            if seq[i][0] != seq[i - 1][0]:
                continue
            clash = True
            g = seq[i][1]
            cands = [j for j in range(len(seq)) if j != i and seq[j][1] == g and seq[j][0] != seq[i][0]
                     and (j == 0 or seq[j - 1][0] != seq[i][0]) and (j + 1 >= len(seq) or seq[j + 1][0] != seq[i][0])
                     and seq[i - 1][0] != seq[j][0] and (i + 1 >= len(seq) or seq[i + 1][0] != seq[j][0])]
            if cands:
                j = cands[int(rng.integers(len(cands)))]
                seq[i], seq[j] = seq[j], seq[i]
        if not clash:
            break
    return seq


def make_plan(stimuli: StimulusSet, config: DesignConfig | None = None, *, participant_id: str,
              seed: int, counterbalance_index: int | None = None) -> Plan:
    """Build the trial plan of one participant (see the module docstring).

    Parameters
    ----------
    stimuli: the stimulus set (its unperturbed motions are the controls and examples).
    config: design choices; default :class:`DesignConfig()` (the paper's procedure).
    participant_id: recorded in the plan.
    seed: the participant's seed (e.g. :func:`participant_seed`); the plan is a
        pure function of (stimuli, config, seed, counterbalance_index).
    counterbalance_index: participant number for ``counterbalance="latin"``.
    """
    cfg = config or DesignConfig()
    rng = np.random.default_rng(seed)
    tab = stimuli.table
    perts_present = set(tab["perturbation"]) - {"none"}
    grouped = {p for ps in cfg.groups.values() for p in ps}
    stray = sorted(perts_present - grouped)
    if stray:
        raise ValueError(f"the stimulus set has perturbation(s) {stray} that no design group lists; "
                         f"groups are {dict(cfg.groups)}")
    controls = list(tab.index[tab["perturbation"] == "none"])
    members: dict[str, list[str]] = {}
    for g, ps in cfg.groups.items():
        ids = list(tab.index[tab["perturbation"].isin(ps)])
        if not ids:
            continue
        if cfg.controls == "each_group":
            ids = controls + ids
        members[g] = ids
    if cfg.controls == "own_group" and controls:
        members["control"] = list(controls)
    if not members:
        raise ValueError("the design has no test stimuli (no group matches the stimulus set)")
    names = list(members)
    if cfg.counterbalance == "latin":
        if counterbalance_index is None:
            raise ValueError("counterbalance='latin' needs counterbalance_index (the participant number)")
        sq = balanced_latin_square(len(names))
        order = [names[k] for k in sq[int(counterbalance_index) % len(sq)]]
    elif cfg.counterbalance == "random":
        order = [names[k] for k in rng.permutation(len(names))]
    else:
        order = names

    # --- test sequence: shuffled within groups, interleaved, each motion n_repeats times
    test: list[tuple[str, str, int]] = []
    if cfg.repeat_mode == "passes":
        for rep in range(1, cfg.n_repeats + 1):
            lists = []
            for g in order:
                ids = [members[g][k] for k in rng.permutation(len(members[g]))]
                lists.append([(s, g) for s in ids])
            seq = _interleave(lists, cfg.interleave)
            if test and len(seq) > 1 and seq[0][0] == test[-1][0]:
                j = next((j for j in range(1, len(seq)) if seq[j][1] == seq[0][1] and seq[j][0] != seq[0][0]), None)
                if j is None:
                    j = 1
                seq[0], seq[j] = seq[j], seq[0]
            test += [(s, g, rep) for s, g in seq]
    else:
        lists = []
        for g in order:
            ids = [(s, g) for s in members[g] for _ in range(cfg.n_repeats)]
            ids = [ids[k] for k in rng.permutation(len(ids))]
            lists.append(ids)
        seq = _no_adjacent_repeats(_interleave(lists, cfg.interleave), rng)
        count: dict[tuple[str, str], int] = {}
        for s, g in seq:
            count[(s, g)] = count.get((s, g), 0) + 1
            test.append((s, g, count[(s, g)]))
    # repair any remaining adjacent repeats (possible for tiny groups)
    for i in range(1, len(test)):
        if test[i][0] == test[i - 1][0]:
            for j in range(i + 1, len(test)):
                if test[j][0] != test[i][0] and (j + 1 >= len(test) or test[j + 1][0] != test[i][0]) \
                        and test[j - 1][0] != test[i][0] and test[j][0] != test[i - 1][0]:
                    test[i], test[j] = test[j], test[i]
                    break

    rows: list[dict] = []

    def add(kind, sid, group, rep, expected=""):
        rows.append(dict(kind=kind, stimulus_id=sid, group=group, repetition=rep, expected_response=expected))

    # --- examples of correct motions first
    if isinstance(cfg.examples, str):
        ex = [controls[k] for k in rng.permutation(len(controls))] if cfg.examples == "unperturbed" else []
    else:
        ex = list(cfg.examples)
        unknown = [s for s in ex if s not in tab.index]
        if unknown:
            raise ValueError(f"example stimulus id(s) not in the stimulus set: {unknown}")
        notok = [s for s in ex if tab.at[s, "perturbation"] != "none"]
        if notok:
            raise ValueError(f"examples must be correct (unperturbed) motions; these are perturbed: {notok}")
    for s in ex:
        add("example", s, "", 0)
    # --- practice
    if cfg.n_practice:
        pool = list(tab.index)
        pick = rng.choice(len(pool), size=cfg.n_practice, replace=cfg.n_practice > len(pool))
        for k in pick:
            add("practice", pool[int(k)], "", 0)
    # --- test with attention checks at evenly spaced, jittered positions
    na = int(cfg.n_attention)
    att_at: dict[int, int] = {}
    if na:
        if not controls:
            raise ValueError("attention checks use unperturbed motions; the stimulus set has none")
        edges = np.linspace(0, len(test), na + 1)
        for a in range(na):
            lo, hi = int(np.ceil(edges[a])) + (1 if a == 0 else 0), int(np.floor(edges[a + 1]))
            pos = int(rng.integers(lo, max(lo, hi) + 1))
            att_at[a] = min(max(pos, 1), len(test))
        expected = (["correct", "incorrect"] * na)[:na]
        expected = [expected[k] for k in rng.permutation(na)]
    att_by_pos: dict[int, list[int]] = {}
    for a, pos in att_at.items():
        att_by_pos.setdefault(pos, []).append(a)
    n_test_phase = 0
    first_test_row = len(rows)
    for i in range(len(test) + 1):
        for a in att_by_pos.get(i, []):
            add("attention", controls[int(rng.integers(len(controls)))], "", 0, expected[a])
            n_test_phase += 1
        if i == len(test):
            break
        s, g, rep = test[i]
        add("test", s, g, rep)
        n_test_phase += 1
    trials = pd.DataFrame(rows)
    trials.insert(0, "trial_index", np.arange(len(trials)))
    trials["break_before"] = False
    if cfg.break_every:
        k = np.arange(len(trials)) - first_test_row
        trials.loc[(k > 0) & (k % int(cfg.break_every) == 0) & (k < n_test_phase), "break_before"] = True
    meta_tab = tab.loc[trials["stimulus_id"]]
    trials["condition"] = meta_tab["condition"].to_numpy()
    trials["perturbation"] = meta_tab["perturbation"].to_numpy()
    trials["direction"] = meta_tab["direction"].to_numpy()
    trials["nominal_level"] = meta_tab["nominal_level"].to_numpy()
    trials["base_clip"] = meta_tab["base_clip"].to_numpy()
    trials = trials[list(PLAN_COLUMNS)]
    from . import __version__

    meta = dict(format=PLAN_FORMAT, participant_id=str(participant_id), seed=int(seed),
                counterbalance_index=None if counterbalance_index is None else int(counterbalance_index),
                group_order=list(order), design=cfg.to_dict(), stimulus_set_id=stimuli.set_id,
                manifest_path=str(stimuli.path), manifest_sha256=stimuli.manifest_sha256,
                created_utc=datetime.now(timezone.utc).isoformat(timespec="seconds"), study_version=__version__)
    return Plan(trials=trials.reset_index(drop=True), meta=meta)
