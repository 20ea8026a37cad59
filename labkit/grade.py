"""Exercises the virtual machine grades: a student's program run and checked as a teacher would.

An :class:`Exercise` states what the answer must do — the drawing it burns (in the job's
work coordinates), how far a burn may stray from it, a time limit, a line width by the dose
model — and :func:`grade` runs the student's G-code on :class:`labkit.machine.virtual.
VirtualMachine` (GRBL 1.1 in laser mode, simulated time) and reports one verdict per check:

``check``
    the program passes :func:`labkit.gcode.check` (GRBL's own rules, line length included);
    nothing else runs when it does not — a program GRBL refuses burns nothing to grade.
``machine``
    every line was accepted by the (virtual) controller, with no alarm, and the program ran
    to its end.
``work area``
    every motion the machine executed stays on the bed: within the machine's travel
    (``$130``, ``$131``) from where the head stood at power-up, 0…travel in the virtual
    machine's coordinates, the head starting at the bed's corner. This is the bed, not
    GRBL's soft limits: those need homing and count −travel…0 from the homed corner
    (the virtual machine grades with soft limits off, as GRBL ships).
``drawing``
    at least ``min_coverage`` of the drawing's length lies within ``band_mm`` of a burned
    stretch (coverage against the target).
``nothing else``
    at most ``stray_mm`` of burned length lies farther than ``band_mm`` from the drawing.
``time``
    the job's machine time (planner-limited moves, simulated) is at most ``max_time_s``.
``speed``
    the speed the machine burned at, median over the burned length, is within ``feed_tol``
    of ``feed_mm_min``.
``width``
    the burned line width of the dose model (:func:`labkit.laser.models.dose_width`) at the
    power and speed the machine actually ran, median over the burned length, is within
    ``width_tol_mm`` of ``width_mm``.
``beam off``
    when the program has ended the beam is off and no laser mode is left armed with power
    (the program ends with ``M5``, ``S0``, or ``M2``/``M30``).

Checks an exercise does not ask for are not run and not listed. A check cell in a chapter
calls :func:`check_exercise` with the exercise's key and the student's program;
``labkit course grade DIR`` grades a folder of submissions (:func:`grade_folder`).

Grading never raises on a student's program: a bad program is a failed check with the
reason in words (file:line:column for the parser's findings).
"""

from __future__ import annotations

import ast
import csv
import math
from dataclasses import dataclass, field
from pathlib import Path as FilePath

import numpy as np

from labkit.geometry.path import Path

__all__ = ["Exercise", "Check", "Grade", "EXERCISES", "drawing_from_gcode", "grade",
           "check_exercise", "answers_in_notebook", "grade_folder"]

#: GRBL's serial receive buffer less one byte, as a character-counting sender fills it
_RX_LIMIT = 127
#: spacing of the points at which coverage is measured along a path, mm
_SAMPLE_STEP_MM = 0.02


@dataclass(frozen=True)
class Exercise:
    """What a graded exercise's answer must do.

    Parameters
    ----------
    key : str
        ``"CC-N"``: chapter number and exercise number (``"22-2"``).
    title : str
        The task in one line, as the report prints it.
    drawing : tuple of Path
        What must be burned (or, with ``follow="feed"``, traced), work coordinates, mm.
    band_mm : float
        How far from the drawing a burned stretch still counts as on it, mm.
    min_coverage : float
        Fraction of the drawing's length that must be burned (0…1).
    stray_mm : float
        Burned length allowed farther than ``band_mm`` from the drawing, mm.
    follow : {"burn", "feed"}
        ``burn``: the stretches the machine ran with the beam on; ``feed``: every feed move
        (G1/G2/G3) beam or not, for exercises about motion alone.
    max_time_s : float, optional
        Machine time allowed for the whole program, s.
    feed_mm_min, feed_tol : float, optional
        Wanted burning speed (mm/min, median over the burned length as the machine ran it)
        and its relative tolerance.
    width_mm, width_tol_mm : float, optional
        Wanted line width and its tolerance, mm (dose model).
    w0_mm, fth_mj_mm2 : float
        The dose model's 1/e² beam radius (mm) and threshold fluence (mJ/mm²).
    origin_mm : (float, float)
        Where the operator set the work origin (G54) before the job, machine mm.
    beam_off : bool
        Check that the program leaves the beam off.
    machine : str
        Machine description (:func:`labkit.motion.load_machine`).
    """

    key: str
    title: str
    drawing: tuple = ()
    band_mm: float = 0.05
    min_coverage: float = 0.99
    stray_mm: float = 0.5
    follow: str = "burn"
    max_time_s: float | None = None
    feed_mm_min: float | None = None
    feed_tol: float = 0.05
    width_mm: float | None = None
    width_tol_mm: float = 0.01
    w0_mm: float = 0.12
    fth_mj_mm2: float = 200.0
    origin_mm: tuple = (0.0, 0.0)
    beam_off: bool = True
    machine: str = "grbl-diode"

    def __post_init__(self):
        from labkit.errors import InputError

        if self.follow not in ("burn", "feed"):
            raise InputError(f"exercise {self.key}: follow must be 'burn' or 'feed', got {self.follow!r}")
        if not 0 < self.min_coverage <= 1:
            raise InputError(f"exercise {self.key}: min_coverage must be in (0, 1], got {self.min_coverage!r}")
        for name in ("band_mm", "stray_mm", "width_tol_mm", "w0_mm", "fth_mj_mm2"):
            if not getattr(self, name) > 0:
                raise InputError(f"exercise {self.key}: {name} must be > 0, got {getattr(self, name)!r}")

    @property
    def answer_name(self) -> str:
        """The variable a chapter's stub and check cell use for the program (``answer_2``)."""
        return f"answer_{self.key.split('-')[1]}"


@dataclass(frozen=True)
class Check:
    """One verdict: the check's name, whether it passed, and why in words."""

    name: str
    passed: bool
    detail: str


@dataclass
class Grade:
    """Every check of one answer to one exercise."""

    exercise: Exercise
    checks: list = field(default_factory=list)
    #: figures measured on the virtual machine (time s, coverage, stray mm, width mm, …)
    figures: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks)

    @property
    def score(self) -> tuple[int, int]:
        """(checks passed, checks run)."""
        return sum(c.passed for c in self.checks), len(self.checks)

    def summary(self) -> str:
        """The report in words, one line per check."""
        got, of = self.score
        head = (f"Exercise {self.exercise.key} — {self.exercise.title}\n"
                f"{'PASSED' if self.passed else 'NOT YET'}: {got} of {of} checks")
        rows = [f"  [{'ok' if c.passed else '--'}] {c.name}: {c.detail}" for c in self.checks]
        return "\n".join([head] + rows)


def drawing_from_gcode(text: str, *, follow: str = "burn") -> tuple:
    """The drawing a G-code program burns (or traces), as Paths in work coordinates.

    Parameters
    ----------
    text : str
        A program (GRBL dialect).
    follow : {"burn", "feed"}
        The burning moves only, or every feed move (G1/G2/G3).

    Returns
    -------
    tuple of Path
        One path per move, lines and arcs exactly.

    Examples
    --------
    >>> d = drawing_from_gcode("G0 X10 Y10\\nM3 S500 F600\\nG1 X20\\nG2 X30 Y10 I5 J0\\nM5")
    >>> [round(p.length_mm, 4) for p in d]
    [10.0, 15.708]
    """
    from labkit.gcode import parse

    moves = parse(text).in_work_coordinates()
    keep = moves.laser_on if follow == "burn" else moves.is_feed
    sweeps, radii = moves.sweep_rad(), moves.radius_mm()
    paths = []
    for i in np.flatnonzero(keep):
        a, b = moves.start[i, :2], moves.end[i, :2]
        if moves.is_arc[i]:
            c = moves.centre[i, :2]
            paths.append(Path.arc(c, float(radii[i]), math.atan2(a[1] - c[1], a[0] - c[0]),
                                  float(sweeps[i])))
        elif np.hypot(*(b - a)) > 0:
            paths.append(Path.polyline([a, b]))
    return tuple(paths)


def _stations(segments: np.ndarray, step_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along straight segments (n, 2, 2) at most ``step_mm`` apart (midpoints of equal
    parts), and the length each point stands for."""
    lengths = np.hypot(*(segments[:, 1] - segments[:, 0]).T)
    parts = np.maximum(np.ceil(lengths / step_mm).astype(np.int64), 1)
    which = np.repeat(np.arange(len(segments)), parts)
    k = np.arange(int(parts.sum())) - np.repeat(np.cumsum(parts) - parts, parts)
    t = (k + 0.5) / parts[which]
    a, b = segments[which, 0], segments[which, 1]
    return a + (b - a) * t[:, None], (lengths / parts)[which]


def _path_segments(paths, tol_mm: float = 0.001) -> np.ndarray:
    """Paths as straight segments (arcs sampled within ``tol_mm``), shape (n, 2, 2)."""
    out = []
    for p in paths:
        pts = p.sample(tol_mm)
        out.append(np.stack([pts[:-1], pts[1:]], axis=1))
    return np.concatenate(out) if out else np.zeros((0, 2, 2))


def _send_program(vm, lines: list) -> tuple[list, float | None]:
    """Stream lines to the virtual machine by character counting and run it until idle.

    Returns the machine's answers (one per line, in order) and the simulated time at which
    the machine went idle after the last line (None when it never did within the limit).
    """
    answers: list[str] = []
    pending = bytearray()
    inflight: list[int] = []

    def pump():
        waiting = vm.in_waiting               # each poll advances the machine by one tick
        if waiting:
            pending.extend(vm.read(waiting))
        while b"\n" in pending:
            raw, _, rest = bytes(pending).partition(b"\n")
            pending[:] = rest
            text = raw.decode("ascii", "replace").strip()
            if text == "ok" or text.startswith("error:"):
                answers.append(text)
                if inflight:
                    inflight.pop(0)
            elif text.startswith("ALARM:"):
                answers.append(text)

    for line in lines:
        data = line.encode("ascii", "replace") + b"\n"
        while sum(inflight) + len(data) > _RX_LIMIT:
            pump()
            if any(a.startswith("ALARM:") for a in answers):
                return answers, None
        vm.write(data)
        inflight.append(len(data))
    limit_s = vm.sim_time_s + 24 * 3600.0       # a program that never ends (M0, a huge job)
    while (inflight or vm.state != "Idle") and vm.sim_time_s < limit_s:
        if vm.state in ("Alarm", "Hold", "Door"):    # nobody here resumes it (M0 holds unanswered)
            break
        pump()
        if any(a.startswith("ALARM:") for a in answers):
            break
    done = not inflight and vm.state == "Idle"
    return answers, (vm.sim_time_s if done else None)


def _program_lines(program) -> tuple[str, list]:
    """The program's text and the (source line, text to send) of each line that sends."""
    from labkit.machine.stream import strip_line

    text = program if isinstance(program, str) else "\n".join(program.source_lines)
    send = []
    for k, raw in enumerate(text.split("\n"), 1):
        s = strip_line(raw.rstrip("\r"))
        if s and not s.startswith("%"):
            send.append((k, s))
    return text, send


def grade(exercise: Exercise, program) -> Grade:
    """Run a student's program on the virtual machine and check it against the exercise.

    Parameters
    ----------
    exercise : Exercise or str
        The exercise, or its key in :data:`EXERCISES`.
    program : str or labkit.machine.Job
        The answer: G-code text (GRBL dialect) or a job.

    Returns
    -------
    Grade
        One :class:`Check` per check the exercise asks for; a program that does not pass
        ``check`` is graded on that alone.

    Raises
    ------
    labkit.errors.InputError
        An unknown exercise key, or an answer that is not text or a job.

    Examples
    --------
    >>> ex = Exercise("0-1", "burn a 10 mm line", drawing=(Path.polyline([(0, 0), (10, 0)]),),
    ...               max_time_s=5)
    >>> g = grade(ex, "G21 G90\\nM4 S500 F600\\nG1 X10\\nM5")
    >>> g.passed, [c.name for c in g.checks]
    (True, ['check', 'machine', 'work area', 'drawing', 'nothing else', 'time', 'beam off'])
    >>> grade(ex, "G21 G90\\nM4 S500 F600\\nG1 X10\\n").checks[-1].detail
    'the program ends with M4 S500 still in effect: the next move would burn; end with M5'
    """
    from labkit.errors import InputError
    from labkit.gcode import check
    from labkit.machine.virtual import VirtualMachine

    if isinstance(exercise, str):
        if exercise not in EXERCISES:
            raise InputError(f"no graded exercise {exercise!r}; known: {', '.join(sorted(EXERCISES))}")
        exercise = EXERCISES[exercise]
    if not isinstance(program, str) and not hasattr(program, "source_lines"):
        raise InputError(f"the answer must be G-code text (a string) or a labkit.machine.Job, "
                         f"got {type(program).__name__}")
    result = Grade(exercise)
    checks = result.checks
    text, send = _program_lines(program)
    if not send:
        checks.append(Check("check", False, "the program is empty: write its G-code lines between the quotes"))
        return result
    problems = check(text, filename="answer")
    if problems:
        shown = "; ".join(str(e) for e in problems[:3])
        more = f" (and {len(problems) - 3} more)" if len(problems) > 3 else ""
        checks.append(Check("check", False, f"{len(problems)} problem(s): {shown}{more}"))
        return result
    checks.append(Check("check", True, "no diagnostics"))

    vm = VirtualMachine(exercise.machine, time_scale=0, tick_s=0.02, banner=False)
    ox, oy = (float(v) for v in exercise.origin_mm)
    # the operator's part: the work origin set where the exercise puts it, the head there
    setup = [f"G10L2P1X{ox:g}Y{oy:g}", "G54", "G0X0Y0"]
    _, t0 = _send_program(vm, setup)
    first_piece = len(vm.executed)
    answers, end_s = _send_program(vm, [s for _, s in send])
    answers = ["ok"] * len(setup) + answers
    bad = [(i, a) for i, a in enumerate(answers) if a != "ok"]
    if bad:
        i, a = bad[0]
        where = f"line {send[i - len(setup)][0]} ({send[i - len(setup)][1]})" if len(setup) <= i < len(setup) + len(send) else "after the last line"
        checks.append(Check("machine", False, f"the controller answered {a} to {where}"))
    elif end_s is None:
        checks.append(Check("machine", False, f"the program did not run to its end (machine state "
                                              f"{vm.state} after {vm.sim_time_s:.0f} s): remove M0/M1 stops"))
    else:
        checks.append(Check("machine", True, f"all {len(send)} lines accepted and run"))

    pieces = [p for p in vm.executed[first_piece:] if p.start != p.end]
    travel = np.asarray(vm.machine.travel_mm, float)[:2]
    outside = [p for p in pieces if not all(0 - 1e-6 <= v <= t + 1e-6 for q in (p.start, p.end)
                                            for v, t in zip(q[:2], travel))]
    if outside:
        # the line's farthest point outside (its pieces are the ticks of one block)
        ends = np.array([p.end[:2] for p in pieces if p.line == outside[0].line])
        beyond = np.maximum(-ends, ends - travel).max(axis=1)
        x, y = ends[int(np.argmax(beyond))]
        k = _source_line(outside[0].line, len(setup), send)
        checks.append(Check("work area", False, f"line {k} ({_line_text(send, k)}) "
                                                f"reaches X{x:.3f} Y{y:.3f} (machine), outside the work "
                                                f"area 0…{travel[0]:g} × 0…{travel[1]:g} mm"))
    else:
        checks.append(Check("work area", True, f"inside 0…{travel[0]:g} × 0…{travel[1]:g} mm"))

    if exercise.follow == "burn":
        traced = [p for p in pieces if p.power > 0 and not p.rapid]
    else:
        traced = [p for p in pieces if not p.rapid]
    shift = np.array([ox, oy])
    if exercise.drawing:
        from labkit.geometry.transform import translate

        drawing = [p.transformed(translate(ox, oy))
                   for p in exercise.drawing]
        target = _path_segments(drawing)
        t_points, t_weights = _stations(target, _SAMPLE_STEP_MM)
        verb = "burned" if exercise.follow == "burn" else "traced"
        if traced:
            from labkit.geometry.measure import path_distance

            burned = [Path.polyline([p.start[:2], p.end[:2]]) for p in traced]
            covered = float(t_weights[path_distance(burned, t_points) <= exercise.band_mm].sum())
            b_points, b_weights = _stations(np.array([[p.start[:2], p.end[:2]] for p in traced]),
                                            _SAMPLE_STEP_MM)
            far = path_distance(drawing, b_points) > exercise.band_mm
            stray = float(b_weights[far].sum())
            stray_at = b_points[far][0] - shift if far.any() else None
        else:
            covered, stray, stray_at = 0.0, 0.0, None
        share = covered / float(t_weights.sum())
        result.figures.update(coverage=share, stray_mm=stray)
        checks.append(Check("drawing", share >= exercise.min_coverage,
                            f"{100 * share:.1f} % of the drawing's {t_weights.sum():.1f} mm {verb} "
                            f"within {exercise.band_mm:g} mm (wanted {100 * exercise.min_coverage:g} %)"
                            + ("" if traced else f"; nothing was {verb}")))
        where = "" if stray_at is None else f", first at X{stray_at[0]:.2f} Y{stray_at[1]:.2f}"
        checks.append(Check("nothing else", stray <= exercise.stray_mm,
                            f"{stray:.2f} mm {verb} off the drawing (allowed {exercise.stray_mm:g} mm){where}"))

    if exercise.max_time_s is not None:
        # from the first line sent to the end of the last motion (the machine polls in ticks of
        # 0.02 s, and a poll passes with each line written: the time is known to a tick or two)
        last = vm.executed[-1].t_end if len(vm.executed) > first_piece else t0
        took = (last if end_s is not None else vm.sim_time_s) - t0
        result.figures["time_s"] = took
        checks.append(Check("time", end_s is not None and took <= exercise.max_time_s,
                            f"{took:.1f} s of machine time (allowed {exercise.max_time_s:g} s)"))

    burns = _burns(vm, first_piece)
    if exercise.feed_mm_min is not None:
        checks.append(_speed_check(exercise, burns, result))
    if exercise.width_mm is not None:
        checks.append(_width_check(exercise, vm, burns, result))

    if exercise.beam_off:
        level = vm.laser_output()
        armed = vm.laser_mode_word in (3, 4) and vm.s_word > 0
        if level > 0:
            detail = (f"the beam is still on at {100 * level:.0f} % after the last line "
                      f"(M{vm.laser_mode_word} keeps it on at rest): end with M5")
        elif armed:
            detail = (f"the program ends with M{vm.laser_mode_word} S{vm.s_word:g} still in effect: "
                      f"the next move would burn; end with M5")
        else:
            detail = "the beam is off and no laser mode is armed"
        checks.append(Check("beam off", level == 0 and not armed, detail))
    return result


def _source_line(vm_line: int, n_setup: int, send: list) -> int | str:
    """The program's source line of the virtual machine's accepted-line count."""
    k = vm_line - n_setup - 1
    return send[k][0] if 0 <= k < len(send) else "?"


def _line_text(send: list, line) -> str:
    """The text sent for a source line (as the controller received it)."""
    return next((text for k, text in send if k == line), "?")


def _burns(vm, first_piece: int) -> np.ndarray:
    """(length mm, speed mm/min, beam fraction) of every burning stretch the machine ran."""
    from labkit.units import mm_s_to_mm_min

    rows = []
    previous_t = vm.executed[first_piece - 1].t_end if first_piece else 0.0
    for p in vm.executed[first_piece:]:
        dt, previous_t = p.t_end - previous_t, p.t_end
        length = math.dist(p.start[:2], p.end[:2])
        if p.power > 0 and not p.rapid and length > 0 and dt > 0:
            rows.append((length, mm_s_to_mm_min(length / dt), p.power))
    return np.asarray(rows, float).reshape(-1, 3)


def _median(values: np.ndarray, weights: np.ndarray) -> float:
    """The weighted median: half the weight lies at or below it."""
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, cum[-1] / 2)])


def _speed_check(exercise: Exercise, burns: np.ndarray, result: Grade) -> Check:
    """The speed the machine burned at, median over the burned length."""
    if not len(burns):
        return Check("speed", False, "nothing was burned, so no speed")
    speed = _median(burns[:, 1], burns[:, 0])
    result.figures["speed_mm_min"] = speed
    ok = abs(speed - exercise.feed_mm_min) <= exercise.feed_tol * exercise.feed_mm_min
    return Check("speed", ok, f"burned at {speed:.0f} mm/min along most of the path (wanted "
                              f"{exercise.feed_mm_min:g} mm/min ± {100 * exercise.feed_tol:g} %)")


def _width_check(exercise: Exercise, vm, burns: np.ndarray, result: Grade) -> Check:
    """The dose-model width along the burn, at the power and speed the machine ran."""
    from labkit.laser.models import dose_width

    if not len(burns):
        return Check("width", False, "nothing was burned, so no width")
    max_mw = float(vm.machine.laser_max_power_mw)
    widths = dose_width(burns[:, 2] * max_mw, burns[:, 1], exercise.w0_mm, exercise.fth_mj_mm2)
    median = _median(widths, burns[:, 0])
    result.figures["width_mm"] = median
    ok = abs(median - exercise.width_mm) <= exercise.width_tol_mm
    return Check("width", ok, f"{median:.3f} mm along most of the burn (dose model, w0 "
                              f"{exercise.w0_mm:g} mm, F_th {exercise.fth_mj_mm2:g} mJ/mm²; "
                              f"wanted {exercise.width_mm:g} ± {exercise.width_tol_mm:g} mm; "
                              f"range {widths.min():.3f}…{widths.max():.3f} mm)")


def check_exercise(key: str, program) -> None:
    """The check cell's call: grade ``program`` for exercise ``key`` and print the report.

    Parameters
    ----------
    key : str
        The exercise (see :data:`EXERCISES`).
    program : str
        The student's program (G-code text).

    Notes
    -----
    It prints and returns nothing, so a cell shows the report alone; :func:`grade` returns
    the :class:`Grade`. An unknown key or an answer that is not text prints what to do.
    """
    if key not in EXERCISES:
        print(f"There is no graded exercise {key!r} (known: {', '.join(sorted(EXERCISES))}).")
        return
    if not isinstance(program, str):
        name = EXERCISES[key].answer_name
        print(f"Write your program as text in {name} = \"\"\"...\"\"\" in the cell above, run it, "
              f"then run this cell (got {type(program).__name__}).")
        return
    print(grade(key, program).summary())


# -- the course's graded exercises ---------------------------------------------------------------

def _square(x, y, side):
    return (Path.rectangle(x, y, side, side),)


#: Chapter 01, section 1's program (without its comments): the drawing exercise 01-3 must keep.
CH01_PROGRAM = """G21 G90
M3 S600
G0 X15 Y5
G1 X30 F1200
X35
G91 G3 X5 Y5 I0 J5
G1 Y20
G3 X-5 Y5 I-5 J0
G90 G1 X15
G3 X10 Y30 I0 J-5
G1 Y10
G3 X15 Y5 I5 J0
M5
"""

EXERCISES = {e.key: e for e in [
    # 01 ex. 3: half the power and half the feed: the same drawing, the same width as section 1's
    # program (dose_width(0.6 × 5500 mW, 1200 mm/min, 0.12 mm, 200 mJ/mm²) = 0.221 mm), at 600 mm/min
    Exercise("01-3", "section 1's rounded square at half the power and half the feed",
             drawing=drawing_from_gcode(CH01_PROGRAM), origin_mm=(50.0, 50.0), max_time_s=15.0,
             feed_mm_min=600.0, width_mm=0.221, width_tol_mm=0.005),
    # 02 ex. 2: a half circle from (0, 0) to (10, 0) over the top (G2), motion only
    Exercise("02-2", "a clockwise half circle from (0, 0) to (10, 0)", follow="feed",
             drawing=(Path.arc((5.0, 0.0), 5.0, math.pi, -math.pi),), origin_mm=(50.0, 50.0),
             beam_off=False, stray_mm=0.05),
    # 05 ex. 2: kerf: the beam runs half a kerf outside a 20 mm square part
    Exercise("05-2", "a 20 mm square part at (10, 10) cut with a 0.2 mm kerf",
             drawing=_square(9.9, 9.9, 20.2), band_mm=0.02, stray_mm=0.1),
    # 16 ex. 1: a 20 mm line 0.25 mm wide at 900 mm/min (w0 0.12 mm, F_th 200 mJ/mm²)
    Exercise("16-1", "a 20 mm line from (10, 10) to (30, 10), 0.25 mm wide, at 900 mm/min",
             drawing=(Path.polyline([(10.0, 10.0), (30.0, 10.0)]),), feed_mm_min=900.0, width_mm=0.25,
             width_tol_mm=0.005, max_time_s=5.0),
    # 21 ex. 2: a 10 mm circle from (0, 0) with G3 (centre (5, 0))
    Exercise("21-2", "a 10 mm circle through (0, 0), centre (5, 0), cut with G3",
             drawing=(Path.circle((5.0, 0.0), 5.0),), origin_mm=(100.0, 100.0), max_time_s=10.0),
    # 22 ex. 2: the 10 mm square at the workpiece corner the operator jogged to (machine X50 Y40)
    Exercise("22-2", "a 10 mm square at machine X50 Y40 (the jogged workpiece corner)",
             drawing=_square(50.0, 40.0, 10.0), max_time_s=15.0),
]}


# -- bulk grading --------------------------------------------------------------------------------

def answers_in_notebook(path) -> dict:
    """The answers a student's notebook holds for graded exercises, without running it.

    A graded exercise's check cell calls ``check_exercise("KEY", answer_N)``; the answer is the
    last string literal assigned to ``answer_N`` in a code cell before it (read with Python's
    ``ast``: the student's code is never executed).

    Returns
    -------
    dict
        Exercise key → program text (exercises whose answer is missing are left out).

    Raises
    ------
    labkit.errors.InputError
        The file is not a readable notebook.
    """
    import nbformat

    from labkit.errors import InputError

    try:
        nb = nbformat.read(str(path), as_version=4)
    except (ValueError, KeyError, OSError, nbformat.reader.NotJSONError) as exc:
        raise InputError(f"{path}: not a readable notebook ({exc})") from None
    strings: dict[str, str] = {}
    found = {}
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        try:
            tree = ast.parse(cell.source)
        except SyntaxError:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) \
                    and isinstance(node.value.value, str):
                for target in node.targets:
                    if isinstance(target, ast.Name):
                        strings[target.id] = node.value.value
            elif isinstance(node, ast.Call) and getattr(node.func, "id", None) == "check_exercise" \
                    and len(node.args) == 2 and isinstance(node.args[0], ast.Constant) \
                    and isinstance(node.args[1], ast.Name) and node.args[1].id in strings:
                found[node.args[0].value] = strings[node.args[1].id]
    return found


_PROGRAM_SUFFIXES = (".gcode", ".nc", ".ngc", ".gc", ".txt")


def _submission_answers(entry: FilePath) -> dict:
    """Exercise key → program for one student's submission (a folder or a notebook)."""
    files = sorted(entry.rglob("*")) if entry.is_dir() else [entry]
    answers = {}
    for f in files:
        if f.suffix == ".ipynb":
            answers.update(answers_in_notebook(f))
        elif f.suffix.lower() in _PROGRAM_SUFFIXES and f.stem in EXERCISES:
            answers[f.stem] = f.read_bytes().decode("utf-8", "replace")
    return answers


def grade_folder(folder, out_dir) -> list[dict]:
    """Grade every student's submissions in ``folder``; write a report per student and a CSV.

    Layout: one entry per student — a folder holding ``KEY.gcode`` files (``22-2.gcode``;
    also ``.nc``, ``.ngc``, ``.gc``, ``.txt``) and/or the student's chapters (``.ipynb``, whose
    answers are read, never run), or a single notebook ``STUDENT.ipynb``.

    Parameters
    ----------
    folder : str or os.PathLike
        The submissions.
    out_dir : str or os.PathLike
        Where ``STUDENT.txt`` (each student's report) and ``grades.csv`` (one row per student
        and exercise: checks passed, checks run, passed, the failed checks) are written.

    Returns
    -------
    list of dict
        The CSV's rows.

    Raises
    ------
    labkit.errors.InputError
        The folder is missing or holds no submission, or the output folder is an existing file.
    """
    from labkit._files import atomic_output
    from labkit.errors import InputError

    folder, out = FilePath(folder), FilePath(out_dir)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such folder of submissions")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder; the reports need a folder")
    entries = sorted(e for e in folder.iterdir()
                     if not e.name.startswith(".") and e.resolve() != out.resolve()
                     and (e.is_dir() or e.suffix == ".ipynb"))
    if not entries:
        raise InputError(f"{folder}: no submissions (a folder or a notebook per student)")
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for entry in entries:
        student = entry.stem if entry.is_file() else entry.name
        answers = _submission_answers(entry)
        report = [f"Student: {student}", ""]
        for key in sorted(EXERCISES):
            if key not in answers:
                report += [f"Exercise {key} — {EXERCISES[key].title}\n  no answer handed in", ""]
                rows.append(dict(student=student, exercise=key, passed=0, checks_passed=0,
                                 checks_run=0, failed="no answer"))
                continue
            g = grade(key, answers[key])
            report += [g.summary(), ""]
            got, of = g.score
            rows.append(dict(student=student, exercise=key, passed=int(g.passed), checks_passed=got,
                             checks_run=of, failed=" ".join(c.name.replace(" ", "_")
                                                            for c in g.checks if not c.passed)))
        done = sum(r["passed"] for r in rows if r["student"] == student)
        report.insert(1, f"Exercises passed: {done} of {len(EXERCISES)}")
        with atomic_output(out / f"{student}.txt", "w", encoding="utf-8") as fh:
            fh.write("\n".join(report))
    with atomic_output(out / "grades.csv", "w", encoding="utf-8", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return rows
