"""Plausibility rules for the numbers a user types: a value that is valid but
can only be a slip of units (degrees written as radians, millimetres as metres,
a percentage as a fraction) is answered with one line naming its field and the
fix, before any work.  Used by studies (:func:`sweeps.study.load_design`),
certify configs (:func:`sweeps.certify.load`) and the planner command lines.

The part's **size** ``S`` is its largest extent, the largest distance between
two of its vertices (m; :func:`kernels.facets.extent`, the size the kernels'
own check :func:`kernels.errors.warn_implausible_size` uses).  The rules:

============================================  =========================  ==========================
field                                         warning (shown always)     error (exit 2, no work)
============================================  =========================  ==========================
a length tolerance or accuracy: tau_v,        > 10% of ``S``             >= ``S``
tau_com, sigma_v, start_xy, distance_abs,
tumble_slip_xy, pos_eps_m, tumble_eps,
tumble_tau_v (``--eps``, ``--tau-v``)
the limit-surface ratio ``c`` (friction.c,                               >= ``S`` (``c`` is at most
planner.support_c, ``--support-c``)                                      the largest distance from
                                                                         the centre of mass to the
                                                                         support)
an angle tolerance: start_theta,              > 20 deg (0.349 rad)       >= pi (no error or
fence_angle, tumble_slip_theta,                                          accuracy exceeds a half
theta_eps_rad                                                            turn: degrees)
a pose angle given as a bare number                                      ``|theta| > 2 pi``
(tasks' start / goal, ``--start``, ``--goal``)                           (degrees; ``720deg`` is
                                                                         fine)
tasks.sample.heading                                                     an end ``> 2 pi`` bare, or
                                                                         wider than a full turn
a friction coefficient (mu_f, mu_s,           > 3                        (< 0: the schema's error)
min_fence_mu, ``--min-fence-mu``)
execution.distance_rel (a fraction)           > 0.2                      >= 1
the part's size                               outside 0.1 mm .. 5 m      outside, in a unit stated
                                                                         (``units:``, ``--units``, a
                                                                         CAD header) where another
                                                                         unit fits: naming that unit
a task's travel (start to goal; a sampled    > 100 ``S``                >= 1000 ``S`` (a part in
task's annulus or box; ``--goal``)                                       mm with config lengths
                                                                         read as metres)
============================================  =========================  ==========================

The thresholds: an error where the value cannot be meant (a tolerance as
large as the part, an angle error of half a turn, a fraction of 1); a warning
where it is large but possible: a tenth of the part is far beyond machining
and placement errors (micrometres to a millimetre on a centimetre part) and
20 deg beyond any fence or robot error, while degrees slipped in as radians
(1, 2, 5) land above it.  Friction above 3 is a warning, not an error: no
fence or support material pairing reaches it (rubber on dry rough surfaces is
about 1 to 2), so it is a slip (a percentage, an angle) or a deliberate
idealisation of a contact that never slips, legitimate in a model study.  A
config's task angles are stored wrapped to (-pi, pi] (:func:`wrap`, in
:func:`sweeps.config.parse_pose` and the sampled goals).
"""
from __future__ import annotations

import dataclasses
import math
import re
import sys
import warnings
from typing import Iterable, Optional, Sequence

#: A length tolerance above this fraction of the part's size is a warning (at 1: an error).
LENGTH_WARN = 0.1
#: Angle tolerances (rad): a warning above, an error at or above.
ANGLE_WARN, ANGLE_MAX = math.radians(20.0), math.pi
#: A bare pose angle (rad) beyond this is degrees.
POSE_ANGLE_MAX = 2.0 * math.pi
#: Friction coefficients above this are a warning.
FRICTION_MAX = 3.0
#: execution.distance_rel (fraction): a warning above, an error at or above.
DISTANCE_REL_WARN, DISTANCE_REL_MAX = 0.2, 1.0

#: What each length field is (for the message), by its last name.
LENGTHS = {"tau_v": "vertex tolerance", "tau_com": "centre-of-mass tolerance",
           "sigma_v": "vertex standard deviation", "start_xy": "start position error",
           "distance_abs": "push-distance error", "tumble_slip_xy": "slip per tumble",
           "pos_eps_m": "position accuracy", "tumble_eps": "planner accuracy",
           "tumble_tau_v": "planned vertex tolerance", "--eps": "accuracy",
           "--tau-v": "vertex tolerance"}
ANGLES = {"start_theta": "start orientation error", "fence_angle": "fence angle error",
          "tumble_slip_theta": "rotational slip per tumble", "theta_eps_rad": "orientation accuracy"}


@dataclasses.dataclass(frozen=True)
class Finding:
    """One implausible value: ``level`` ``"error"`` or ``"warning"``; ``line`` the
    message (it starts with the field's dotted path or flag)."""

    level: str
    line: str


def _error(line: str) -> list[Finding]:
    return [Finding("error", line)]


def _warning(line: str) -> list[Finding]:
    return [Finding("warning", line)]


def _num(v) -> str:
    return f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)


def _pair(r) -> str:
    return f"[{_num(r[0])}, {_num(r[1])}]"


# --------------------------------------------------------------------------
# The rules, one value at a time
# --------------------------------------------------------------------------
def wrap(theta: float) -> float:
    """An angle (rad) in (-pi, pi]: returned as it is when already inside (bit
    for bit), else wrapped (:func:`kernels.planar.wrap_angle_np`)."""
    if -math.pi < theta <= math.pi:
        return theta
    from kernels import wrap_angle_np

    return float(wrap_angle_np(theta))


def part_size(vertices) -> float:
    """The part's size (m): the largest distance between two of its vertices."""
    import numpy as np

    from kernels import extent

    return extent(np.asarray(vertices, dtype=np.float64))


def size(s: float, part=None) -> list[Finding]:
    """A part ``s`` metres across outside the sizes nudge expects: the kernels'
    own warning (:func:`kernels.errors.warn_implausible_size`), word for word
    (nothing for a part of no size, which the kernels refuse).

    When the unit was stated (``part``'s ``units_from``: a part file's
    ``units:``, ``--units``, a CAD file's header) and another unit puts the
    same numbers inside the sizes nudge expects, it is an error naming that
    unit: ``--units m`` on a mesh in millimetres is a part 60 m across, whose
    fix is ``--units mm``, not dividing the file's numbers by 1000."""
    from kernels import warn_implausible_size

    if not s > 0:
        return []
    stated = _stated_unit(s, part)
    if stated:
        return _error(stated)
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        warn_implausible_size(s)
    return [Finding("warning", " ".join(str(w.message).split())) for w in got]


#: Units tried, in this order, for a part's numbers that are implausible in their stated unit
_UNIT_GUESSES = ("mm", "m", "cm", "in", "um")


def _stated_unit(s: float, part) -> Optional[str]:
    """The line for a part ``s`` m across read in a unit the user or the file
    stated, when that size is implausible and another unit is not; else None."""
    from sweeps.cad import PLAUSIBLE_SIZE_M
    from sweeps.units import UNITS

    unit, where = getattr(part, "units", None), getattr(part, "units_from", "") or ""
    lo, hi = PLAUSIBLE_SIZE_M
    if unit not in UNITS or lo <= s <= hi or where.startswith(("the default", "no unit")):
        return None
    numbers = s / UNITS[unit]
    fits = [u for u in _UNIT_GUESSES if u != unit and lo <= numbers * UNITS[u] <= hi]
    if not fits:
        return None
    u = fits[0]
    name = part.source.name
    if where.startswith("--"):                      # a flag: --units
        field, fix = where, f"give {where} {u}"
    elif where.startswith("the file"):              # the CAD file's own header
        field = "units"
        fix = (f"its numbers are not in the unit its header says: give units: {u} in the part "
               f"file (--units {u} for a file given on the command line)")
    else:
        field, fix = "units", f"write units: {u} in {part.path.name}"
    said = "" if where.startswith("--") else f" ({where})"
    return (f"{field}: {name} read in {unit}{said} is a part {s:.3g} m across, outside the "
            f"sizes nudge expects ({lo * 1e3:g} mm to {hi:g} m); in {u} it is "
            f"{numbers * UNITS[u] * 1e3:.3g} mm across - its numbers look like {u}: {fix}")


def length(field: str, v: Optional[float], s: float) -> list[Finding]:
    """A length tolerance or accuracy ``v`` (m) against the part's size ``s`` (m)."""
    if v is None or not v > 0 or not s > 0:
        return []
    what = LENGTHS.get(field.rsplit(".", 1)[-1], "tolerance")
    if v >= s:
        hint = (f"if you meant {v:g} mm, write {v / 1000:g}" if v / 1000 <= LENGTH_WARN * s
                else f"give one below {LENGTH_WARN * s:.3g} (a tenth of the part)")
        return _error(f"{field}: {v:g} m is not smaller than the part ({s:.3g} m across); a {what} "
                      f"this large cannot be meant - lengths are metres; {hint}")
    if v > LENGTH_WARN * s:
        return _warning(f"{field}: {v:g} m is {100 * v / s:.0f}% of the part's size ({s:.3g} m "
                        f"across), a large {what}; lengths are metres (check it is not in "
                        f"millimetres)")
    return []


def support_ratio(field: str, c, s: float) -> list[Finding]:
    """A range ``c`` ``[lo, hi]`` (m) of the limit-surface ratio ``m_max / f_max``:
    at most the largest distance from the centre of mass to the support, so
    never the part's size ``s`` (m)."""
    if c is None or not s > 0 or not c[1] >= s:
        return []
    hint = (f"if you meant mm, write [{c[0] / 1000:g}, {c[1] / 1000:g}]" if 1 <= c[1] < 1000 * s
            else "give a range below the part's size")
    return _error(f"{field}: {_pair(c)} m reaches the part's size ({s:.3g} m across), and the "
                  f"limit-surface ratio c = m_max / f_max is at most the distance from the centre "
                  f"of mass to the farthest support point - lengths are metres; {hint}")


#: A task's travel (m) beyond these multiples of the part's size: a warning, an error.
TRAVEL_WARN, TRAVEL_ERROR = 100.0, 1000.0


def travel(field: str, d: float, s: float, units: str = "m", xy=None) -> list[Finding]:
    """A task that moves the part ``d`` metres (start to goal, or the farthest a
    sampled goal can be) against the part's size ``s``: a config's lengths are
    metres even when the part file is in millimetres, so ``goal: [120, 30, 0]``
    on an mm part is a goal 120 m away.  ``units``: the part file's unit (the
    hint writes ``xy``, the numbers as typed, in metres)."""
    if not (d > 0 and s > 0) or d < TRAVEL_WARN * s:
        return []
    head = (f"{field}: the part travels {d:.3g} m, {d / s:,.0f} times its size ({s * 1e3:.3g} mm "
            "across); lengths in a config or on the command line are metres")
    if units != "m" and xy is not None:
        from sweeps.units import unit_factor

        k = unit_factor(units)
        hint = (f" even when the part file is in {units}: if you meant {units}, write "
                f"{', '.join(f'{float(v) * k:g}' for v in xy)}")
    else:
        hint = "; check the unit of the numbers"
    if d >= TRAVEL_ERROR * s:
        return _error(head + hint)
    return _warning(head + hint)


def design_draws(design, required) -> list[Finding]:
    """A tolerance design (``design:``, enabled) on too few draws to certify any
    design, even one with no failure (:func:`robustness.tolerance_design.design_samples_needed`):
    it would end in a design of zeros, after all its work."""
    if design is None or not design.enabled:
        return []
    from robustness import DESIGN_HEADROOM, design_samples_needed

    p, conf = required.probability, required.confidence
    need = design_samples_needed(p, conf)
    if design.n_samples >= need:
        return []
    strict = 1.0 - DESIGN_HEADROOM * (1.0 - conf)
    return _error(f"design.n_samples: {design.n_samples} design draws cannot show P(success) >= "
                  f"{p:g} at the design's {strict * 100:.4g}% confidence (a tenth of the stated "
                  f"error rate: headroom for its verification on fresh draws) even with no "
                  f"failure; give at least {need} (default 1000)")


def angle_tolerance(field: str, v: Optional[float]) -> list[Finding]:
    """An angle tolerance or accuracy ``v`` (rad, a half-width)."""
    if v is None or not v > 0:
        return []
    what = ANGLES.get(field.rsplit(".", 1)[-1], "angle tolerance")
    if v >= ANGLE_MAX:
        return _error(f"{field}: {v:g} rad is half a turn or more, which no {what} can be; it "
                      f"looks like degrees - give radians ({v:g} deg = {math.radians(v):.3g} rad)")
    if v > ANGLE_WARN:
        return _warning(f"{field}: {v:g} rad ({math.degrees(v):.0f} deg) is a loose {what}; "
                        f"angles are radians here ({v:g} deg would be {math.radians(v):.3g} rad)")
    return []


def pose_angle(field: str, raw) -> list[Finding]:
    """A pose angle as written: a bare number (radians; a config value or a
    command-line word) beyond a full turn is degrees; one with a ``deg`` or
    ``rad`` suffix means what it says."""
    from sweeps.terminal import ANGLE

    if isinstance(raw, bool):
        return []
    if isinstance(raw, str):
        m = ANGLE.match(raw)
        if not m or m.group(2):
            return []
        x, text = float(m.group(1)), m.group(1)
    elif isinstance(raw, (int, float)):
        x, text = float(raw), _num(raw)
    else:
        return []
    if abs(x) <= POSE_ANGLE_MAX:
        return []
    return _error(f"{field}: {text} looks like degrees (more than a full turn in radians); write "
                  f"{text}deg, or radians within [-pi, pi]")


def heading(field: str, raw: Sequence, lo: float, hi: float) -> list[Finding]:
    """A goal-heading range as written (``raw``) and in radians (``lo``, ``hi``)."""
    bare = [isinstance(r, (int, float)) and not isinstance(r, bool) for r in raw]
    if any(b and abs(x) > POSE_ANGLE_MAX for b, x in zip(bare, (lo, hi))):
        fixed = ", ".join(f"{_num(r)}deg" if b else str(r) for r, b in zip(raw, bare))
        return _error(f"{field}: {_pair(raw)} looks like degrees; write [{fixed}] or radians "
                      f"within [-pi, pi]")
    if hi - lo > POSE_ANGLE_MAX * (1 + 1e-12):
        return _error(f"{field}: {_pair(raw)} spans {hi - lo:.3g} rad, more than a full turn; give "
                      f"a range within one turn (e.g. [-180deg, 180deg])")
    return []


def friction(field: str, mu) -> list[Finding]:
    """A friction coefficient or range ``[lo, hi]`` (negative values are the
    schema's errors)."""
    if mu is None:
        return []
    top = max(mu) if isinstance(mu, (tuple, list)) else mu
    if not top > FRICTION_MAX:
        return []
    shown = _pair(mu) if isinstance(mu, (tuple, list)) else _num(mu)
    return _warning(f"{field}: {shown} exceeds {FRICTION_MAX:g}, more than any fence or support "
                    f"material pairing (rubber on dry rough surfaces is about 1 to 2); give the "
                    f"Coulomb coefficient (e.g. [0.3, 0.8]), or keep it only to idealise a contact "
                    f"that never slips")


def relative(field: str, v: Optional[float]) -> list[Finding]:
    """A relative push-distance error ``v`` (a fraction of each push)."""
    if v is None or not v > DISTANCE_REL_WARN:
        return []
    if v >= DISTANCE_REL_MAX:
        return _error(f"{field}: {v:g} is a fraction of each push's distance (0.05 = 5%); 1 or more "
                      f"lets the fence stop before it moves the part - give a fraction below 1")
    return _warning(f"{field}: {v:g} is {100 * v:.0f}% of each push's distance; it is a fraction "
                    f"(0.05 = 5%)")


# --------------------------------------------------------------------------
# A config (study configuration or certify config)
# --------------------------------------------------------------------------
def config_findings(cfg, part, s: Optional[float] = None) -> list[Finding]:
    """Every rule over a validated config (:class:`sweeps.config.Evaluation`
    with ``tasks``) and its part (a :class:`~sweeps.partfile.PartFile`; ``s`` its
    size, m, when known)."""
    s = part_size(part.vertices) if s is None else s
    t, x, e, p, f = cfg.tolerances, cfg.execution, cfg.eps, cfg.planner, cfg.friction
    out = size(s, part)
    for field, v in (("tolerances.tau_v", t.tau_v), ("tolerances.tau_com", t.tau_com),
                     ("tolerances.sigma_v", t.sigma_v), ("execution.start_xy", x.start_xy),
                     ("execution.distance_abs", x.distance_abs),
                     ("execution.tumble_slip_xy", x.tumble_slip_xy),
                     ("eps.pos_eps_m", e.pos_eps_m), ("planner.tumble_eps", p.tumble_eps),
                     ("planner.tumble_tau_v", p.tumble_tau_v)):
        out += length(field, v, s)
    out += support_ratio("friction.c", f.c, s) + support_ratio("planner.support_c", p.support_c, s)
    for field, v in (("execution.start_theta", x.start_theta),
                     ("execution.fence_angle", x.fence_angle),
                     ("execution.tumble_slip_theta", x.tumble_slip_theta),
                     ("eps.theta_eps_rad", e.theta_eps_rad)):
        out += angle_tolerance(field, v)
    out += relative("execution.distance_rel", x.distance_rel)
    out += friction("friction.mu_f", f.mu_f) + friction("friction.mu_s", f.mu_s)
    out += friction("planner.min_fence_mu", p.min_fence_mu)
    out += design_draws(getattr(cfg, "design", None), cfg.required)
    tasks = cfg.tasks
    units = getattr(part, "units", "m") or "m"
    if isinstance(tasks, list):
        for i, task in enumerate(tasks):
            for key in ("start", "goal"):
                pose = getattr(task, key)
                if isinstance(pose, list) and len(pose) >= 3:
                    out += pose_angle(f"tasks[{i}].{key}[2]", pose[2])
            a, b = _xy(task.start), _xy(task.goal)
            if a is not None and b is not None:
                out += travel(f"tasks[{i}].goal", math.dist(a, b), s, units, b)
    else:
        from sweeps.config import parse_angle

        sm = tasks.sample
        if isinstance(sm.start, list) and len(sm.start) >= 3:
            out += pose_angle("tasks.sample.start[2]", sm.start[2])
        far = _sample_reach(sm)
        if far is not None:
            out += travel(f"tasks.sample.{far[0]}", far[1], s, units, far[2])
        lo = parse_angle(sm.heading[0], "tasks.sample.heading[0]")
        hi = parse_angle(sm.heading[1], "tasks.sample.heading[1]")
        out += heading("tasks.sample.heading", sm.heading, lo, hi)
    return out


def _xy(pose):
    """The (x, y) of a pose as a config holds it (a list of numbers), else None."""
    try:
        return float(pose[0]), float(pose[1])
    except (TypeError, ValueError, IndexError, KeyError):   # a sensorless start: a mapping
        return None


def _sample_reach(sm):
    """``(key, metres, numbers)``: how far a sampled task's goal can be from its
    start (the annulus's outer radius, the box's farthest corner), or None."""
    ann = getattr(sm, "annulus", None)
    if ann is not None:
        return "annulus", abs(float(ann[1])), (ann[1],)
    box = getattr(sm, "box", None)
    if box is not None:
        (x0, x1), (y0, y1) = box
        return "box", math.hypot(max(abs(x0), abs(x1)), max(abs(y0), abs(y1))), (x1, y1)
    return None


def vet(findings: Iterable[Finding]) -> list[str]:
    """The warning lines of ``findings``; raises :class:`~sweeps.config.ConfigError`
    with one line per error when there is one."""
    from sweeps.config import ConfigError

    findings = list(findings)
    errors = list(dict.fromkeys(f.line for f in findings if f.level == "error"))
    if errors:
        raise ConfigError(errors[0], errors)
    return list(dict.fromkeys(f.line for f in findings if f.level == "warning"))


def check_design(design) -> list[str]:
    """Every configuration of a study (:class:`sweeps.study.Design`): its
    warning lines; raises :class:`~sweeps.config.ConfigError` on an error.  A
    line that not every configuration has names the first configuration with it
    (``params: configuration 3 (tolerances.tau_v=0.5): ...``)."""
    per, sizes = [], {}
    for cid, cfg in enumerate(design.configs):
        part = design.part(cid)
        key = id(part)
        if key not in sizes:
            sizes[key] = part_size(part.vertices)
        per.append(config_findings(cfg, part, sizes[key]))
    common = set.intersection(*({(f.level, f.line) for f in fs} for fs in per)) if per else set()
    out, seen = [], set()
    for cid, fs in enumerate(per):
        for f in fs:
            if (f.level, f.line) in seen:
                continue
            seen.add((f.level, f.line))
            line = f.line
            if (f.level, f.line) not in common:
                where = ", ".join(f"{p}={v!r}" for p, v in design.points[cid].items())
                line = f"params: configuration {cid} ({where}): {line}"
            out.append(Finding(f.level, line))
    return vet(out)


def screen_config(cfg, part) -> None:
    """A certify config and its part: raises :class:`~sweeps.config.ConfigError`
    on an error, else writes each warning line on stderr (whatever ``--quiet``)."""
    emit(vet(config_findings(cfg, part)))


def emit(lines: Iterable[str]) -> None:
    """Write ``warning: <line>`` on stderr for each line."""
    for line in lines:
        sys.stderr.write(f"warning: {line}\n")


# --------------------------------------------------------------------------
# The planner command lines
# --------------------------------------------------------------------------
def cli_findings(part, poses: Optional[dict] = None, lengths: Optional[dict] = None,
                 frictions: Optional[dict] = None, limit_surface: Optional[dict] = None) -> list:
    """The rules over a planner command line: the part (its size), ``poses``
    ``{flag: text}`` (``x,y,theta[,face]`` as typed, or None), ``lengths``
    ``{flag: metres}``, ``frictions`` ``{flag: coefficient}`` and
    ``limit_surface`` ``{flag: (lo, hi)}`` (None where not given)."""
    s = part_size(part.vertices)
    out = size(s, part)
    xy = {}
    for flag, text in (poses or {}).items():
        words = str(text).split(",") if text is not None else []
        if len(words) >= 3:
            out += pose_angle(flag, words[2].strip())
        try:
            xy[flag] = (float(words[0]), float(words[1]))
        except (ValueError, IndexError):
            pass
    if "--goal" in xy:
        units = getattr(part, "units", "m") or "m"
        out += travel("--goal", math.dist(xy.get("--start", (0.0, 0.0)), xy["--goal"]), s, units,
                      xy["--goal"])
    for flag, v in (lengths or {}).items():
        out += length(flag, v, s)
    for flag, v in (frictions or {}).items():
        out += friction(flag, v)
    for flag, c in (limit_surface or {}).items():
        out += support_ratio(flag, c, s)
    return out


def screen_cli(part, **given) -> Optional[list[str]]:
    """:func:`cli_findings` on stderr before any work: each warning as
    ``warning: ...`` and each error as ``error: ...`` (the warnings only when
    there is no error).  Returns the warning lines shown (for :func:`mute`), or
    None when there was an error (the command exits with status 2)."""
    from sweeps.terminal import fail

    try:
        shown = vet(cli_findings(part, **given))
    except ValueError as exc:   # ConfigError: one line per mistake
        for line in exc.lines:
            fail(line)
        return None
    emit(shown)
    return shown


def mute(lines: Sequence[str]) -> None:
    """Inside a ``warnings.catch_warnings()`` block: ignore the warnings whose
    text was already shown before the work (:func:`screen_cli`)."""
    for line in lines:
        warnings.filterwarnings("ignore", message=re.escape(line))
