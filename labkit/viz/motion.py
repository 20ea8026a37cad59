"""Plots and widgets for the motion chapters (09 Bresenham, 10 speed profiles,
11 look-ahead, 12 laser power).

matplotlib and ipywidgets are imported inside the functions, so importing
this module costs nothing.
"""

from __future__ import annotations

import numpy as np

from labkit.viz._widgets import interact_figure

__all__ = [
    "plot_lattice_path",
    "plot_profile",
    "plot_speed_time",
    "plot_speed_distance",
    "plot_power_time",
    "plot_step_rates",
    "plot_burn",
    "compare_planners",
    "bresenham_explorer",
    "profile_explorer",
    "lookahead_explorer",
    "laser_explorer",
]

_PLANNER_COLOURS = {"junction": "tab:blue", "fast": "tab:red", "normal": "tab:orange", "hq": "tab:green"}


def _axes(ax, figsize=(7, 3.5)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_lattice_path(points, ax=None, *, line=None, circle=None, colour_by=None, title=None,
                      labels=None):
    """Lattice points of a Bresenham walk on a zoomed step grid.

    Parameters
    ----------
    points : array (n, 2)
        Lattice points (steps).
    line : pair of points, optional
        The exact line to draw over the steps.
    circle : (centre, radius), optional
        The exact circle to draw over the steps.
    colour_by : array of int, optional
        A class per point (e.g. the octant) for the colours.
    labels : dict, optional
        Class → legend label.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    pts = np.asarray(points)
    ax = _axes(ax, (6, 6))
    lo = pts.min(axis=0) - 1
    hi = pts.max(axis=0) + 1
    if circle is not None:
        c, r = np.asarray(circle[0], float), float(circle[1])
        lo = np.minimum(lo, np.floor(c - r) - 1)
        hi = np.maximum(hi, np.ceil(c + r) + 1)
    ax.set_xticks(np.arange(lo[0], hi[0] + 1))
    ax.set_yticks(np.arange(lo[1], hi[1] + 1))
    ax.grid(True, color="0.85", linewidth=0.6)
    ax.set_axisbelow(True)
    ax.plot(pts[:, 0], pts[:, 1], "-", color="0.5", linewidth=1, zorder=2)
    if colour_by is None:
        ax.plot(pts[:, 0], pts[:, 1], "s", color="tab:blue", markersize=7, zorder=3)
    else:
        cls = np.asarray(colour_by)
        cmap = plt.get_cmap("tab10")
        for k in np.unique(cls):
            sel = cls == k
            ax.plot(pts[sel, 0], pts[sel, 1], "s", color=cmap(int(k) % 10), markersize=7, zorder=3,
                    label=(labels or {}).get(int(k), str(k)))
        ax.legend(fontsize="small", loc="best")
    if line is not None:
        (x0, y0), (x1, y1) = line
        ax.plot([x0, x1], [y0, y1], color="tab:red", linewidth=1.5, zorder=4, label="exact line")
    if circle is not None:
        t = np.linspace(0, 2 * np.pi, 400)
        ax.plot(c[0] + r * np.cos(t), c[1] + r * np.sin(t), color="tab:red", linewidth=1.2, zorder=4)
    ax.set_xlim(lo[0] - 0.5, hi[0] + 0.5)
    ax.set_ylim(lo[1] - 0.5, hi[1] + 0.5)
    ax.set_aspect("equal")
    ax.tick_params(labelsize="x-small")
    ax.set_xlabel("x (steps)")
    ax.set_ylabel("y (steps)")
    if title:
        ax.set_title(title)
    return ax


def plot_profile(profiles, i=0, ax=None, *, against="distance", label=None, colour=None, shade=True):
    """One block's speed profile against distance or time, phases shaded (``shade``).

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = _axes(ax)
    t_total = float(profiles.time_s[i])
    t = np.linspace(0.0, t_total, 400)
    s, v = profiles.sample(i, t)
    x = s if against == "distance" else t
    line, = ax.plot(x, v, label=label, color=colour)
    c = line.get_color()
    if against == "distance":
        a = float(profiles.accel_mm[i])
        b = a + float(profiles.cruise_mm[i])
    else:
        a = float(profiles.accel_s[i])
        b = a + float(profiles.cruise_s[i])
    end = float(profiles.length_mm[i]) if against == "distance" else t_total
    if shade:
        ax.axvspan(0, a, color=c, alpha=0.08)
        ax.axvspan(b, end, color=c, alpha=0.16)
    ax.axhline(float(profiles.cap_mm_s[i]), color="0.6", linestyle=":", linewidth=1)
    return _speed_axes(ax, "distance along the block (mm)" if against == "distance" else "time (s)")


def plot_speed_time(plan, ax=None, *, n=3000, label=None, boundaries=True, colour=None):
    """Speed against time over a whole plan, super block boundaries as thin lines."""
    ax = _axes(ax, (9, 3.2))
    smp = plan.sample(n)
    colour = colour or _PLANNER_COLOURS.get(plan.planner)
    ax.plot(smp["time_s"], smp["speed_mm_s"], color=colour, linewidth=1,
            label=label or f"{plan.planner} ({plan.job_time_s:.2f} s)")
    if boundaries:
        _super_block_lines(ax, plan, plan.block_start_s[plan.motion], colour)
    return _speed_axes(ax, "time (s)")


def _super_block_lines(ax, plan, block_starts, colour):
    """Thin vertical lines where a super block begins (``block_starts``: where each motion
    block starts on the plot's x axis)."""
    edges = np.flatnonzero(np.diff(plan.lookahead.super_block)) + 1
    for x in block_starts[edges]:
        ax.axvline(x, color=colour, alpha=0.25, linewidth=0.6)


def _speed_axes(ax, xlabel):
    ax.set_xlabel(xlabel)
    ax.set_ylabel("speed (mm/s)")
    ax.set_ylim(bottom=0)
    return ax


def plot_speed_distance(plan, ax=None, *, label=None, colour=None):
    """Speed against distance along the path (super block boundaries as thin lines)."""
    ax = _axes(ax, (9, 3.2))
    prof = plan.profiles
    ends = np.cumsum(prof.length_mm)
    starts = ends - prof.length_mm
    xs, vs = [], []
    for j in range(len(prof)):
        s = np.linspace(0.0, prof.length_mm[j], 40)
        xs.append(starts[j] + s)
        vs.append(np.asarray(prof.speed_at(j, s)))
    colour = colour or _PLANNER_COLOURS.get(plan.planner)
    if xs:
        ax.plot(np.concatenate(xs), np.concatenate(vs), color=colour, linewidth=1, label=label or plan.planner)
        _super_block_lines(ax, plan, starts, colour)
    return _speed_axes(ax, "distance along the path (mm)")


def plot_power_time(plan, ax=None, *, n=3000, label=None, colour="tab:red", cap=True):
    """Instantaneous laser power against time (the laser maximum dotted)."""
    ax = _axes(ax, (9, 3.2))
    smp = plan.sample(n)
    ax.plot(smp["time_s"], smp["power_mw"], color=colour, linewidth=1, label=label)
    if cap:
        ax.axhline(plan.machine.laser_max_power_mw, color="0.4", linestyle=":", linewidth=1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("laser power (mW)")
    ax.set_ylim(0, plan.machine.laser_max_power_mw * 1.08)
    return ax


def plot_step_rates(trace, ax=None, *, axes="xyz", smooth=1):
    """Step rate of each axis against time, from a :class:`~labkit.motion.timer.StepTrace`.

    The rate at a step is 1 / (time since that axis' previous step), averaged
    over ``smooth`` steps.
    """
    ax = _axes(ax, (9, 3.2))
    for i, name in enumerate("xyz"):
        if name not in axes:
            continue
        sel = trace.step[:, i] != 0
        t = trace.time_s[sel]
        if len(t) < 2 + smooth:
            continue
        dt = (t[smooth:] - t[:-smooth]) / smooth
        ax.plot(t[smooth:], 1.0 / dt, linewidth=0.9, label=f"{name.upper()} axis")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("step rate (steps/s)")
    ax.legend(fontsize="small")
    return ax


def plot_burn(plan, ax=None, *, step_mm=0.01, quantity="dose_mj_per_mm", label=None, colour=None):
    """Dose (or speed, or power) along the burned path only."""
    ax = _axes(ax, (9, 3.2))
    bp = plan.burn_profile(step_mm)
    ax.plot(bp["distance_mm"], bp[quantity], linewidth=1, label=label, color=colour)
    ax.set_xlabel("distance along the burned path (mm)")
    ax.set_ylabel({"dose_mj_per_mm": "dose (mJ/mm)", "speed_mm_s": "speed (mm/s)",
                   "power_mw": "power (mW)"}.get(quantity, quantity))
    ax.set_ylim(bottom=0)
    return ax


def compare_planners(moves, machine=None, *, planners=("fast", "normal", "hq", "junction"),
                     buffer_blocks=None, law=None):
    """Plan one program with several planners: a DataFrame of figures and the plans."""
    import pandas as pd

    from labkit.motion import plan

    plans = {name: plan(moves, machine, planner=name, buffer_blocks=buffer_blocks, law=law)
             for name in planners}
    rows = []
    for name, p in plans.items():
        s = p.summary()
        rows.append({"planner": name, "ramps": s.law, "job time (s)": round(s.job_time_s, 3),
                     "super blocks": s.super_blocks, "mean speed (mm/s)": round(s.mean_speed_mm_s, 2),
                     "peak speed (mm/s)": round(s.peak_speed_mm_s, 2),
                     "corners above GRBL's limit": s.junctions_over_limit})
    return pd.DataFrame(rows).set_index("planner"), plans


# -- widgets --------------------------------------------------------------------------------

#: Slider labels are words with units; let them take the width they need.
_WIDE = {"description_width": "initial"}
#: The laser explorer's dose axis, mJ/mm: fixed, from a faint mark to far beyond any cut.
_DOSE_RANGE_MJ_PER_MM = (1.0, 1.0e4)


def bresenham_explorer():
    """Widget: a line to an end point and an arc of a radius, on the step grid."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.motion import arc_lattice_points, line_points
    from labkit.motion.bresenham import arc_octants

    def show(x_end, y_end, radius, centre_dx, sweep_deg):
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5.2))
        pts = line_points([0, 0], [x_end, y_end])
        driver = "X" if abs(x_end) >= abs(y_end) else "Y"
        plot_lattice_path(pts, a1, line=((0, 0), (x_end, y_end)),
                          title=f"line to ({x_end}, {y_end}): {len(pts) - 1} ticks, driver {driver}")
        c = np.array([centre_dx, 0.0])
        a0 = 0.0
        end = c + radius * np.array([np.cos(np.radians(sweep_deg)), np.sin(np.radians(sweep_deg))])
        s = np.floor(c + [radius, 0] + 0.5).astype(int)
        e = np.floor(end + 0.5).astype(int)
        arc = arc_lattice_points(s, e, c, clockwise=False, radius=float(radius), sweep_rad=np.radians(sweep_deg - a0))
        oct_ = arc_octants(arc, c).tolist()
        plot_lattice_path(arc, a2, circle=(c, radius), colour_by=oct_,
                          labels={k: f"octant {k + 1}: driver {'Y' if k in (0, 3, 4, 7) else 'X'}"
                                  for k in range(8)},
                          title=f"arc r = {radius}, {sweep_deg}°: {len(arc) - 1} ticks")
        fig.tight_layout()
        return fig

    return interact_figure(show,
                         x_end=w.IntSlider(value=11, min=-15, max=15, description="line end X (steps)", style=_WIDE),
                         y_end=w.IntSlider(value=4, min=-15, max=15, description="line end Y (steps)", style=_WIDE),
                         radius=w.IntSlider(value=8, min=2, max=14, description="arc radius (steps)", style=_WIDE),
                         centre_dx=w.FloatSlider(value=0.0, min=-0.5, max=0.5, step=0.05,
                                                 description="centre off grid (steps)", style=_WIDE),
                         sweep_deg=w.IntSlider(value=270, min=10, max=360, step=5, description="arc sweep (°)",
                                               style=_WIDE))


def profile_explorer():
    """Widget: one block's profile from its length, slopes and entry/exit speeds."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.motion import block_profiles, reach_speed

    def show(length_mm, cap_mm_s, entry_mm_s, exit_mm_s, up, down, law):
        if law == "accel":
            up, down = up * 12.5, down * 12.5          # slider 40 Hz/step ≈ 500 mm/s²
        ve = max(entry_mm_s, 0.05)
        vx = max(exit_mm_s, 0.05)
        ve = min(ve, cap_mm_s)
        vx = min(vx, cap_mm_s, reach_speed(ve, length_mm, up, law))
        ve = min(ve, reach_speed(vx, length_mm, down, law))
        p = block_profiles(length_mm, ve, cap_mm_s, vx, up, down, law)
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 3.6))
        plot_profile(p, 0, a1, against="distance")
        plot_profile(p, 0, a2, against="time")
        a1.set_title(f"{p.shape_name[0]}: peak {p.peak_mm_s[0]:.2f} mm/s")
        a2.set_title(f"{p.time_s[0] * 1000:.1f} ms (up {p.accel_mm[0]:.3f} mm, "
                     f"cruise {p.cruise_mm[0]:.3f} mm, down {p.decel_mm[0]:.3f} mm)")
        fig.tight_layout()
        note = None
        if (ve, vx) != (entry_mm_s, exit_mm_s):
            note = f"entry/exit adjusted to reachable values: {ve:.2f} / {vx:.2f} mm/s"
        return fig, note

    return interact_figure(show,
                         length_mm=w.FloatLogSlider(value=2.0, base=10, min=-2, max=1.5, step=0.05,
                                                    description="block length (mm)", style=_WIDE),
                         cap_mm_s=w.FloatSlider(value=25.0, min=1, max=25.7, step=0.5,
                                                description="speed cap (mm/s)", style=_WIDE),
                         entry_mm_s=w.FloatSlider(value=0.5, min=0.05, max=25.0, step=0.25,
                                                  description="entry speed (mm/s)", style=_WIDE),
                         exit_mm_s=w.FloatSlider(value=0.5, min=0.05, max=25.0, step=0.25,
                                                 description="exit speed (mm/s)", style=_WIDE),
                         up=w.IntSlider(value=40, min=5, max=200, description="ramp up (Hz/step)", style=_WIDE),
                         down=w.IntSlider(value=40, min=5, max=200, description="ramp down (Hz/step)", style=_WIDE),
                         law=w.ToggleButtons(options=["linear", "accel"], description="ramp law", style=_WIDE))


def lookahead_explorer(make_moves, machine=None):
    """Widget: planner, buffer depth and ramp law on a job made by ``make_moves(rows, segments)``."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    def show(rows, segments, buffer_blocks, law):
        moves = make_moves(rows, segments)
        table, plans = compare_planners(moves, machine, buffer_blocks=buffer_blocks,
                                        law=None if law == "each its own" else law)
        fig, ax = plt.subplots(figsize=(10, 3.6))
        for p in plans.values():
            plot_speed_time(p, ax)
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))   # beside the data
        fig.tight_layout()
        return fig, table.to_string()

    return interact_figure(show, rows=w.IntSlider(value=4, min=1, max=12, description="raster rows", style=_WIDE),
                         segments=w.IntSlider(value=4, min=1, max=12, description="power steps per row",
                                              style=_WIDE),
                         buffer_blocks=w.IntSlider(value=16, min=1, max=64, description="planner buffer (blocks)",
                                                   style=_WIDE),
                         law=w.ToggleButtons(options=["each its own", "linear", "accel"], description="ramp law",
                                             style=_WIDE))


def laser_explorer(make_moves, machine=None):
    """Widget: power, feed, laser mode, planner and corner loops on a job made by
    ``make_moves(s_word, feed_mm_min, mode)``; power and dose along the burned path."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.motion import load_machine, plan
    from labkit.motion.power import dose_uniformity
    from labkit.toolpath.corners import add_corner_loops

    m = load_machine(machine)

    def show(s_word, feed_mm_min, mode, planner, loops):
        moves = make_moves(s_word, feed_mm_min, 3 if mode == "M3 constant" else 4)
        if loops:
            moves, _ = add_corner_loops(moves, accel_mm_s2=min(m.accel_mm_s2))
        p = plan(moves, m, planner=planner)
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 3.6))
        plot_power_time(p, a1)
        a1.set_title(f"power against time ({p.job_time_s:.2f} s)")
        plot_burn(p, a2)
        # A fixed logarithmic dose axis: moving a slider must show a 10x change as one, not rescale it away.
        a2.set_yscale("log")
        a2.set_ylim(*_DOSE_RANGE_MJ_PER_MM)
        bp = p.burn_profile(0.01)
        u = dose_uniformity(bp["dose_mj_per_mm"], bp["speed_mm_s"], bp["feed_mm_s"])
        a2.set_title(f"dose along the cut: CV {u['cv']:.3f}, max/mean {u['max_over_mean']:.2f}")
        fig.tight_layout()
        return fig

    return interact_figure(show, s_word=w.IntSlider(value=500, min=50, max=1000, step=50,
                                                     description="power (S of 1000)", style=_WIDE),
                         feed_mm_min=w.IntSlider(value=1200, min=120, max=1500, step=60,
                                                 description="feed (mm/min)", style=_WIDE),
                         mode=w.ToggleButtons(options=["M3 constant", "M4 dynamic"], description="laser mode",
                                              style=_WIDE),
                         planner=w.ToggleButtons(options=["junction", "normal", "fast", "hq"], description="planner",
                                                 style=_WIDE),
                         loops=w.Checkbox(value=False, description="corner loops"))
